"""Point loads, optionally scaled by a time history."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.effects.points import MaterialPoints
from dda.kinematics import displacement_matrices


class PointLoads(Effect):
    """F_i += T_i(x, y)ᵀ (Fx, Fy)·factor(t), the point moving with the block.

    The factor is interpolated linearly in the (time, factor) table at the
    end of the step (constant beyond its ends); 1 without a history.
    """

    name = "loads"

    def __init__(
        self,
        points: MaterialPoints,
        force: np.ndarray,
        histories: list[np.ndarray | None],
        exact_rotation: bool,
    ) -> None:
        self.points = points
        self.force = np.asarray(force, dtype=float).reshape(-1, 2)
        self.histories = histories
        self.exact_rotation = exact_rotation

    def factors(self, time: float) -> np.ndarray:
        return np.array(
            [1.0 if h is None else float(np.interp(time, h[:, 0], h[:, 1])) for h in self.histories]
        )

    def current_forces(self, time: float) -> np.ndarray:
        return self.force * self.factors(time)[:, None]

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        rows = self.points.rows
        t = displacement_matrices(self.points.positions, blocks.centroid[rows])
        per_load = np.einsum("mkr,mk->mr", t, self.current_forces(ctx.time))
        f = np.zeros((blocks.count, 6))
        np.add.at(f, rows, per_load)
        return f

    def after_step(self, blocks: BlockSet, d: np.ndarray, ctx: StepContext) -> None:
        self.points.move(blocks, d, self.exact_rotation)

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        self.points.reassign(new, parent_of)
