"""The settings a trade-off study sweeps, and the grid specification syntax.

A grid is written ``key=v1,v2;key=v1,...`` with the keys

* ``method``: ``augmented-lagrangian`` (``al``) and/or ``penalty``;
* ``penalty``: initial penalty as a multiple of the largest Young's modulus;
* ``tolerance``: AL tolerance as a fraction of the model size (ignored by the
  penalty method, which runs once per other combination);
* ``time_step``: the maximum time step, in the case's time unit;
* ``ratio``: the maximum displacement ratio g2.

Every combination is one setting (a Cartesian product), run ``--repeats`` times.
A key the specification does not give sweeps every value of the case's default
grid (:data:`DEFAULT_GRIDS`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass

ALIASES = {
    "al": "augmented-lagrangian",
    "augmented-lagrangian": "augmented-lagrangian",
    "penalty": "penalty",
}
KEYS = ("method", "penalty", "tolerance", "time_step", "ratio")
SCENE_FILE = "scene file"  # any case that is not built in: its grid takes its time step


def _sweep(penalty: list, time_step: list, ratio: list, tolerance: list | None = None) -> dict:
    """A default grid: both methods and the AL tolerances (1e-4, 1e-6), plus these."""
    return {
        "method": ["augmented-lagrangian", "penalty"],
        "penalty": penalty,
        "tolerance": tolerance or [1e-4, 1e-6],
        "time_step": time_step,
        "ratio": ratio,
    }


# every case's default grid; a scene file's time step is its own (see default_grid)
DEFAULT_GRIDS = {
    "sliding_block": _sweep([0.1, 1.0, 10.0], [0.02, 0.01, 0.005], [0.01, 0.002]),
    "pushed_block": _sweep([1e-4, 1e-2, 1.0, 10.0], [0.02, 0.01, 0.005], [0.01]),
    # no contact: one method, penalty and tolerance (they change nothing)
    "pendulum": {
        "method": ["penalty"],
        "penalty": [10.0],
        "tolerance": [1e-6],
        "time_step": [1e-2, 3e-3, 1e-3, 3e-4, 1e-4],
        "ratio": [0.5, 0.01],
    },
    "stack": _sweep([0.1, 1.0, 10.0], [0.004, 0.002, 0.001], [0.01, 0.002]),
    "wall": _sweep([50.0], [1e-3, 5e-4], [0.01], tolerance=[1e-3, 1e-4, 1e-5]),
    SCENE_FILE: _sweep([1.0, 10.0], [], [0.01]),
}


@dataclass(frozen=True)
class Setting:
    """One point of the grid (see the module docstring for the units)."""

    method: str
    penalty: float
    tolerance: float
    time_step: float
    ratio: float

    def as_dict(self) -> dict:
        return asdict(self)

    @property
    def label(self) -> str:
        tol = f" tol={self.tolerance:g}" if self.method != "penalty" else ""
        return f"{self.method} p={self.penalty:g}E{tol} dt={self.time_step:g} g2={self.ratio:g}"


def default_grid(case: str, time_step: float | None = None) -> dict[str, list]:
    """A copy of ``DEFAULT_GRIDS[case]``; a scene file's sweeps ``time_step``, its own."""
    grid = {key: list(values) for key, values in DEFAULT_GRIDS[case].items()}
    if case == SCENE_FILE:
        grid["time_step"] = [time_step]
    return grid


def spec(grid: dict[str, list]) -> str:
    """``grid`` in the specification syntax: ``"method=al,penalty; penalty=1,10; ..."``."""
    short = {name: alias for alias, name in ALIASES.items() if len(alias) < len(name)}
    words = {
        key: [short.get(v, v) if key == "method" else value_text(v) for v in grid[key]]
        for key in KEYS
    }
    return "; ".join(f"{key}={','.join(words[key])}" for key in KEYS)


def value_text(value: float | str) -> str:
    """``1e-4`` and ``5e-4`` as written so; ``0.01`` and ``10`` too; words as they are."""
    if isinstance(value, str):
        return value
    if 0 < abs(value) < 1e-3:
        mantissa, _, exponent = f"{value:.12e}".partition("e")
        return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"
    return f"{value:g}"


def given_keys(text: str) -> list[str]:
    """The keys a specification gives, in :data:`KEYS` order (unchecked: see parse_grid)."""
    named = {part.partition("=")[0].strip() for part in text.split(";")}
    return [key for key in KEYS if key in named]


def parse_grid(text: str, defaults: dict[str, list] | None = None) -> dict[str, list]:
    """``"method=al,penalty;time_step=0.01,0.005"`` -> {key: values}, defaults filled in.

    Raises
    ------
    ValueError
        For an unknown key, method or a value that is not a finite positive number (below
        1 for a fraction of the model size)
        (whether the scene takes it is :func:`dda.tradeoff.checks.check_settings`'s).
    """
    values = {k: list(v) for k, v in (defaults or {}).items()}
    given: set[str] = set()
    for part in filter(None, (p.strip() for p in text.split(";"))):
        key, _, items = part.partition("=")
        key = key.strip()
        if key not in KEYS:
            raise ValueError(f"unknown grid key {key!r}; expected one of {', '.join(KEYS)}")
        if key in given:  # the second list silently replaced the first
            raise ValueError(f"grid key {key!r} is given twice: give its values in one list")
        given.add(key)
        words = [w.strip() for w in items.split(",") if w.strip()]
        if not words:
            raise ValueError(f"grid key {key!r} has no values")
        values[key] = (
            [_method(w) for w in words] if key == "method" else [_positive(w, key) for w in words]
        )
    missing = [k for k in KEYS if k not in values]
    if missing:
        raise ValueError(f"grid lacks {', '.join(missing)}")
    return values


def _method(word: str) -> str:
    if word not in ALIASES:
        raise ValueError(f"unknown contact method {word!r}; expected al or penalty")
    return ALIASES[word]


# grid keys that are fractions of the model size, below 1: an AL tolerance of the model's
# size lets blocks pass through each other (a scene takes any positive length)
FRACTIONS = ("tolerance",)


def _positive(word: str, key: str) -> float:
    """``word`` as a finite number above zero (inf and nan are refused: no run takes them),
    below 1 for a fraction of the model size (:data:`FRACTIONS`)."""
    try:
        value = float(word)
    except ValueError:
        raise ValueError(f"grid key {key!r}: {word!r} is not a number") from None
    if not 0 < value < math.inf:
        raise ValueError(f"grid key {key!r}: {word!r} must be a finite positive number")
    if key in FRACTIONS and value >= 1.0:
        raise ValueError(
            f"grid key {key!r}: {word!r} must be below 1 (a fraction of the model size)"
        )
    return value


def expand(grid: dict[str, list]) -> list[Setting]:
    """Every combination, once; the penalty method ignores the tolerance."""
    seen, out = set(), []
    for method, p, tol, dt, ratio in itertools.product(*(grid[k] for k in KEYS)):
        if method == "penalty":
            tol = grid["tolerance"][0]
        setting = Setting(method, float(p), float(tol), float(dt), float(ratio))
        if setting not in seen:
            seen.add(setting)
            out.append(setting)
    return out
