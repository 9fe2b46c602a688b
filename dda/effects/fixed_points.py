"""Points held at their initial position by stiff springs."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.effects.points import MaterialPoints
from dda.kinematics import displacement_matrices


class FixedPoints(Effect):
    """Spring p_f to the initial position: K_ii += p_f TᵀT, F_i += p_f Tᵀ(x₀ - x).

    ``x₀ - x`` is the displacement that brings the point back where it
    started (docs/theory.md §3, "point held by a spring").

    With the exact rotation a block's point a = x − c from its centroid turns to
    R(r) a = a + r J a + o(r), o(r) = (cos r − 1) a + (sin r − r) J a, not to the step's
    linear a + r J a. A dynamic step takes that known part of the point's motion for the
    rotation r̂ = ω₀ Δt its spin predicts (the spring pulls toward x₀ − o(r̂): a point
    held at its place stays there as the block turns about it), and the rotational
    stiffness of o: ½ p_f |x − x₀ + o(r)|² holds r² p_f a·(x₀ − x) / 2 beyond the step's
    quadratic, a·F₀ with F₀ = p_f (x₀ − x) the spring's force on the block, whose
    positive part over the block's points it adds, K_ii[2, 2] += ⟨Σ a·F₀⟩₊, as a bolt
    adds its tension's (:mod:`dda.effects.bolts`): a stiff spring ringing at a coarse Δt
    flips the sign of its a·F₀, whose negative part then makes energy (+1.8e4 J at 1e-2),
    and the sum keeps a block swaying on two springs, whose terms cancel, unbiased (the
    positive part point by point took 5 times the released block's FEM differences).
    Without them a block swinging on a fixed point gained energy at every swing (+89 J of
    1.06e4 J moved in 1 s at Δt = 1e-3, +8.5 J at 1e-4); with them it loses 88 J and
    8.5 J, and its angle converges as before. A static step
    takes neither: its steps are no energy balance, and the stiffness slowed the way to
    rest (a block hung 0.6 rad off, `cases/verify/swing.toml`, was not at rest in its 300
    steps: strains 7.6e-2 off the FEM's, 3.1e-3 without).
    """

    name = "fixed_points"

    def __init__(self, points: MaterialPoints, stiffness: float, exact_rotation: bool) -> None:
        self.points = points
        self.anchors = points.positions.copy()
        self.stiffness_value = float(stiffness)
        self.exact_rotation = exact_rotation

    def _matrices(self, blocks: BlockSet) -> np.ndarray:
        return displacement_matrices(self.points.positions, blocks.centroid[self.points.rows])

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        t = self._matrices(blocks)
        k = np.zeros((blocks.count, 6, 6))
        np.add.at(k, self.points.rows, self.stiffness_value * np.einsum("mki,mkj->mij", t, t))
        if self.exact_rotation and len(self.points) and not ctx.static:
            turning = np.zeros(blocks.count)
            np.add.at(turning, self.points.rows, self._turning(blocks))
            k[:, 2, 2] += np.maximum(turning, 0.0)  # the positive part, block by block
        return k

    def _turned(self, blocks: BlockSet, dt: float) -> np.ndarray:
        """(m, 2) o(r̂): where the exact rotation takes each point beyond the step's linear
        T D, for the rotation r̂ = ω₀ Δt the block's spin predicts (class docstring)."""
        arm = self.points.positions - blocks.centroid[self.points.rows]
        r = blocks.velocity[self.points.rows, 2] * dt
        turn = np.column_stack([-arm[:, 1], arm[:, 0]])
        return (np.cos(r) - 1.0)[:, None] * arm + (np.sin(r) - r)[:, None] * turn

    def _turning(self, blocks: BlockSet) -> np.ndarray:
        """(m,) a·F₀ of each point: the rotational stiffness of its spring as the exact
        rotation turns it (class docstring), of either sign: a block's points' sum is
        what its step takes the positive part of."""
        arm = self.points.positions - blocks.centroid[self.points.rows]
        force = self.stiffness_value * (self.anchors - self.points.positions)
        return np.einsum("mk,mk->m", arm, force)

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        t = self._matrices(blocks)
        gap = self.anchors - self.points.positions
        if self.exact_rotation and len(self.points) and not ctx.static:
            gap = gap - self._turned(blocks, ctx.dt)
        f = np.zeros((blocks.count, 6))
        np.add.at(f, self.points.rows, self.stiffness_value * np.einsum("mki,mk->mi", t, gap))
        return f

    def preload(self, blocks: BlockSet, d: np.ndarray) -> None:
        """x₀ ← x₀ − T d: each spring pulls as it would with its point moved by the
        step ``d`` (linear in d, as in the step's equations)."""
        if len(self.points):
            moved = np.einsum("mki,mi->mk", self._matrices(blocks), d[self.points.rows])
            self.anchors = self.anchors - moved

    def after_step(self, blocks: BlockSet, d: np.ndarray, ctx: StepContext) -> None:
        self.points.move(blocks, d, self.exact_rotation)

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        self.points.reassign(new, parent_of)
