"""Small validators for rock-mass scene values; each error names its dotted key."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import shapely

from dda.errors import SceneError


def check_table(source: str, key: str, value: Any, allowed: set[str]) -> Mapping[str, Any]:
    """Return ``value`` if it is a table whose keys are all in ``allowed``."""
    if not isinstance(value, Mapping):
        raise SceneError(source, key, f"must be a table, got {type(value).__name__}")
    for name in value:
        if name not in allowed:
            known = ", ".join(sorted(allowed))
            raise SceneError(source, f"{key}.{name}", f"unknown key (known: {known})")
    return value


def check_list(source: str, key: str, value: Any) -> list:
    """Return ``value`` if it is a list (an array or an array of tables)."""
    if not isinstance(value, list):
        raise SceneError(source, key, f"must be a list, got {type(value).__name__}")
    return value


def number(
    source: str,
    key: str,
    value: Any,
    *,
    positive: bool = False,
    non_negative: bool = False,
) -> float:
    """A finite real number, optionally > 0 or >= 0."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(source, key, f"must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise SceneError(source, key, f"must be finite, got {x}")
    if positive and x <= 0.0:
        raise SceneError(source, key, f"must be > 0, got {x:g}")
    if non_negative and x < 0.0:
        raise SceneError(source, key, f"must be >= 0, got {x:g}")
    return x


def integer(source: str, key: str, value: Any, *, minimum: int | None = None) -> int:
    """An integer, optionally at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(source, key, f"must be an integer, got {value!r}")
    if minimum is not None and value < minimum:
        raise SceneError(source, key, f"must be >= {minimum}, got {value}")
    return value


def text(source: str, key: str, value: Any, *, choices: tuple[str, ...] = ()) -> str:
    """A string, optionally one of ``choices``."""
    if not isinstance(value, str):
        raise SceneError(source, key, f"must be a string, got {value!r}")
    if choices and value not in choices:
        raise SceneError(source, key, f"must be one of {', '.join(choices)}; got {value!r}")
    return value


def point(source: str, key: str, value: Any) -> tuple[float, float]:
    """An ``[x, y]`` pair of finite numbers."""
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise SceneError(source, key, f"must be a point [x, y], got {value!r}")
    return number(source, key, value[0]), number(source, key, value[1])


def points(source: str, key: str, value: Any, *, minimum: int) -> np.ndarray:
    """A list of at least ``minimum`` points, as an (n, 2) array."""
    check_list(source, key, value)
    if len(value) < minimum:
        raise SceneError(source, key, f"needs at least {minimum} points, got {len(value)}")
    return np.array([point(source, f"{key}[{i}]", p) for i, p in enumerate(value)])


def simple_polygon(source: str, key: str, value: Any) -> shapely.Polygon:
    """A polygon from a vertex list: at least three points, a simple ring, non-zero area.

    A closing vertex equal to the first one is accepted and dropped.
    """
    xy = points(source, key, value, minimum=3)
    if len(xy) > 3 and np.array_equal(xy[0], xy[-1]):
        xy = xy[:-1]
    ring = shapely.LinearRing(xy)
    if not shapely.is_simple(ring):
        raise SceneError(source, key, "self-intersecting boundary (edges cross or touch)")
    polygon = shapely.Polygon(ring)
    if not polygon.is_valid or polygon.area <= 0.0:
        raise SceneError(source, key, f"not a valid polygon ({shapely.is_valid_reason(polygon)})")
    return polygon
