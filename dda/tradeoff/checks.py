"""Every setting of a study checked before any run: its scene as the run will read it.

A grid value can pass the grid's own syntax (a finite positive number) and still be
one the scene refuses: a ratio g2 of 2, a penalty that overflows once multiplied by
Young's modulus, a time step so short that the run exceeds ``analysis.max_steps``.
:func:`check_settings` builds each setting's scene dict (:meth:`Case.scene`) and
passes it through the checks the run itself makes (:func:`dda.load_scene` and
:func:`dda.scene.limits.check_run_size`), in the client, so that such a value is
refused at once with one line naming the grid key and value, before the plan is
printed or any worker starts.
"""

from __future__ import annotations

import dda
from dda.scene.limits import check_run_size, estimated_steps
from dda.tradeoff.cases import Case
from dda.tradeoff.grid import KEYS, Setting, value_text

# the scene key each grid key sets (Case.scene), and the keys a grid key decides
# through the run's size (the steps a duration takes at the setting's time step)
SCENE_KEYS = {
    "contact.method": "method",
    "contact.penalty": "penalty",
    "contact.tolerance": "tolerance",
    "analysis.time_step": "time_step",
    "analysis.duration": "time_step",
    "analysis.max_displacement_ratio": "ratio",
}


class GridError(ValueError):
    """A setting of the grid whose scene is refused: ``str(exc)`` names the grid key and
    value (or the whole setting), the scene's key and the reason."""


def check_settings(
    case: Case, settings: list[Setting], fine: Setting | None = None
) -> tuple[int, Setting] | None:
    """Load the scene of every setting (and of the ``fine`` reference run) as its run will;
    return the most steps a run takes and its setting (None without settings).

    Raises
    ------
    GridError
        At the first setting whose scene :func:`dda.load_scene` or the run's size
        check refuses.
    """
    runs = [(_check(case, setting, fine=False), setting) for setting in settings]
    if fine is not None:
        runs.append((_check(case, fine, fine=True), fine))
    return max(runs, key=lambda run: run[0], default=None)


def _check(case: Case, setting: Setting, fine: bool) -> int:
    """Refuse ``setting`` of ``case`` (``fine``: the reference run the grid's extremes make);
    else its run's steps."""
    try:
        scene = dda.load_scene(case.scene(setting))
        check_run_size(scene)
        return estimated_steps(scene)
    except dda.SceneError as exc:
        said = _named(setting, exc.key, fine)
        raise GridError(f"{said}: {exc.key}: {exc.reason}") from None


def _named(setting: Setting, scene_key: str, fine: bool) -> str:
    """``--grid time_step=1e-300`` for the grid key that set ``scene_key``, ``--grid
    time_step: the fine reference run's time_step=2.5e-9`` for the reference run made from
    the grid's values; else the whole setting (the grid key is then not known)."""
    key = SCENE_KEYS.get(scene_key)
    if key is None:
        values = "; ".join(f"{k}={value_text(getattr(setting, k))}" for k in KEYS)
        return f"--grid: the fine reference run's {values}" if fine else f"--grid {values}"
    value = f"{key}={value_text(getattr(setting, key))}"
    return f"--grid {key}: the fine reference run's {value}" if fine else f"--grid {value}"
