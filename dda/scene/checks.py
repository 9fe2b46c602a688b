"""The scene validator: type, range and name checks of raw values.

Every check of :class:`Checker` returns the converted value or raises
:class:`dda.errors.SceneError` naming the source, the dotted key
(``blocks[2].vertices``) and the reason, with a "did you mean" hint for
near misses. :mod:`dda.scene` checks the block scene with it and
:mod:`dda.scene.rockmass.parse` the rock-mass keys.
"""

from __future__ import annotations

import difflib
import math
import numbers
import reprlib
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any, NamedTuple, NoReturn

import numpy as np
import shapely

from dda.errors import SceneError

Point = tuple[float, float]


class Interval(NamedTuple):
    """A range of allowed real values, for checks and messages."""

    low: float = -math.inf
    high: float = math.inf
    low_closed: bool = False
    high_closed: bool = False

    def holds(self, x: float) -> bool:
        above = x >= self.low if self.low_closed else x > self.low
        below = x <= self.high if self.high_closed else x < self.high
        return above and below

    def describe(self) -> str:
        if self.high == math.inf:
            return f"{'>=' if self.low_closed else '>'} {self.low:g}"
        left = "[" if self.low_closed else "("
        right = "]" if self.high_closed else ")"
        return f"in {left}{self.low:g}, {self.high:g}{right}"


ANY = Interval()
# positions (block vertices, fixed points, load points) beyond this are refused: they
# leave no precision for contacts, and squares of them overflow in the geometry checks
MAX_COORDINATE = 1e15
POSITIVE = Interval(0.0)
NON_NEGATIVE = Interval(0.0, low_closed=True)
POISSON = Interval(-1.0, 0.5)
ANGLE = Interval(0.0, 90.0, low_closed=True)
OPEN_UNIT = Interval(0.0, 1.0)

_KINDS = {
    bool: "a boolean",
    np.bool_: "a boolean",
    str: "a string",
    Mapping: "a table",
    list: "a list",
    tuple: "a list",
}


def value_kind(value: object) -> str:
    """Plain-words type of a value for messages."""
    for cls, words in _KINDS.items():
        if isinstance(value, cls):
            return words
    if isinstance(value, numbers.Number):
        return f"the number {reprlib.repr(value)}"
    return f"a {type(value).__name__}"


def _plain_points(items: Sequence[Any]) -> tuple[Point, ...] | None:
    """Fast path: pairs of plain finite floats or ints, else None (check in detail)."""
    plain = (float, int)
    for p in items:
        if type(p) not in (list, tuple) or len(p) != 2:
            return None
        if type(p[0]) not in plain or type(p[1]) not in plain:
            return None
    try:
        array = np.array(items, dtype=float).reshape(-1, 2)
    except OverflowError:
        return None
    if not np.isfinite(array).all():
        return None
    return tuple(map(tuple, array.tolist()))


def join_key(prefix: str, name: object) -> str:
    """Dotted key of ``name`` inside the table at ``prefix``."""
    text = str(name) if name != "" else '""'
    return f"{prefix}.{text}" if prefix else text


def suggest(word: str, options: Collection[str]) -> str:
    """A "did you mean" hint for a near miss, or the list of options."""
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    if close:
        return f"did you mean {close[0]!r}?"
    if len(options) <= 12:
        return "expected one of " + ", ".join(repr(o) for o in sorted(options))
    return "no similar name"


# keys that earlier versions read and this one refuses, with the reason
RETIRED = {
    "contact.state_band": "no longer used: each step's contact problem is solved to "
    "convergence, with no state band (docs/contact.md); remove the key",
}


