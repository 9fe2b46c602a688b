"""The settings a trade-off study sweeps, and the grid specification syntax.

A grid is written ``key=v1,v2;key=v1,...`` with the keys

* ``method``: ``augmented-lagrangian`` (``al``) and/or ``penalty``;
* ``penalty``: initial penalty as a multiple of the largest Young's modulus;
* ``tolerance``: AL tolerance as a fraction of the model size (ignored by the
  penalty method, which runs once per other combination);
* ``time_step``: the maximum time step, in the case's time unit;
* ``ratio``: the maximum displacement ratio g2.

Every combination is one run (a Cartesian product).
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass

ALIASES = {
    "al": "augmented-lagrangian",
    "augmented-lagrangian": "augmented-lagrangian",
    "penalty": "penalty",
}
KEYS = ("method", "penalty", "tolerance", "time_step", "ratio")


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


def parse_grid(text: str, defaults: dict[str, list] | None = None) -> dict[str, list]:
    """``"method=al,penalty;time_step=0.01,0.005"`` -> {key: values}, defaults filled in.

    Raises
    ------
    ValueError
        For an unknown key, method or a value that is not a positive number.
    """
    values = {k: list(v) for k, v in (defaults or {}).items()}
    for part in filter(None, (p.strip() for p in text.split(";"))):
        key, _, items = part.partition("=")
        key = key.strip()
        if key not in KEYS:
            raise ValueError(f"unknown grid key {key!r}; expected one of {', '.join(KEYS)}")
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


def _positive(word: str, key: str) -> float:
    try:
        value = float(word)
    except ValueError:
        raise ValueError(f"grid key {key!r}: {word!r} is not a number") from None
    if not value > 0:
        raise ValueError(f"grid key {key!r}: {word!r} must be positive")
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
