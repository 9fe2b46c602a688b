"""Block polygons as the FEM side sees them: scene size, tolerances, conforming vertices.

Blocks are separate bodies, but their meshes should still meet vertex to
vertex along an interface so that node-to-segment contact sees matching
ends. :func:`conforming_polygons` therefore inserts into every polygon edge
the vertices of the other blocks that lie on it (T-junctions), and the load
points and fixed points of the block itself that lie on its boundary, so
that each of them becomes a mesh node.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda import Scene


def block_polygons(scene: Scene) -> list[np.ndarray]:
    """Vertices of every scene block as ``(k, 2)`` arrays (counter-clockwise)."""
    return [np.asarray(b.vertices, dtype=float) for b in scene.blocks]


def polygon_centroid(vertices: np.ndarray) -> np.ndarray:
    """Area centroid of one simple polygon."""
    centroid = shapely.Polygon(vertices).centroid
    return np.array([centroid.x, centroid.y])


def scene_size(scene: Scene) -> float:
    """Diagonal of the bounding box of all blocks (the model's length scale)."""
    points = np.concatenate(block_polygons(scene))
    return float(np.hypot(*(points.max(axis=0) - points.min(axis=0))))


def geometric_tolerance(scene: Scene) -> float:
    """Distance under which two points or a point and an edge count as touching."""
    return 1e-7 * scene_size(scene)


def point_segment_distance(
    points: np.ndarray, a: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance from every point to every segment and the projection parameter.

    Parameters
    ----------
    points : (m, 2)
    a, b : (f, 2) segment ends

    Returns
    -------
    distance, xi : (m, f) arrays; ``xi`` in [0, 1] locates the closest point
        ``a + xi (b - a)``.
    """
    d = b - a
    length2 = np.maximum(np.einsum("fi,fi->f", d, d), np.finfo(float).tiny)
    rel = points[:, None, :] - a[None, :, :]
    xi = np.clip(np.einsum("mfi,fi->mf", rel, d) / length2, 0.0, 1.0)
    closest = a[None] + xi[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2), xi


def insert_points_on_edges(vertices: np.ndarray, points: np.ndarray, tol: float) -> np.ndarray:
    """Insert into a closed polygon the points that lie on its edges.

    Points within ``tol`` of an existing vertex or farther than ``tol`` from
    every edge are ignored. Inserted points keep the edge order (sorted by
    their position along the edge); the result is still counter-clockwise.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) == 0:
        return vertices
    a, b = vertices, np.roll(vertices, -1, axis=0)
    near_vertex = np.linalg.norm(points[:, None] - vertices[None], axis=2).min(axis=1) <= tol
    distance, xi = point_segment_distance(points, a, b)
    out = []
    for edge in range(len(vertices)):
        out.append(vertices[edge])
        on_edge = (distance[:, edge] <= tol) & ~near_vertex & (xi[:, edge] > 0) & (xi[:, edge] < 1)
        order = np.argsort(xi[on_edge, edge])
        out.extend(points[on_edge][order])
    return _unique_rows(np.array(out), tol)


def _unique_rows(vertices: np.ndarray, tol: float) -> np.ndarray:
    """Drop consecutive duplicates (within ``tol``) of a closed polygon."""
    keep = np.linalg.norm(vertices - np.roll(vertices, 1, axis=0), axis=1) > tol
    keep[0] = True
    return vertices[keep]


def conforming_polygons(scene: Scene, tol: float | None = None) -> list[np.ndarray]:
    """Block polygons with T-junction vertices, load points and fixed points inserted."""
    tol = geometric_tolerance(scene) if tol is None else tol
    polygons = block_polygons(scene)
    all_vertices = np.concatenate(polygons)
    result = []
    for i, block in enumerate(scene.blocks):
        own = [ld.point for ld in scene.loads if ld.block == block.name]
        own += list(block.fixed_points)
        extra = np.concatenate([all_vertices, np.array(own, dtype=float).reshape(-1, 2)])
        result.append(insert_points_on_edges(polygons[i], extra, tol))
    return result
