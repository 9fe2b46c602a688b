"""Point loads, optionally scaled by a time history."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.effects.points import MaterialPoints
from dda.kinematics import displacement_matrices


def history_mean(history: np.ndarray, start: float, end: float) -> float:
    """(1/Δt) ∫ f(t) dt over the step [start, end] of the factor f interpolated linearly
    in the (time, factor) rows of ``history`` (constant beyond its ends): the trapezoids
    between the step's ends and the table's times within it, exact for f piecewise
    linear; f(end) for a step of no length."""
    times, values = history[:, 0], history[:, 1]
    if not end > start:
        return float(np.interp(end, times, values))
    inside = times[(times > start) & (times < end)]
    knots = np.concatenate([[start], inside, [end]])
    f = np.interp(knots, times, values)
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(knots)) / (end - start))


class PointLoads(Effect):
    """F_i += T_i(x, y)ᵀ (Fx, Fy)·factor, the point moving with the block.

    The factor of a step is the mean over the step of the (time, factor) table,
    interpolated linearly (constant beyond its ends; :func:`history_mean`); 1 without a
    history. The mean gives a free block its impulse ∫ F dt exactly, whatever Δt (Shi's
    update: v₁ − v₀ = F Δt / m); the factor at the step's end was first order in Δt and
    lost a pulse shorter than a step (an audit: a 5 ms pulse, none of it at Δt = 10 ms,
    39 % short at 3 ms). A static step, an equilibrium at its end, takes the factor
    there.
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

    def step_forces(self, start: float, end: float) -> np.ndarray:
        """The forces of the step from ``start`` to ``end``: each at its factor's mean."""
        means = [1.0 if h is None else history_mean(h, start, end) for h in self.histories]
        return self.force * np.array(means)[:, None]

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        rows = self.points.rows
        t = displacement_matrices(self.points.positions, blocks.centroid[rows])
        start = ctx.time if ctx.static else ctx.time - ctx.dt  # a static step: at its end
        per_load = np.einsum("mkr,mk->mr", t, self.step_forces(start, ctx.time))
        f = np.zeros((blocks.count, 6))
        np.add.at(f, rows, per_load)
        return f

    def after_step(self, blocks: BlockSet, d: np.ndarray, ctx: StepContext) -> None:
        self.points.move(blocks, d, self.exact_rotation)

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        self.points.reassign(new, parent_of)
