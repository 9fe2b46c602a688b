"""Rock bolts: linear springs between a material point of one block and one of another.

A bolt from P (block i) to Q (block j) with stiffness k, pretension f0 and
installed length L0 carries the tension T = f0 + k e, e = |Q − P| − L0
(tension positive). Within a step its stretch is linear in the unknowns,
with n = (Q − P)/|Q − P| at the step start and T(x, y) of docs/theory.md §1:

    e(D) = e0 + r_i·D_i + r_j·D_j,   r_i = −nᵀ T_i(P),   r_j = nᵀ T_j(Q)

(the bolt's analogue of a contact's linearised distance, paper eqs. 9-13).
Its energy f0 e + ½ k e² is a convex quadratic in D: it adds k r_iᵀr_i,
k r_iᵀr_j, k r_jᵀr_i, k r_jᵀr_j to K_ii, K_ij, K_ji, K_jj (as
:class:`dda.effects.pair_springs.PairSprings`) and −(f0 + k e0) r_iᵀ, −(f0 + k e0) r_jᵀ
to F_i, F_j. Where a fixed block follows the ground, its known step enters
e0 as it enters a contact's gap (:mod:`dda.effects.seismic`).

A bolt breaks between steps, never within a solve: after each accepted step
its tension at the new positions is compared with its capacity, and a bolt
beyond it is gone from the next step on (a :class:`dda.result.BoltEvent`).
Bolts of a ``[[stages]]`` entry exist from the start but hold nothing until
their stage installs them at their positions then (L0 = their length then).
"""

from __future__ import annotations

import logging

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.effects.pair_springs import PairSprings
from dda.effects.points import MaterialPoints
from dda.kinematics import project_rows
from dda.result import BoltEvent

log = logging.getLogger(__name__)


