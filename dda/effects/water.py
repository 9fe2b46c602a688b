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

In a scene with ``[seismic]`` the phreatic line moves with the ground (the groundwater is
in the rock that the ground carries): at time t it is the table translated by the
ground's displacement u(t) (:meth:`WaterPressure.follow`, before each step). The field
then changes in time: the potential it gains at the blocks' place over a step,
V(x₀, t₁) − V(x₀, t₀), is work done on them from outside (:mod:`dda.run.energy`). The
pressure stays hydrostatic under g: the ground's acceleration does not change γw.
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.kinematics import displacement_matrices

_GAUSS = np.array([-1.0, 1.0]) / np.sqrt(3.0)  # two-point Gauss abscissae on [-1, 1]


class WaterPressure(Effect):
    """Hydrostatic pressure below the phreatic line ``table`` (x increasing), unit weight γw."""

    name = "water"

    def __init__(self, table: np.ndarray, unit_weight: float) -> None:
        self.table = np.asarray(table, float).reshape(-1, 2)
        self.drawn = self.table  # the table as the scene gives it, at t = 0
        self.unit_weight = float(unit_weight)
        self.ground = None  # the [seismic] ground motion that carries the table, if any

    def follow(self, time: float) -> None:
        """Put the table where the ground has carried it at ``time``: the drawn table
        translated by the ground's displacement (nothing without ``ground``)."""
        if self.ground is None:
            return
        shifted = self.drawn + self.ground.ground(time)[0]
        if not np.array_equal(shifted, self.table):
            self.table = shifted  # a new array: the wet edges kept for the last are not

    def energy_at(self, blocks: BlockSet, time: float) -> float:
        """:meth:`energy` with the table where the ground carried it at ``time`` (the
        table is left there)."""
        self.follow(time)
        return self.energy(blocks)

    def head(self, x: np.ndarray) -> np.ndarray:
        """h(x): the phreatic line's height (level beyond its ends)."""
        return np.interp(x, self.table[:, 0], self.table[:, 1])

    def slope(self, x: np.ndarray) -> np.ndarray:
        """h'(x): the phreatic line's slope (0 beyond its ends)."""
        return self._slopes()[np.searchsorted(self.table[:, 0], x)]

    def _slopes(self) -> np.ndarray:
        """The line's slope before its first point, on each stretch, and after its last."""
        xs, hs = self.table[:, 0], self.table[:, 1]
        return np.concatenate([[0.0], np.diff(hs) / np.diff(xs), [0.0]])

    def hessian(self, blocks: BlockSet) -> np.ndarray | None:
        """(n, 6, 6) the Hessian of :meth:`energy`, each block's own, None where no edge
        is wet. Each edge a→b gives ∫₀¹ g(x(t)) (b_x − a_x) dt, g = γw ⟨h − y⟩₊² / 2,
        x(t) = (1 − t) a + t b; over u = (a, b) its Hessian is

            ∫ [Wᵀ ∇²g W (b_x − a_x) + Wᵀ ∇g cᵀ + c ∇gᵀ W] dt,   W = [(1 − t) I, t I],

        c = (−1, 0, 1, 0), ∇g = p (h', −1), ∇²g = γw [h'², −h'; −h', 1] below the line:
        of degree 2 in t on each wet piece (two Gauss points). ∇g is continuous at the
        waterline, so its moving ends add nothing. At a kink x_k of the line, where h'
        jumps from h'₋ to h'₊, the integrand of the gradient jumps by p (h'₋ − h'₊) and its
        place t_k = (x_k − a_x)/(b_x − a_x) moves with u, which adds

            −p_k (h'₋ − h'₊) sign(b_x − a_x) w wᵀ,   w = (1 − t_k, 0, t_k, 0).

        The ends move with the block's unknowns as u = u₀ + [T(a); T(b)] D, so the
        block's Hessian is Σ Jᵀ H J, J = [T(a); T(b)]."""
        wet = self._wet(blocks)
        if wet is None:
            return None
        rows, a, b, (e, x, half, depth, t) = wet
        slope = self.slope(x[..., 0])
        weight = half[:, :, None] * self.unit_weight  # Gauss weight 1 on [-1, 1]: half a piece
        # W(t)ᵀ C W(t) = [[(1 − t)², t(1 − t)], [t(1 − t), t²]] ⊗ C for a 2 × 2 C
        ends = np.stack([np.stack([(1 - t) ** 2, t * (1 - t)], -1),
                         np.stack([t * (1 - t), t**2], -1)], -2)  # fmt: skip
        below = weight * (depth > 0.0) * e[:, 0, None, None]  # γw (b_x − a_x), below the line
        curvature = below[..., None, None] * np.stack(
            [np.stack([slope**2, -slope], -1), np.stack([-slope, np.ones_like(slope)], -1)], -2
        )
        per_edge = np.einsum("epgab,epgkl->eakbl", ends, curvature).reshape(-1, 4, 4)
        # Wᵀ ∇g cᵀ + c ∇gᵀ W, ∇g = p (h', −1)/γw·γw, c = (−1, 0, 1, 0)
        pull = (weight * depth)[..., None] * np.stack([slope, -np.ones_like(slope)], -1)
        wg = np.concatenate(
            [np.einsum("epg,epgk->ek", 1 - t, pull), np.einsum("epg,epgk->ek", t, pull)], axis=1
        )  # (e, 4): ∫ Wᵀ ∇g dt
        cross = wg[:, :, None] * np.array([-1.0, 0.0, 1.0, 0.0])[None, None, :]
        per_edge += cross + np.swapaxes(cross, 1, 2) + self._kinks(a, b)
        centroid = blocks.centroid[rows]
        jacobian = np.concatenate(
            [displacement_matrices(a, centroid), displacement_matrices(b, centroid)], axis=1
        )  # (e, 4, 6)
        out = np.zeros((blocks.count, 6, 6))
        np.add.at(out, rows, np.swapaxes(jacobian, 1, 2) @ per_edge @ jacobian)
        return out

    def _kinks(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(e, 4, 4) the kinks' part of each edge's Hessian (:meth:`hessian`)."""
        xs, hs = self.table[:, 0], self.table[:, 1]
        slopes = self._slopes()
        jump = slopes[:-1] - slopes[1:]  # h'₋ − h'₊ at each of the line's points
        along = b[:, 0] - a[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (xs[None, :] - a[:, 0, None]) / along[:, None]  # (e, k)
        inside = np.isfinite(t) & (t > 0.0) & (t < 1.0) & (jump[None, :] != 0.0)
        t = np.where(inside, t, 0.0)
        y = a[:, 1, None] + t * (b[:, 1] - a[:, 1])[:, None]
        pressure = self.unit_weight * np.maximum(hs[None, :] - y, 0.0) * inside
        scale = -pressure * jump[None, :] * np.sign(along)[:, None]  # (e, k)
        w = np.zeros(t.shape + (4,))
        w[..., 0], w[..., 2] = 1.0 - t, t
        return np.einsum("ek,eki,ekj->eij", scale, w, w)

    def stiffness(self, blocks: BlockSet, ctx: StepContext | None = None) -> np.ndarray | None:
        """(n, 6, 6) the forces' stiffness −∂F/∂D, the positive part of each block's
        :meth:`hessian`, so that a step takes the pressure at its end to first order, not
        at its start: a block floating in water is held by γw times its waterline's width,
        and with the pressure of the step start alone it bobbed ever higher (a 1 m ×
        0.5 m block, Δt = 1e-3: +1.0 J in 4 s). The negative part (a floating block's
        pressure may tip it over, above its metacentre) is left to the forces of the step
        start: K stays positive definite."""
        hessian = self.hessian(blocks)
        if hessian is None:
            return None
        values, vectors = np.linalg.eigh(hessian)  # fixed blocks: 0 (they have no edges)
        return np.einsum("nik,nk,njk->nij", vectors, np.maximum(values, 0.0), vectors)

    def energy(self, blocks: BlockSet) -> float:
        """Σ ∫_block p dA over the free blocks: the potential of the pressure, whose
        generalised forces (:meth:`forces`) are minus its gradient for any motion of the
        blocks (p is a fixed field; −∮ p n·u ds = −d∫ p dA). By the divergence theorem
        with Q = −γw ⟨h − y⟩₊² / 2 (∂Q/∂y = p): ∫ p dA = −∮ Q dx, on each wet piece of an
        edge a polynomial of degree 2 in its parameter (exact with two Gauss points)."""
        wet = self._wet(blocks)
        if wet is None:
            return 0.0
        e, _, half, depth, _ = wet[3]
        integrand = 0.5 * self.unit_weight * depth**2 * e[:, 0, None, None]  # γw⟨h−y⟩²/2 dx/dt
        return float(np.sum(integrand * half[:, :, None]))

    def forces(self, blocks: BlockSet, ctx: StepContext | None = None) -> np.ndarray | None:
        """(n, 6) −∮ p Tᵀ n ds of every free block: minus the gradient of :meth:`energy`."""
        f = np.zeros((blocks.count, 6))
        wet = self._wet(blocks)
        if wet is None:
            return f
        rows, _, _, (e, x, half, depth, _) = wet
        normal = np.column_stack([e[:, 1], -e[:, 0]])  # outward (CCW) normal x edge length
        weight = self.unit_weight * depth * half[:, :, None]  # Gauss weight 1: half a piece
        load = -weight[..., None] * normal[:, None, None, :]  # (e, p, 2, 2): force per point
        rows = np.broadcast_to(rows[:, None, None], depth.shape).ravel()
        tm = displacement_matrices(x.reshape(-1, 2), blocks.centroid[rows])
        generalised = np.einsum("mkr,mk->mr", tm, load.reshape(-1, 2))
        np.add.at(f, rows, generalised)
        return f

    def _wet(self, blocks: BlockSet):
        """(owner row, start a, end b, :meth:`_gauss` of a→b) of the free blocks' edges
        that reach below the table's highest point, None if none do; made once for the
        blocks' geometry (a step's forces and stiffness share it)."""
        return blocks.kept(
            "_water_edges", lambda: self._free_edges(blocks), blocks.vertices, blocks.fixed,
            self.table,
        )  # fmt: skip

    def _free_edges(self, blocks: BlockSet):
        """:meth:`_wet`, made."""
        owner = blocks.vertex_owner
        start = np.flatnonzero(~blocks.fixed[owner])
        a = blocks.vertices[start]
        b = blocks.vertices[blocks.next_vertex[start]]
        wet = np.minimum(a[:, 1], b[:, 1]) < self.table[:, 1].max()
        if not wet.any():
            return None
        a, b = a[wet], b[wet]
        return owner[start][wet], a, b, self._gauss(a, b)

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
