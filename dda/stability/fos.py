"""The factor of safety of a scene by strength reduction, as one call.

``factor_of_safety(scene)`` checks the scene, then runs the search of
:mod:`dda.stability.search` with the trials of :mod:`dda.stability.trial` on the
given :class:`dda.parallel.Workers` (this process by default). ``dda fos`` adds the
stored rows, the progress lines and the pictures.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import dda
from dda.parallel import Workers
from dda.scene import read_scene_file
from dda.stability.criterion import criterion_of
from dda.stability.search import Outcome, search
from dda.stability.strength_reduction import reducible
from dda.stability.trial import Trial, run_trial


def check_reducible(scene: dda.Scene) -> None:
    """Raise ``dda.SceneError`` (key ``joints``) when no strength can be reduced."""
    if not reducible(scene, scene.fos.intact):
        raise dda.SceneError(
            scene.source,
            "joints",
            "nothing can fail by strength reduction: no joint has friction, cohesion or "
            "tensile strength"
            + (
                "" if scene.fos.intact else " ([fos] intact also reduces breakable materials)"
            ),  # fmt: skip
        )


def factor_of_safety(
    scene: Mapping[str, Any] | str | Path,
    workers: Workers | None = None,
    on_row: Callable[[dict], None] | None = None,
) -> tuple[Outcome, list[dict]]:
    """The factor of safety of ``scene`` (a raw dict or a scene file) and every trial's row.

    Raises
    ------
    dda.SceneError
        For a scene that cannot be searched (refused, static, no gravity and no
        ``[fos] velocity``, nothing to reduce).
    """
    source = "<dict>"
    if not isinstance(scene, Mapping):
        source, scene = str(scene), read_scene_file(scene)
    raw = dict(scene)
    loaded = dda.load_scene(raw, source)
    criterion_of(loaded)
    check_reducible(loaded)
    rows: list[dict] = []
    pool = workers or Workers(None)

    def run(factors: list[float]):
        trials = [Trial(raw, f, source, keep_frame=False) for f in factors]
        for row in pool.map_unordered(run_trial, trials):
            rows.append(row)
            if on_row is not None:
                on_row(row)
            yield row["factor"], row["failed"]

    fos = loaded.fos
    return search(run, fos.lower, fos.upper, fos.tolerance, pool.size), rows
