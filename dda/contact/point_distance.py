"""Distances from points to block polygons: to the boundary, and to the block (0 inside).

The contact pipeline asks both for every candidate pairing it checks (tens of
thousands per step at 10,000 blocks). A compiled loop over each block's edges
(segment distance, crossing-number inside test) does it without building
shapely geometries; shapely is the fallback without numba and the reference
the tests compare with.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.jit import compiled, kernel


def block_polygons(blocks: BlockSet, rows: np.ndarray) -> np.ndarray:
    """shapely polygons of the given block rows (no Python loop over blocks)."""
    starts = blocks.offsets[rows]
    counts = blocks.offsets[rows + 1] - starts
    ring = np.repeat(np.arange(len(rows)), counts)
    take = starts[ring] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return shapely.polygons(shapely.linearrings(blocks.vertices[take], indices=ring))


def point_distances(
    blocks: BlockSet, points: np.ndarray, rows: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(distance to the boundary, distance to the block) of point k and block ``rows[k]``.

    The second is 0 for a point inside the block, else equal to the first.
    """
    if len(rows) == 0:
        return np.zeros(0), np.zeros(0)
    if compiled(_distances_kernel):
        return _distances_kernel(
            np.ascontiguousarray(points, dtype=np.float64),
            np.asarray(rows, dtype=np.int64),
            blocks.offsets.astype(np.int64),
            np.ascontiguousarray(blocks.vertices, dtype=np.float64),
        )
    unique, local = np.unique(rows, return_inverse=True)
    polygons = block_polygons(blocks, unique)[local]
    geometry = shapely.points(points)
    return (
        shapely.distance(shapely.boundary(polygons), geometry),
        shapely.distance(polygons, geometry),
    )


def _distances(points, rows, offsets, vertices):
    """Compiled :func:`point_distances`: min segment distance, crossing-number parity."""
    n = points.shape[0]
    boundary = np.empty(n)
    to_block = np.empty(n)
    for k in range(n):
        start, end = offsets[rows[k]], offsets[rows[k] + 1]
        px, py = points[k, 0], points[k, 1]
        best = np.inf
        inside = False
        for i in range(start, end):
            j = i + 1 if i + 1 < end else start
            x1, y1 = vertices[i, 0], vertices[i, 1]
            ex, ey = vertices[j, 0] - x1, vertices[j, 1] - y1
            wx, wy = px - x1, py - y1
            length2 = ex * ex + ey * ey
            t = (wx * ex + wy * ey) / length2 if length2 > 0.0 else 0.0
            t = min(max(t, 0.0), 1.0)
            dx, dy = wx - t * ex, wy - t * ey
            best = min(best, np.sqrt(dx * dx + dy * dy))
            if (y1 > py) != (vertices[j, 1] > py) and px < x1 + (py - y1) * ex / ey:
                inside = not inside
        boundary[k] = best
        to_block[k] = 0.0 if inside else best
    return boundary, to_block


_distances_kernel = kernel(_distances)
