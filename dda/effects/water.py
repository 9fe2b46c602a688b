"""Water pressure in the joints: hydrostatic edge loads below a phreatic line.

With the phreatic line y = h(x) (the ``[water] table``, linear between its
points and level beyond its ends) and the unit weight γw of water, the
pressure at a point is p = γw ⟨h(x) − y⟩₊. It acts on every edge of every
free block, normal to the edge and into the block:

    F_i += −∫_edge p(s) T_i(x(s))ᵀ n ds      (n the edge's outward unit normal)

On an edge, split at the x of the line's points and where p falls to zero,
p and T are linear, so two Gauss points per piece integrate it exactly. A
block under water gets γw times its submerged area upward (Archimedes); two
blocks sharing a wetted joint get equal and opposite pressures on its two
faces, which is the effective-stress principle: the contact carries the
normal force less the water's (Hoek & Bray's U on a sliding plane).
The loads are evaluated at the step start; their work is external work
(:mod:`dda.run.energy`).
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.geometry import next_vertex_index
from dda.kinematics import displacement_matrices

_GAUSS = np.array([-1.0, 1.0]) / np.sqrt(3.0)  # two-point Gauss abscissae on [-1, 1]


class WaterPressure(Effect):
    """Hydrostatic pressure below the phreatic line ``table`` (x increasing), unit weight γw."""

    name = "water"

    def __init__(self, table: np.ndarray, unit_weight: float) -> None:
        self.table = np.asarray(table, float).reshape(-1, 2)
        self.unit_weight = float(unit_weight)

    def head(self, x: np.ndarray) -> np.ndarray:
        """h(x): the phreatic line's height (level beyond its ends)."""
        return np.interp(x, self.table[:, 0], self.table[:, 1])

    def forces(self, blocks: BlockSet, ctx: StepContext | None = None) -> np.ndarray | None:
        """(n, 6) generalised forces of the water pressure on every free block."""
        f = np.zeros((blocks.count, 6))
        owner = blocks.vertex_owner
        start = np.flatnonzero(~blocks.fixed[owner])
        a = blocks.vertices[start]
        b = blocks.vertices[next_vertex_index(blocks.offsets)[start]]
        wet = np.minimum(a[:, 1], b[:, 1]) < self.table[:, 1].max()
        start, a, b = start[wet], a[wet], b[wet]
        if not len(start):
            return f
        lo, hi = self._wet_pieces(a, b)  # (e, p) parameters along each edge
        half = (hi - lo) / 2.0
        t = ((lo + hi) / 2.0)[:, :, None] + half[:, :, None] * _GAUSS  # (e, p, 2)
        e = b - a
        x = a[:, None, None, :] + t[..., None] * e[:, None, None, :]
        pressure = self.unit_weight * np.maximum(self.head(x[..., 0]) - x[..., 1], 0.0)
        normal = np.column_stack([e[:, 1], -e[:, 0]])  # outward (CCW) normal x edge length
        weight = pressure * half[:, :, None]  # Gauss weight 1 on [-1, 1] → half the piece
        load = -weight[..., None] * normal[:, None, None, :]  # (e, p, 2, 2): force per point
        rows = np.broadcast_to(owner[start][:, None, None], t.shape).ravel()
        tm = displacement_matrices(x.reshape(-1, 2), blocks.centroid[rows])
        generalised = np.einsum("mkr,mk->mr", tm, load.reshape(-1, 2))
        np.add.at(f, rows, generalised)
        return f

    def _wet_pieces(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (e, p): the pieces of each edge a→b (parameter in [0, 1]) under the
        line, one per stretch between the line's points (empty pieces have lo = hi)."""
        dx = b[:, 0] - a[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            cross = (self.table[None, :, 0] - a[:, 0, None]) / dx[:, None]
        cross = np.clip(np.nan_to_num(cross, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
        ends = np.sort(np.column_stack([np.zeros(len(a)), cross, np.ones(len(a))]), axis=1)
        t0, t1 = ends[:, :-1], ends[:, 1:]

        def depth(t):  # h − y at parameter t: linear on each piece
            x = a[:, None, :] + t[..., None] * (b - a)[:, None, :]
            return self.head(x[..., 0]) - x[..., 1]

        q0, q1 = depth(t0), depth(t1)
        with np.errstate(divide="ignore", invalid="ignore"):
            zero = t0 + (t1 - t0) * q0 / (q0 - q1)
        lo = np.where(q0 >= 0.0, t0, zero)
        hi = np.where(q1 >= 0.0, t1, zero)
        dry = (q0 < 0.0) & (q1 < 0.0)
        return np.where(dry, t0, lo), np.where(dry, t0, hi)
