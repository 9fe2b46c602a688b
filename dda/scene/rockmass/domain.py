"""The rock to cut: regions minus excavations, with the checks that need all of it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from dda.errors import SceneError
from dda.scene.rockmass.spec import RockMass

OVERLAP_TOLERANCE = 1e-9  # relative area that counts as an overlap


@dataclass(frozen=True)
class Domain:
    """The rock: one (possibly multi-part) geometry per region, excavations removed.

    Attributes
    ----------
    parts : geometry of each region after the excavations are removed
    materials : material of each region
    rock : union of all parts
    size : diagonal of the rock's bounding box (the length scale of tolerances)
    """

    parts: tuple[shapely.Geometry, ...]
    materials: tuple[str, ...]
    rock: shapely.Geometry

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return tuple(self.rock.bounds)

    @property
    def size(self) -> float:
        x0, y0, x1, y1 = self.bounds
        return float(np.hypot(x1 - x0, y1 - y0))


def build_domain(mass: RockMass, source: str) -> Domain:
    """Regions minus excavations; refuse overlapping regions and stray excavations."""
    polygons = [r.polygon for r in mass.regions]
    _check_overlaps(polygons, [r.key for r in mass.regions], source)
    whole = shapely.union_all(polygons)
    for ex in mass.excavations:
        if ex.polygon.intersection(whole).area <= OVERLAP_TOLERANCE * ex.polygon.area:
            raise SceneError(source, ex.key, "lies outside the rock (it removes nothing)")
    removed = shapely.union_all([ex.polygon for ex in mass.excavations])
    parts = tuple(shapely.difference(polygons, removed)) if mass.excavations else tuple(polygons)
    rock = shapely.union_all(parts)
    if rock.is_empty or rock.area <= OVERLAP_TOLERANCE * whole.area:
        raise SceneError(source, "excavations", "remove all the rock")
    return Domain(parts=parts, materials=tuple(r.material for r in mass.regions), rock=rock)


def _check_overlaps(polygons: list[shapely.Polygon], keys: list[str], source: str) -> None:
    if len(polygons) < 2:
        return
    tree = shapely.STRtree(polygons)
    left, right = tree.query(polygons, predicate="intersects")
    pairs = left < right
    left, right = left[pairs], right[pairs]
    if len(left) == 0:
        return
    geoms = np.asarray(polygons, dtype=object)
    shared = shapely.area(shapely.intersection(geoms[left], geoms[right]))
    scale = np.minimum(shapely.area(geoms[left]), shapely.area(geoms[right]))
    bad = np.flatnonzero(shared > OVERLAP_TOLERANCE * scale)
    if len(bad):
        k = bad[np.argmax(shared[bad])]  # the largest overlap
        i, j = left[k], right[k]
        said = f"overlaps {keys[i]} by {overlap_said(geoms[i], geoms[j])} (regions must not)"
        raise SceneError(source, f"{keys[j]}.polygon", said)


def overlap_said(a: shapely.Geometry, b: shapely.Geometry) -> str:
    """``"25 of area near (7.5, 7.5)"``: how much two shapes overlap, and where."""
    common = shapely.intersection(a, b)
    x, y = shapely.get_coordinates(shapely.point_on_surface(common))[0]
    return f"{common.area:.3g} of area near ({x:.6g}, {y:.6g})"
