"""BlockSet: the state of every block as a struct of arrays.

One row per block, vertices packed (see :mod:`dda.geometry`). The engine
never keeps a Python object per block. A BlockSet is replaced, not edited in
place, when blocks appear (fracture) so that arrays stay contiguous.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from dda.geometry import owner_of_vertex, polygon_moments


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

    @property
    def count(self) -> int:
        return len(self.names)

    @property
    def vertex_owner(self) -> np.ndarray:
        """(NV,) the block of every vertex; kept while ``offsets`` is the same array (a
        BlockSet gets new offsets, never edits them, when blocks appear)."""
        kept = self.__dict__.get("_vertex_owner")
        if kept is None or kept[0] is not self.offsets:
            kept = (self.offsets, owner_of_vertex(self.offsets))
            self.__dict__["_vertex_owner"] = kept
        return kept[1]

    def update_moments(self) -> None:
        """Recompute area, centroid and second moments from the vertices."""
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
