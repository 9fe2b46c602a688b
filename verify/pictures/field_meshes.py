"""The blocks and the FEM mesh of a case as pyvista datasets, for the field pictures.

Everything lies in the plane z = 0 (outlines, hatching and labels a little
above it, so that they are drawn over the filled blocks). Polygons, convex or
concave, are filled through shapely's constrained Delaunay triangulation.

pyvista is imported here, after ``VTK_DEFAULT_OPENGL_WINDOW`` is set to
``vtkEGLRenderWindow``: off screen through EGL, no display needed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import shapely
from shapely.ops import polylabel

from verify.fem import fields
from verify.fem.geometry import scene_size
from verify.harness.cases import CaseResult

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
import pyvista  # noqa: E402

pyvista.OFF_SCREEN = True


# the largest displacement drawn: this fraction of the model's size, and of its smallest
# free block's (√area), whichever is less (a wall drawn moving further closes an opening
# and overlaps its neighbours)
MODEL_FRACTION, BLOCK_FRACTION = 0.06, 0.2
# displacements below this fraction of the model's size are round-off: drawn as they are
ROUND_OFF = 1e-9


def magnification(result: CaseResult) -> float:
    """Factor that draws the largest displacement as :data:`MODEL_FRACTION` of the
    model's size or :data:`BLOCK_FRACTION` of its smallest free block's, whichever is
    less; 1 (not magnified) where every displacement is round-off (:data:`ROUND_OFF`)."""
    largest = max(
        float(np.abs(fields.nodal_displacement(result.fem)).max()),
        max(float(np.abs(d).max()) for d in result.dda.vertex_displacement),
    )
    size = scene_size(result.scene)
    if largest <= ROUND_OFF * size:
        return 1.0
    free = [shapely.Polygon(result.scene.blocks[i].vertices).area for i in free_blocks(result)]
    smallest = float(np.sqrt(min(free))) if free else size
    return min(MODEL_FRACTION * size, BLOCK_FRACTION * smallest) / largest


def free_blocks(result: CaseResult) -> list[int]:
    """Scene indices of the meshed (free) blocks."""
    return list(result.fem.block_mesh.blocks)


def fixed_polygons(result: CaseResult) -> list[np.ndarray]:
    """The fixed blocks' polygons."""
    return [np.asarray(b.vertices, dtype=float) for b in result.scene.blocks if b.fixed]


