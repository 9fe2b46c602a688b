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
The pressure is a fixed field, so its loads derive from a potential, Σ ∫_block p dA
(:meth:`WaterPressure.energy`, counted with gravity's in :mod:`dda.run.energy`); a
step takes them at its start with their stiffness, the potential's Hessian
(:meth:`WaterPressure.stiffness`).
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
        return self._forces(blocks)

    def stiffness(self, blocks: BlockSet, ctx: StepContext | None = None) -> np.ndarray | None:
        """(n, 6, 6) the forces' stiffness −∂F/∂D (the Hessian of :meth:`energy`, each
        block's own), so that a step takes the pressure at its end to first order, not
        at its start: a block floating in water is held by γw times its waterline's width,
        and with the pressure of the step start alone it bobbed ever higher (a 1 m ×
        0.5 m block, Δt = 1e-3: +1.0 J in 4 s). Central differences of the forces at the
        blocks moved by ±ε of each unknown (1e-6 of the block's size for a translation,
        1e-6 for a rotation or strain), made symmetric, and of it the positive part: a
        block's pressure may tip it over (a floating block above its metacentre), which
        is left to the forces of the step start; K stays positive definite."""
        edges = self._free_edges(blocks)
        if edges is None:
            return None
        rows, a0, b0 = edges
        n, size = blocks.count, np.sqrt(blocks.area)
        centroid = blocks.centroid[rows]
        ta, tb = displacement_matrices(a0, centroid), displacement_matrices(b0, centroid)
        step = 1e-6 * np.where(np.arange(6)[:, None] < 2, size[None, :], 1.0)  # (6, n)
        # the edges of every block moved by +ε, then −ε, along each unknown: 12 copies
        shift = step[:, None, rows, None] * np.array([1.0, -1.0])[None, :, None, None]
        a = (a0 + shift * np.moveaxis(ta, 2, 0)[:, None]).reshape(-1, 2)
        b = (b0 + shift * np.moveaxis(tb, 2, 0)[:, None]).reshape(-1, 2)
        copies = 12
        forces = self._edge_forces(
            (rows + n * np.arange(copies)[:, None]).ravel(),
            np.tile(a0, (copies, 1)), np.tile(b0, (copies, 1)), a, b,
            np.tile(blocks.centroid, (copies, 1)), copies * n,
        ).reshape(6, 2, n, 6)  # fmt: skip
        hessian = -(forces[:, 0] - forces[:, 1]) / (2.0 * step[:, :, None])  # (k, n, 6)
        hessian = np.transpose(hessian, (1, 2, 0))  # (n, 6, k): column k, the unknown moved
        hessian = 0.5 * (hessian + np.transpose(hessian, (0, 2, 1)))
        values, vectors = np.linalg.eigh(hessian)
        kept = np.einsum("nik,nk,njk->nij", vectors, np.maximum(values, 0.0), vectors)
        kept[blocks.fixed] = 0.0
        return kept

    def energy(self, blocks: BlockSet) -> float:
        """Σ ∫_block p dA over the free blocks: the potential of the pressure, whose
        generalised forces (:meth:`forces`) are minus its gradient for any motion of the
        blocks (p is a fixed field; −∮ p n·u ds = −d∫ p dA). By the divergence theorem
        with Q = −γw ⟨h − y⟩₊² / 2 (∂Q/∂y = p): ∫ p dA = −∮ Q dx, on each wet piece of an
        edge a polynomial of degree 2 in its parameter (exact with two Gauss points)."""
        edges = self._free_edges(blocks)
        if edges is None:
            return 0.0
        e, _, half, depth, _ = self._gauss(*edges[1:])
        integrand = 0.5 * self.unit_weight * depth**2 * e[:, 0, None, None]  # γw⟨h−y⟩²/2 dx/dt
        return float(np.sum(integrand * half[:, :, None]))

    def _forces(self, blocks: BlockSet) -> np.ndarray:
        """(n, 6) −∮ p Tᵀ n ds of every free block: minus the gradient of :meth:`energy`."""
        edges = self._free_edges(blocks)
        if edges is None:
            return np.zeros((blocks.count, 6))
        rows, a, b = edges
        return self._edge_forces(rows, a, b, a, b, blocks.centroid, blocks.count)

    def _edge_forces(self, rows, a0, b0, a, b, centroids, count) -> np.ndarray:
        """(count, 6) −∫ p T(x₀)ᵀ n ds summed by ``rows`` over the edges a→b, each the
        edge a0→b0 of its block moved (x = x₀ + T(x₀) D, T about ``centroids[rows]``):
        minus the gradient of the pressure's potential at that D."""
        f = np.zeros((count, 6))
        wet = np.minimum(a[:, 1], b[:, 1]) < self.table[:, 1].max()
        rows, a, b, a0, b0 = rows[wet], a[wet], b[wet], a0[wet], b0[wet]
        if not len(rows):
            return f
        e, x, half, depth, t = self._gauss(a, b)
        x0 = a0[:, None, None, :] + t[..., None] * (b0 - a0)[:, None, None, :]
        normal = np.column_stack([e[:, 1], -e[:, 0]])  # outward (CCW) normal x edge length
        weight = self.unit_weight * depth * half[:, :, None]  # Gauss weight 1: half a piece
        load = -weight[..., None] * normal[:, None, None, :]  # (e, p, 2, 2): force per point
        rows = np.broadcast_to(rows[:, None, None], depth.shape).ravel()
        tm = displacement_matrices(x0.reshape(-1, 2), centroids[rows])
        generalised = np.einsum("mkr,mk->mr", tm, load.reshape(-1, 2))
        np.add.at(f, rows, generalised)
        return f

    def _free_edges(self, blocks: BlockSet):
        """(owner row, start a, end b) of the free blocks' edges that reach below the
        table's highest point; None if none do."""
        owner = blocks.vertex_owner
        start = np.flatnonzero(~blocks.fixed[owner])
        a = blocks.vertices[start]
        b = blocks.vertices[next_vertex_index(blocks.offsets)[start]]
        wet = np.minimum(a[:, 1], b[:, 1]) < self.table[:, 1].max()
        if not wet.any():
            return None
        return owner[start][wet], a[wet], b[wet]

    def _gauss(self, a: np.ndarray, b: np.ndarray):
        """(edge vectors e = b − a, Gauss points x (e, p, 2, 2), half-lengths of the wet
        pieces in the edge parameter (e, p), depth ⟨h − y⟩₊ at the points, their
        parameters t (e, p, 2)) of the edges a→b."""
        lo, hi = self._wet_pieces(a, b)  # (e, p) parameters along each edge
        half = (hi - lo) / 2.0
        t = ((lo + hi) / 2.0)[:, :, None] + half[:, :, None] * _GAUSS  # (e, p, 2)
        e = b - a
        x = a[:, None, None, :] + t[..., None] * e[:, None, None, :]
        depth = np.maximum(self.head(x[..., 0]) - x[..., 1], 0.0)
        return e, x, half, depth, t

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