class RockBolts(Effect):
    """Every bolt of the scene (those of stages too), as arrays.

    Parameters
    ----------
    names : bolt names
    ends : the 2m end points: starts (rows 0..m-1), then ends (m..2m-1)
    stiffness, pretension, capacity : (m,) k, f0 and the breaking tension (inf: never)
    installed : (m,) bool, bolts in place from the start
    exact_rotation : how the end points move with their blocks (dda.kinematics)
    """

    name = "bolts"

    def __init__(
        self,
        names: list[str],
        ends: MaterialPoints,
        stiffness: np.ndarray,
        pretension: np.ndarray,
        capacity: np.ndarray,
        installed: np.ndarray,
        exact_rotation: bool,
    ) -> None:
        self.names = list(names)
        self.ends = ends
        self.axial_stiffness = np.asarray(stiffness, float)
        self.pretension = np.asarray(pretension, float)
        self.capacity = np.asarray(capacity, float)
        self.active = np.asarray(installed, bool).copy()  # installed and not broken
        self.installed = self.active.copy()
        self.rest_length = self.lengths()
        self.exact_rotation = exact_rotation
        self.events: list[BoltEvent] = []

    def __len__(self) -> int:
        return len(self.names)

    def lengths(self) -> np.ndarray:
        """|Q − P| of every bolt at the end points' current positions."""
        m = len(self)
        return np.linalg.norm(self.ends.positions[m:] - self.ends.positions[:m], axis=1)

    def tension(self) -> np.ndarray:
        """T = f0 + k (|Q − P| − L0) of every bolt now; 0 for those not in place."""
        t = self.pretension + self.axial_stiffness * (self.lengths() - self.rest_length)
        return np.where(self.active, t, 0.0)

    def segments(self) -> np.ndarray:
        """(b, 2, 2): start and end point of every bolt in place (for pictures)."""
        m = len(self)
        ends = self.ends.positions
        return np.stack([ends[:m], ends[m:]], axis=1)[self.active].copy()

    def energy(self) -> float:
        """Σ f0 e + ½ k e² of the bolts in place: the potential of their forces."""
        return float(np.sum(self.energies()[self.active]))

    def energies(self) -> np.ndarray:
        """f0 e + ½ k e² of every bolt, in place or not."""
        e = self.lengths() - self.rest_length
        return self.pretension * e + 0.5 * self.axial_stiffness * e * e

    def linearised(self, blocks: BlockSet):
        """(i, j, r_i, r_j, e0) of the bolts in place at the step start (module docstring;
        the known step of fixed blocks that follow the ground: :meth:`step_springs`)."""
        i, j, r_i, r_j, length = self._rows(blocks, along=True)
        return i, j, r_i, r_j, length - self.rest_length[self.active]

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray | None:
        """F_i −= (f0 + k e0) r_iᵀ, F_j −= (f0 + k e0) r_jᵀ; and where a fixed block moves
        with the ground by its known step, the springs across the bolts' force at it,
        −(T⁺/L) Δ⊥₀ (r⊥_i, r⊥_j) (:meth:`swing`: the pivot's sideways step pulls the
        bolt's other end along)."""
        if not self.active.any():
            return None
        axial, across, e0 = self.step_springs(blocks, ctx.prescribed if ctx else None)
        start = self.pretension[self.active] + axial.stiffness * e0
        if ctx is not None and ctx.prescribed is not None:
            sideways = across.stiffness * across.stretch(ctx.prescribed)
        else:
            sideways = np.zeros(len(across))
        f = np.zeros((blocks.count, 6))
        for springs, force in ((axial, start), (across, sideways)):
            np.add.at(f, springs.block_i, -force[:, None] * springs.row_i)
            np.add.at(f, springs.block_j, -force[:, None] * springs.row_j)
        return f

    def couplings(self, blocks: BlockSet, ctx: StepContext) -> PairSprings | None:
        """The bolts' springs between their two blocks (K_ii, K_ij, K_ji, K_jj): k along
        each bolt, and T⁺/L across it (:meth:`swing`)."""
        if not self.active.any():
            return None
        axial, across, _ = self.step_springs(blocks, ctx.prescribed if ctx else None)
        return PairSprings.join([axial, across])

    def step_springs(self, blocks: BlockSet, prescribed: np.ndarray | None = None):
        """(the springs along the bolts in place, k; those across them, T⁺/L; the stretch
        e0 at the step start, with the known step ``prescribed`` of fixed blocks that
        follow the ground): the bolts' terms of a step, T = f0 + k e0."""
        i, j, r_i, r_j, e0 = self.linearised(blocks)
        axial = PairSprings(i, j, r_i, r_j, self.axial_stiffness[self.active])
        if prescribed is not None:
            e0 = e0 + axial.stretch(prescribed)
        tension = self.pretension[self.active] + axial.stiffness * e0
        return axial, self.swing(blocks, tension), e0

    def swing(self, blocks: BlockSet, tension: np.ndarray) -> PairSprings:
        """The bolts' stiffness across their line, T⁺/L (the geometric stiffness of a
        taut cable): an end that moves by Δ⊥ across the bolt stretches it by
        |Δ⊥|² / (2L) to second order, so the tension T at the step start adds the energy
        ½ (T/L) |Δ⊥|², with Δ⊥ = tᵀ (T_j(Q) D_j − T_i(P) D_i), t ⟂ the bolt. Without it a
        bolt's direction is frozen within a step and a block that swings on it gains
        energy (a pendulum on a 2 m bolt at 30°, Δt = 1e-3: 0.8 J a second). A bolt in
        compression holds nothing across (T⁺ = max(T, 0): the term stays convex)."""
        i, j, r_i, r_j, length = self._rows(blocks, along=False)
        return PairSprings(i, j, r_i, r_j, np.maximum(tension, 0.0) / length)

    def _rows(self, blocks: BlockSet, along: bool):
        """(i, j, r_i, r_j, L) of the bolts in place: their blocks, the rows of their ends'
        motion along the bolt (``along``: n = (Q − P)/L) or across it (n turned 90°),
        r_i = −nᵀ T_i(P), r_j = nᵀ T_j(Q), and their lengths L."""
        m = len(self)
        act = np.flatnonzero(self.active)
        rows, points = self.ends.rows, self.ends.positions
        i, j = rows[act], rows[m + act]
        p, q = points[act], points[m + act]
        length = np.linalg.norm(q - p, axis=1)
        n = (q - p) / length[:, None]
        if not along:
            n = np.stack([-n[:, 1], n[:, 0]], axis=1)
        r_i = -project_rows(n, p, blocks.centroid[i])
        r_j = project_rows(n, q, blocks.centroid[j])
        return i, j, r_i, r_j, length

    def preload(self, blocks: BlockSet, d: np.ndarray) -> None:
        """L0 ← L0 − (r_i·D_i + r_j·D_j): each bolt in place pulls as it would stretched
        by the step ``d`` (linear in d, as in the step's equations)."""
        if self.active.any():
            self.rest_length[self.active] -= self.step_springs(blocks)[0].stretch(d)

    def after_step(self, blocks: BlockSet, d: np.ndarray, ctx: StepContext) -> None:
        """Move the end points with their blocks; break the bolts beyond their capacity."""
        self.ends.move(blocks, d, self.exact_rotation)
        force = self.tension()
        broken = np.flatnonzero(self.active & (force > self.capacity))
        held = self.energies()
        for k in broken:
            self.events.append(BoltEvent(
                int(ctx.step), float(ctx.time), self.names[k], float(force[k]), float(held[k])
            ))  # fmt: skip
            log.info("step %d: bolt %s broke at %.6g", ctx.step, self.names[k], force[k])
        self.active[broken] = False

    def install(self, bolts: np.ndarray, rows: np.ndarray, start: np.ndarray, end: np.ndarray):
        """Put ``bolts`` (indices) in place: ends at ``start``, ``end`` (k, 2) in blocks
        ``rows`` (k, 2), unstretched (their tension is their pretension)."""
        m = len(self)
        self.ends.rows[bolts], self.ends.rows[m + bolts] = rows[:, 0], rows[:, 1]
        self.ends.positions[bolts], self.ends.positions[m + bolts] = start, end
        self.rest_length[bolts] = self.lengths()[bolts]
        self.active[bolts] = self.installed[bolts] = True

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        self.ends.reassign(new, parent_of)