def scene_bounds(result: CaseResult, pad: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corner of every block, widened by ``pad`` × the model size."""
    points = np.concatenate([np.asarray(b.vertices, dtype=float) for b in result.scene.blocks])
    margin = pad * scene_size(result.scene)
    return points.min(axis=0) - margin, points.max(axis=0) + margin


def dda_displacement_at(result: CaseResult, block: int, points: np.ndarray) -> np.ndarray:
    """The DDA block's affine displacement at ``points`` (fitted to its vertices)."""
    x0 = np.asarray(result.scene.blocks[block].vertices, dtype=float)
    design = np.column_stack([np.ones(len(x0)), x0])
    coefficients = np.linalg.lstsq(design, result.dda.vertex_displacement[block], rcond=None)[0]
    return np.column_stack([np.ones(len(points)), points]) @ coefficients


def on_plane(xy: np.ndarray, z: float = 0.0) -> np.ndarray:
    """(k, 2) points as (k, 3) points at height z."""
    return np.column_stack([xy, np.full(len(xy), z)])


def triangles(
    polygons: Sequence[np.ndarray],
    cell_values: Sequence[float] | None = None,
    values_at: Callable[[int, np.ndarray], np.ndarray] | None = None,
) -> Any:
    """Polygons filled with triangles (their own corners: a field may jump between them).

    ``cell_values``: one value per polygon, stored as cell array ``"value"``;
    ``values_at(k, points)``: values at the corners of polygon k's triangles,
    stored as point array ``"value"`` (interpolated across each triangle).
    """
    corners, values, owner = [], [], []
    for k, polygon in enumerate(polygons):
        cut = shapely.constrained_delaunay_triangles(shapely.Polygon(polygon))
        xy = shapely.get_coordinates(cut).reshape(-1, 4, 2)[:, :3].reshape(-1, 2)
        corners.append(xy)
        owner.append(np.full(len(xy) // 3, k))
        if values_at is not None:
            values.append(values_at(k, xy))
    xy = np.concatenate(corners)
    mesh = pyvista.PolyData.from_regular_faces(on_plane(xy), np.arange(len(xy)).reshape(-1, 3))
    if cell_values is not None:
        mesh.cell_data["value"] = np.asarray(cell_values, dtype=float)[np.concatenate(owner)]
    if values_at is not None:
        mesh.point_data["value"] = np.concatenate(values)
    return mesh


def outlines(polygons: Sequence[np.ndarray], z: float) -> Any:
    """Closed outlines of the polygons as line segments at height ``z``."""
    starts = np.concatenate([np.asarray(p, dtype=float) for p in polygons])
    ends = np.concatenate([np.roll(np.asarray(p, dtype=float), -1, axis=0) for p in polygons])
    return segments(starts, ends, z)


def segments(starts: np.ndarray, ends: np.ndarray, z: float) -> Any:
    """Line segments from ``starts[i]`` to ``ends[i]`` at height ``z``."""
    m = len(starts)
    points = on_plane(np.concatenate([starts, ends]), z)
    lines = np.column_stack([np.full(m, 2), np.arange(m), np.arange(m) + m]).ravel()
    return pyvista.PolyData(points, lines=lines)


def hatching(polygons: Sequence[np.ndarray], spacing: float, z: float) -> Any | None:
    """Diagonal lines (45°) ``spacing`` apart, clipped to the polygons (None if none)."""
    if not polygons:
        return None
    region = shapely.union_all([shapely.Polygon(p) for p in polygons])
    x0, y0, x1, y1 = region.bounds
    offsets = np.arange(x0 - (y1 - y0), x1 + spacing, spacing)
    diagonals = shapely.MultiLineString(
        [[(c, y0), (c + (y1 - y0), y1)] for c in offsets]
    ).intersection(region)
    pieces = [g for g in getattr(diagonals, "geoms", [diagonals]) if not g.is_empty]
    ends = [shapely.get_coordinates(g)[[0, -1]] for g in pieces if g.length > 0]
    if not ends:
        return None
    ends = np.array(ends)
    return segments(ends[:, 0], ends[:, 1], z)


def dots(polygons: Sequence[np.ndarray], spacing: float, z: float) -> Any | None:
    """A square grid of points ``spacing`` apart inside the polygons (None if none)."""
    if not polygons:
        return None
    region = shapely.union_all([shapely.Polygon(p) for p in polygons])
    x0, y0, x1, y1 = region.bounds
    x, y = np.meshgrid(
        np.arange(x0 + spacing / 2, x1, spacing), np.arange(y0 + spacing / 2, y1, spacing)
    )
    grid = np.column_stack([x.ravel(), y.ravel()])
    inside = grid[shapely.contains_xy(region, grid[:, 0], grid[:, 1])]
    return pyvista.PolyData(on_plane(inside, z)) if len(inside) else None


def fem_mesh(result: CaseResult, mag: float, corner_values: np.ndarray) -> Any:
    """The FEM's triangles moved by ``mag`` × their displacement, corners duplicated.

    ``corner_values``: (M, 3) a value at every element's corners (a field
    discontinuous between elements), point array ``"value"``.
    """
    mesh = result.fem.block_mesh.mesh
    corners = mesh.t.T
    xy = mesh.p.T[corners] + mag * fields.nodal_displacement(result.fem)[corners]
    faces = np.arange(corners.size).reshape(-1, 3)
    out = pyvista.PolyData.from_regular_faces(on_plane(xy.reshape(-1, 2)), faces)
    out.point_data["value"] = np.asarray(corner_values, dtype=float).ravel()
    return out


def fem_nodes(result: CaseResult, node_values: np.ndarray) -> Any:
    """The FEM's undeformed triangles with a value at every node (point array ``"value"``)."""
    mesh = result.fem.block_mesh.mesh
    out = pyvista.PolyData.from_regular_faces(on_plane(mesh.p.T), mesh.t.T)
    out.point_data["value"] = np.asarray(node_values, dtype=float)
    return out


def moved_blocks(result: CaseResult, mag: float) -> list[np.ndarray]:
    """The free blocks' polygons moved by ``mag`` × the DDA vertex displacements."""
    return [
        np.asarray(result.scene.blocks[i].vertices, dtype=float)
        + mag * result.dda.vertex_displacement[i]
        for i in free_blocks(result)
    ]


def block_polygons(result: CaseResult, blocks: Sequence[int]) -> list[np.ndarray]:
    """The scene polygons of some blocks."""
    return [np.asarray(result.scene.blocks[i].vertices, dtype=float) for i in blocks]


def label_point(polygon: np.ndarray) -> np.ndarray:
    """A point well inside the polygon for its label: the centroid, else the pole of
    inaccessibility (the point farthest from the edges; for a concave block)."""
    shape = shapely.Polygon(polygon)
    point = shape.centroid
    if not shape.contains(point):
        point = polylabel(shape, tolerance=1e-3 * np.sqrt(shape.area))
    return np.array([point.x, point.y])
