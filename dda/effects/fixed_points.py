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
        return k

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        t = self._matrices(blocks)
        gap = self.anchors - self.points.positions
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