@dataclass(frozen=True)
class Checker:
    """Type and range checks of raw values; every failure is a SceneError."""

    source: str

    def fail(self, key: str, reason: str) -> NoReturn:
        raise SceneError(self.source, key, reason)

    def table(self, value: object, key: str, allowed: Collection[str]) -> Mapping[str, Any]:
        """A mapping whose keys are all in ``allowed``."""
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {value_kind(value)}")
        for name in value:
            if join_key(key, name) in RETIRED:
                self.fail(join_key(key, name), RETIRED[join_key(key, name)])
            if name not in allowed:
                self.fail(join_key(key, name), "unknown key; " + suggest(str(name), allowed))
        return value

    def named_tables(self, value: object, key: str) -> Mapping[str, Any]:
        """A mapping of user-chosen, non-empty string names."""
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {value_kind(value)}")
        for name in value:
            if not isinstance(name, str) or not name:
                self.fail(join_key(key, name), "names must be non-empty strings")
        return value

    def sequence(self, value: object, key: str) -> Sequence[Any]:
        """A list (or tuple, or 1-D+ numpy array)."""
        if isinstance(value, list | tuple):
            return value
        if isinstance(value, np.ndarray) and value.ndim >= 1:
            return value
        self.fail(key, f"expected a list, got {value_kind(value)}")

    def listed(self, value: object, key: str) -> Sequence[Any]:
        """A list that is not empty: a key whose empty list would do nothing (stage
        changes, moving or watched blocks) is refused rather than ignored."""
        items = self.sequence(value, key)
        if len(items) == 0:
            self.fail(key, "is empty: list at least one (an empty list would do nothing)")
        return items

    def real(self, value: object, key: str, interval: Interval = ANY) -> float:
        """A finite real number (not a boolean) inside ``interval``."""
        if type(value) is not float:
            if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
                self.fail(key, f"expected a number, got {value_kind(value)}")
            try:
                value = float(value)
            except OverflowError:
                self.fail(key, "number too large")
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        if not interval.holds(value):
            self.fail(key, f"must be {interval.describe()}, got {value:g}")
        return value

    def count(self, value: object, key: str) -> int:
        """A positive integer (not a boolean, not a float)."""
        return self.integer(value, key, minimum=1)

    def integer(self, value: object, key: str, minimum: int = 0) -> int:
        """An integer (not a boolean, not a float) of at least ``minimum``."""
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
            self.fail(key, f"expected an integer, got {value_kind(value)}")
        if value < minimum:
            words = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
            self.fail(key, f"must be {words}, got {value}")
        return int(value)

    def boolean(self, value: object, key: str) -> bool:
        if not isinstance(value, bool | np.bool_):
            self.fail(key, f"expected true or false, got {value_kind(value)}")
        return bool(value)

    def text(self, value: object, key: str) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {value_kind(value)}")
        return value

    def choice(self, value: object, key: str, options: tuple[str, ...]) -> str:
        """One of ``options``, with a near-miss hint otherwise."""
        word = self.text(value, key)
        if word not in options:
            self.fail(key, f"unknown value {word!r}; " + suggest(word, options))
        return word

    def vector(self, value: object, key: str, size: int) -> tuple[float, ...]:
        """A list of exactly ``size`` finite numbers."""
        items = self.sequence(value, key)
        if len(items) != size:
            self.fail(key, f"expected {size} numbers, got {len(items)}")
        return tuple(self.real(x, f"{key}[{k}]") for k, x in enumerate(items))

    def points(self, value: object, key: str, min_count: int = 0) -> tuple[Point, ...]:
        """A list of [x, y] pairs, at least ``min_count`` of them."""
        items = self.sequence(value, key)
        if len(items) < min_count:
            self.fail(key, f"expected at least {min_count} pairs, got {len(items)}")
        plain = _plain_points(items)
        if plain is not None:
            return plain
        return tuple(self.vector(p, f"{key}[{k}]", 2) for k, p in enumerate(items))

    def positions(self, value: object, key: str, min_count: int = 0) -> tuple[Point, ...]:
        """:meth:`points` within ±``MAX_COORDINATE``."""
        pairs = self.points(value, key, min_count)
        for k, pair in enumerate(pairs):
            self.bounded(pair, f"{key}[{k}]")
        return pairs

    def position(self, value: object, key: str) -> tuple[float, ...]:
        """One [x, y] within ±``MAX_COORDINATE``."""
        return self.bounded(self.vector(value, key, 2), key)

    def bounded(self, pair: tuple[float, ...], key: str) -> tuple[float, ...]:
        """``pair`` itself, refused when a coordinate lies beyond ±``MAX_COORDINATE``."""
        if max(abs(pair[0]), abs(pair[1])) > MAX_COORDINATE:
            self.fail(
                key,
                f"{list(pair)} lies beyond ±{MAX_COORDINATE:g}: a model this large keeps no "
                "precision for its contacts (use a length unit that fits)",
            )
        return pair

    def simple_polygon(self, value: object, key: str) -> shapely.Polygon:
        """A polygon from a vertex list: three points or more, a simple ring, non-zero area.

        A closing vertex equal to the first one is accepted and dropped.
        """
        xy = np.array(self.positions(value, key, min_count=3))
        if len(xy) > 3 and np.array_equal(xy[0], xy[-1]):
            xy = xy[:-1]
        ring = shapely.LinearRing(xy)
        if shapely.Polygon(ring).area == 0.0 and _on_one_line(xy):  # a line folds onto itself
            self.fail(key, "encloses no area (its points lie on one line)")
        if not shapely.is_simple(ring):
            self.fail(key, "self-intersecting boundary (edges cross or touch)")
        polygon = shapely.Polygon(ring)
        if not polygon.is_valid or polygon.area <= 0.0:
            self.fail(key, f"not a valid polygon ({shapely.is_valid_reason(polygon)})")
        return polygon

    def known(self, value: object, key: str, names: Collection[str], what: str) -> str:
        """The name of an existing ``what`` (material, joint, block)."""
        name = self.text(value, key)
        if name not in names:
            hint = suggest(name, names) if names else f"the scene defines no {what}"
            self.fail(key, f"unknown {what} {name!r}; {hint}")
        return name


def _on_one_line(xy: np.ndarray) -> bool:
    """Whether every point lies on the line through the first and the farthest from it
    (a bow-tie whose halves cancel has no area either, but crosses itself)."""
    far = xy[np.argmax(np.hypot(*(xy - xy[0]).T))] - xy[0]
    cross = far[0] * (xy[:, 1] - xy[0, 1]) - far[1] * (xy[:, 0] - xy[0, 0])
    return bool(np.all(np.abs(cross) <= 1e-12 * float(np.dot(far, far))))


Spec = Callable[[Checker, Any, str], Any]


def real(interval: Interval = ANY) -> Spec:
    return partial(Checker.real, interval=interval)


def choice(*options: str) -> Spec:
    return partial(Checker.choice, options=options)


def vector(size: int) -> Spec:
    return partial(Checker.vector, size=size)


def checked_fields(chk: Checker, value: object, key: str, specs: Mapping[str, Spec]) -> dict:
    """Check a table against per-key specs; return the converted values given."""
    table = chk.table(value, key, specs)
    return {name: specs[name](chk, item, join_key(key, name)) for name, item in table.items()}


def require(chk: Checker, values: Mapping[str, Any], key: str, names: Sequence[str]) -> None:
    for name in names:
        if name not in values:
            chk.fail(join_key(key, name), "is required")


def table_list(chk: Checker, raw: Mapping[str, Any], key: str) -> Sequence[Any]:
    """An optional array of tables (``[[blocks]]`` etc.), empty when absent."""
    return chk.sequence(raw.get(key, []), key)
