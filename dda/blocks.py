"""BlockSet: the state of every block as a struct of arrays.

One row per block, vertices packed (see :mod:`dda.geometry`). The engine
never keeps a Python object per block. A BlockSet is replaced, not edited in
place, when blocks appear (fracture) so that arrays stay contiguous.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from dda.geometry import (
    central_moments,
    edge_moment_terms,
    next_vertex_index,
    owner_of_vertex,
    polygon_integrals,
    polygon_moments,
    previous_vertex_index,
)
from dda.jit import compiled_in_run, formula, kernel

# the formulas polygon_moments uses, compiled into the moments kernel (the same numbers)
for _formula in (edge_moment_terms, polygon_integrals, central_moments):
    formula(_formula)


@dataclass
class BlockSet:
    """Blocks, with per-block and per-vertex arrays.

    Attributes
    ----------
    names : list of str, block names ("parent/1" for fragments)
    ids : (n,) int, stable ids (never reused)
    material : (n,) int, row into the model's material table
    vertices : (NV, 2) current vertex coordinates, counter-clockwise per block
    offsets : (n+1,) block i owns ``vertices[offsets[i]:offsets[i+1]]``
    edge_joint : (NV,) int, joint row of the edge starting at each vertex (-1: default)
    centroid, area, ixx, iyy, ixy : current polygon integrals (about the centroid)
    velocity : (n, 6) time derivative of Shi's six unknowns (u0, v0, r0, ex, ey, gxy)
    acceleration : (n, 6) their acceleration over the last step (NaN: not known yet;
        :mod:`dda.solve.integrator`)
    stress : (n, 3) sxx, syy, sxy (tension positive)
    rotation : (n,) accumulated rotation
    displacement : (n, 2) centroid displacement since the start
    fixed : (n,) bool, blocks removed from the unknowns
    origin : (n,) int, id of the scene block each block is (or is a fragment of);
        ``[[interfaces]]`` between two scene blocks hold for their fragments too
    mass_area : (n,) the area that, times the material's density, is the block's mass:
        its area when it was made. Mass is conserved while the block strains and its
        area changes (the density is ρ mass_area / area; :attr:`density_ratio`)
    """

    names: list[str]
    ids: np.ndarray
    material: np.ndarray
    vertices: np.ndarray
    offsets: np.ndarray
    edge_joint: np.ndarray
    velocity: np.ndarray
    stress: np.ndarray
    rotation: np.ndarray
    displacement: np.ndarray
    fixed: np.ndarray
    centroid: np.ndarray = None  # type: ignore[assignment]
    area: np.ndarray = None  # type: ignore[assignment]
    ixx: np.ndarray = None  # type: ignore[assignment]
    iyy: np.ndarray = None  # type: ignore[assignment]
    ixy: np.ndarray = None  # type: ignore[assignment]
    origin: np.ndarray = None  # type: ignore[assignment]
    acceleration: np.ndarray = None  # type: ignore[assignment]
    mass_area: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.acceleration is None:
            self.acceleration = np.full((len(self.names), 6), np.nan)
        if self.origin is None:
            self.origin = np.asarray(self.ids, np.int64).copy()
        if self.centroid is None:
            self.update_moments()
        if self.mass_area is None:
            self.mass_area = self.area.copy()

    @property
    def density_ratio(self) -> np.ndarray:
        """(n,) current density over the material's: mass_area / area."""
        return self.mass_area / self.area

    def masses(self, material_density: np.ndarray) -> np.ndarray:
        """(n,) m_i = ρ_i mass_area_i, ρ the density of each block's material."""
        return material_density[self.material] * self.mass_area

    @property
    def count(self) -> int:
        return len(self.names)

    @property
    def vertex_owner(self) -> np.ndarray:
        """(NV,) the block of every vertex; kept while ``offsets`` is the same array (a
        BlockSet gets new offsets, never edits them, when blocks appear)."""
        return self._kept("_vertex_owner", owner_of_vertex)

    @property
    def next_vertex(self) -> np.ndarray:
        """(NV,) the next vertex of every vertex in its polygon; kept like
        :attr:`vertex_owner`."""
        return self._kept("_next_vertex", next_vertex_index)

    @property
    def previous_vertex(self) -> np.ndarray:
        """(NV,) the previous vertex of every vertex in its polygon; kept likewise."""
        return self._kept("_previous_vertex", previous_vertex_index)

    def _kept(self, name: str, make) -> np.ndarray:
        return self.kept(name, lambda: make(self.offsets), self.offsets)

    def kept(self, name: str, make, *sources: np.ndarray):
        """``make()``, computed once and kept (read-only, shared) while ``sources`` are
        the same arrays: the fields it is derived from, which a BlockSet replaces and
        never edits. An array made is made read-only; anything else is the caller's to
        leave as it is."""
        kept = self.__dict__.get(name)
        if kept is None or any(a is not b for a, b in zip(kept[0], sources, strict=True)):
            kept = (sources, make())
            if isinstance(kept[1], np.ndarray):
                kept[1].flags.writeable = False  # shared by every caller
            self.__dict__[name] = kept
        return kept[1]

    def update_moments(self) -> None:
        """Recompute area, centroid and second moments from the vertices
        (:func:`dda.geometry.polygon_moments`; in a run with the kernels, its compiled
        twin :func:`_moments`)."""
        if compiled_in_run(moments_kernel):
            moments = moments_kernel(
                np.ascontiguousarray(self.vertices, np.float64), self.offsets.astype(np.int64)
            )
            self.area, self.centroid, self.ixx, self.iyy, self.ixy = moments
            return
        m = polygon_moments(self.vertices, self.offsets)
        self.area, self.centroid = m["area"], m["centroid"]
        self.ixx, self.iyy, self.ixy = m["ixx"], m["iyy"], m["ixy"]

    def polygon(self, i: int) -> np.ndarray:
        return self.vertices[self.offsets[i] : self.offsets[i + 1]]

    def copy(self) -> BlockSet:
        return replace(
            self,
            **{
                f.name: getattr(self, f.name).copy()
                for f in fields(self)
                if isinstance(getattr(self, f.name), np.ndarray | list)
            },
        )


