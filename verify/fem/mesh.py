"""Triangle meshes of the blocks: one disconnected MeshTri, one tag per element.

Each block polygon (convex or concave) is meshed on its own:

1. its edges are split into pieces no longer than ``4 A / P`` (A area,
   P perimeter: the side of a square, about twice the thickness of a slab),
   so that a thin block does not start from needle triangles;
2. shapely's constrained Delaunay triangulation of that polygon gives a
   coarse mesh that conforms to every boundary vertex;
3. ``MeshTri.refined(k)`` halves every edge k times, with the smallest k
   that brings the longest edge under the requested size.

Uniform refinement keeps the shape quality of the coarse triangles, and the
boundary of every refined block is exactly its polygon. Blocks are separate
bodies: the nodes of two blocks that touch are distinct. Fixed blocks are
not meshed (the engine treats them as rigid; see :mod:`verify.fem.statics`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import shapely
from skfem import MeshTri

from dda.scene import Scene
from verify.fem.geometry import conforming_polygons, scene_size

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BlockMesh:
    """All meshed blocks in one :class:`skfem.MeshTri`.

    Attributes
    ----------
    mesh : the combined mesh (disconnected, one component per block)
    element_block : (M,) scene index of the block of every element
    node_block : (N,) scene index of the block of every node
    blocks : scene indices of the meshed (free) blocks
    polygons : conforming polygon of every scene block (fixed ones included)
    size : the requested element size
    """

    mesh: MeshTri
    element_block: np.ndarray
    node_block: np.ndarray
    blocks: tuple[int, ...]
    polygons: tuple[np.ndarray, ...]
    size: float

    def boundary_facets(self, block: int) -> np.ndarray:
        """Indices of the boundary facets of one block."""
        facets = self.mesh.boundary_facets()
        return facets[self.element_block[self.mesh.f2t[0, facets]] == block]


def split_edges(vertices: np.ndarray, spacing: float) -> np.ndarray:
    """Split every edge of a closed polygon into equal pieces of at most ``spacing``."""
    a, b = vertices, np.roll(vertices, -1, axis=0)
    pieces = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / spacing - 1e-9)).astype(int)
    out = [a[k] + (b[k] - a[k]) * (j / n) for k, n in enumerate(pieces) for j in range(n)]
    return np.array(out)


def quality_spacing(vertices: np.ndarray) -> float:
    """Edge spacing ``4 A / P`` that keeps a slab's coarse triangles well shaped."""
    polygon = shapely.Polygon(vertices)
    return 4.0 * polygon.area / polygon.length


def triangulate_polygon(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Constrained Delaunay triangulation of one simple polygon.

    Returns
    -------
    points : (2, n) node coordinates (the polygon's vertices)
    triangles : (3, m) counter-clockwise node indices
    """
    index = {(float(x), float(y)): k for k, (x, y) in enumerate(vertices)}
    triangles = shapely.constrained_delaunay_triangles(shapely.Polygon(vertices))
    t = np.array(
        [[index[tuple(c)] for c in shapely.get_coordinates(tri)[:3]] for tri in triangles.geoms]
    )
    p = vertices[t]
    area2 = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (
        p[:, 1, 1] - p[:, 0, 1]
    )
    t[area2 < 0] = t[area2 < 0][:, ::-1]
    return np.ascontiguousarray(vertices.T), np.ascontiguousarray(t.T)


def refinement_levels(points: np.ndarray, triangles: np.ndarray, size: float) -> int:
    """Smallest number of uniform refinements that brings every edge under ``size``."""
    p = points[:, triangles]
    longest = max(np.linalg.norm(p[:, i] - p[:, (i + 1) % 3], axis=0).max() for i in range(3))
    return max(0, int(np.ceil(np.log2(longest / size) - 1e-9)))


def mesh_polygon(vertices: np.ndarray, size: float) -> MeshTri:
    """Mesh one polygon with elements no longer than ``size`` (see module notes)."""
    points, triangles = triangulate_polygon(split_edges(vertices, quality_spacing(vertices)))
    mesh = MeshTri(points, triangles)
    levels = refinement_levels(points, triangles, size)
    return mesh.refined(levels) if levels else mesh


def default_size(scene: Scene, divisions: int = 8) -> float:
    """Element size: the smallest free block's ``sqrt(area)`` over ``divisions``."""
    sizes = [np.sqrt(shapely.Polygon(b.vertices).area) for b in scene.blocks if not b.fixed] or [
        scene_size(scene)
    ]
    return float(min(sizes)) / divisions


def mesh_blocks(scene: Scene, size: float | None = None) -> BlockMesh:
    """Mesh every free block of a scene into one tagged, disconnected MeshTri.

    Parameters
    ----------
    scene : the scene whose blocks are meshed (fixed blocks are skipped)
    size : longest element edge wanted; default :func:`default_size`
    """
    size = default_size(scene) if size is None else float(size)
    polygons = conforming_polygons(scene)
    blocks = tuple(i for i, b in enumerate(scene.blocks) if not b.fixed)
    points, triangles, element_block, node_block = [], [], [], []
    offset = 0
    for i in blocks:
        m = mesh_polygon(polygons[i], size)
        points.append(m.p)
        triangles.append(m.t + offset)
        element_block.append(np.full(m.t.shape[1], i))
        node_block.append(np.full(m.p.shape[1], i))
        offset += m.p.shape[1]
    mesh = MeshTri(
        np.ascontiguousarray(np.hstack(points)), np.ascontiguousarray(np.hstack(triangles))
    )
    log.debug("meshed %d blocks: %d elements, size %.3g", len(blocks), mesh.t.shape[1], size)
    return BlockMesh(
        mesh=mesh,
        element_block=np.concatenate(element_block),
        node_block=np.concatenate(node_block),
        blocks=blocks,
        polygons=tuple(polygons),
        size=size,
    )
