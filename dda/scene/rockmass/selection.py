"""Pick cut blocks by rules: for ``[[fix]]`` entries and ``[groups.NAME]`` tables."""

from __future__ import annotations

import numpy as np
import shapely

from dda.errors import SceneError
from dda.geometry import next_vertex_index, owner_of_vertex
from dda.scene.rockmass.spec import Selector


def select_blocks(
    selector: Selector,
    names: list[str],
    materials: list[str],
    centroids: np.ndarray,
    vertices: np.ndarray,
    offsets: np.ndarray,
    bounds: tuple[float, float, float, float],
    tolerance: float,
    source: str,
) -> np.ndarray:
    """Boolean mask of the blocks meeting every rule of ``selector``; refuse an empty one."""
    mask = np.ones(len(names), dtype=bool)
    if selector.polygon is not None:
        shapely.prepare(selector.polygon)
        mask &= shapely.contains_xy(selector.polygon, centroids[:, 0], centroids[:, 1])
    if selector.inside is not None:
        mask &= blocks_inside(vertices, offsets, selector.inside, tolerance)
    if selector.touching is not None:
        line = shapely.LineString(selector.touching)
        mask &= edges_along(vertices, offsets, line, tolerance)
    if selector.sides:
        lines = [_side(bounds, s) for s in selector.sides]
        mask &= edges_along(vertices, offsets, shapely.MultiLineString(lines), tolerance)
    if selector.material is not None:
        mask &= np.array([m == selector.material for m in materials], dtype=bool)
    if selector.blocks is not None:
        mask &= np.isin(np.array(names, dtype=object), np.array(selector.blocks, dtype=object))
    if not mask.any():
        raise SceneError(source, selector.key, "selects no block")
    return mask


def blocks_inside(
    vertices: np.ndarray, offsets: np.ndarray, polygon: shapely.Polygon, tolerance: float
) -> np.ndarray:
    """True for blocks that lie inside ``polygon`` grown by ``tolerance`` (all of them,
    not only their centroid: a block bent around an opening has its centroid in it)."""
    rings = shapely.linearrings(vertices, indices=owner_of_vertex(offsets))
    grown = shapely.buffer(polygon, tolerance, join_style="mitre")
    shapely.prepare(grown)
    return shapely.covers(grown, shapely.polygons(rings))


def edges_along(
    vertices: np.ndarray, offsets: np.ndarray, line: shapely.Geometry, tolerance: float
) -> np.ndarray:
    """True for blocks with an edge lying on ``line`` (both ends and middle within tolerance)."""
    shapely.prepare(line)
    end = vertices[next_vertex_index(offsets)]
    near = [
        shapely.dwithin(line, shapely.points(p), tolerance)
        for p in (vertices, end, 0.5 * (vertices + end))
    ]
    on_line = near[0] & near[1] & near[2]
    hits = np.bincount(owner_of_vertex(offsets), weights=on_line, minlength=len(offsets) - 1)
    return hits > 0


def _side(bounds: tuple[float, float, float, float], side: str) -> shapely.LineString:
    x0, y0, x1, y1 = bounds
    ends = {
        "bottom": [(x0, y0), (x1, y0)],
        "top": [(x0, y1), (x1, y1)],
        "left": [(x0, y0), (x0, y1)],
        "right": [(x1, y0), (x1, y1)],
    }
    return shapely.LineString(ends[side])


def check_names(selector_key: str, names: tuple[str, ...], known: set[str], source: str) -> None:
    """Refuse block names that are not in the scene."""
    for i, name in enumerate(names):
        if name not in known:
            raise SceneError(source, f"{selector_key}[{i}]", f"unknown block {name!r}")