def _moments(vertices, offsets):
    """Compiled :func:`dda.geometry.polygon_moments`, polygon by polygon: the same edge
    terms summed in vertex order, as its ``bincount`` sums them (the same numbers)."""
    n = offsets.shape[0] - 1
    area, centroid = np.empty(n), np.empty((n, 2))
    ixx, iyy, ixy = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        first, last = offsets[i], offsets[i + 1]
        rx, ry = vertices[first, 0], vertices[first, 1]
        # the sums of the edges' terms, in vertex order as numpy's bincount adds them
        sum_c = sum_x = sum_y = sum_xx = sum_yy = sum_xy = 0.0
        for k in range(first, last):
            j = k + 1 if k + 1 < last else first
            x0, y0 = vertices[k, 0] - rx, vertices[k, 1] - ry
            x1, y1 = vertices[j, 0] - rx, vertices[j, 1] - ry
            c, cx, cy, cxx, cyy, cxy = edge_moment_terms(x0, y0, x1, y1)
            sum_c, sum_x, sum_y = sum_c + c, sum_x + cx, sum_y + cy
            sum_xx, sum_yy, sum_xy = sum_xx + cxx, sum_yy + cyy, sum_xy + cxy
        s, sx, sy, sxx, syy, sxy = polygon_integrals(sum_c, sum_x, sum_y, sum_xx, sum_yy, sum_xy)
        x, y = (sx / s, sy / s) if s != 0.0 else (np.nan, np.nan)  # numpy's 0/0
        area[i] = s
        centroid[i, 0], centroid[i, 1] = x + rx, y + ry
        ixx[i], iyy[i], ixy[i] = central_moments(s, x, y, sxx, syy, sxy)
    return area, centroid, ixx, iyy, ixy


moments_kernel = kernel(_moments)
