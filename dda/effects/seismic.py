"""Earthquake input: fixed blocks that follow a prescribed ground motion.

The ``[seismic]`` record gives the ground acceleration a(t) = (ax, ay) at
times t_k (times ``scale``), linear between them and zero outside. The
ground starts at rest; its velocity and displacement are the exact integrals
of that piecewise-linear acceleration, on segment k (τ = t − t_k, h its length):

    v = v_k + a_k τ + (a_{k+1} − a_k) τ² / (2h)
    u = u_k + v_k τ + a_k τ²/2 + (a_{k+1} − a_k) τ³ / (6h)

and after the record the ground keeps its last velocity. A step from t to
t + Δt moves each moving fixed block rigidly by u(t + Δt) − u(t): those
blocks stay out of the unknowns, and that known step enters every contact
gap they take part in (g0 + ∇g_j·D_j, likewise the shear motion and a bolt's
stretch) before the step is solved. The work the moving ground does on the
blocks is counted as external work (:mod:`dda.run.energy`).
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext


class GroundMotion(Effect):
    """Moves the fixed blocks of origin ``ids`` by the integrated ground acceleration.

    Parameters
    ----------
    times : (k,) record times, increasing
    acceleration : (k, 2) ground acceleration at those times (already scaled)
    ids : origin ids (:attr:`dda.blocks.BlockSet.origin`) of the blocks that move
    """

    name = "seismic"

    def __init__(self, times: np.ndarray, acceleration: np.ndarray, ids: np.ndarray) -> None:
        self.times = np.asarray(times, float)
        self.acceleration = np.asarray(acceleration, float).reshape(-1, 2)
        self.ids = np.asarray(ids, np.int64)
        h = np.diff(self.times)[:, None]
        a0, a1 = self.acceleration[:-1], self.acceleration[1:]
        dv = h * (a0 + a1) / 2.0
        self.velocity = np.vstack([np.zeros((1, 2)), np.cumsum(dv, axis=0)])
        du = self.velocity[:-1] * h + a0 * h**2 / 2.0 + (a1 - a0) * h**2 / 6.0
        self.displacement = np.vstack([np.zeros((1, 2)), np.cumsum(du, axis=0)])

    def ground(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(u, v): ground displacement and velocity at time t (module docstring)."""
        times = self.times
        if t <= times[0]:
            return np.zeros(2), np.zeros(2)
        if t >= times[-1]:
            v = self.velocity[-1]
            return self.displacement[-1] + v * (t - times[-1]), v.copy()
        k = int(np.searchsorted(times, t, side="right")) - 1
        tau, h = t - times[k], times[k + 1] - times[k]
        a0, jerk = self.acceleration[k], (self.acceleration[k + 1] - self.acceleration[k]) / h
        v = self.velocity[k] + a0 * tau + jerk * tau**2 / 2.0
        u = self.displacement[k] + self.velocity[k] * tau + a0 * tau**2 / 2.0 + jerk * tau**3 / 6.0
        return u, v

    def moving(self, blocks: BlockSet) -> np.ndarray:
        """(n,) bool: the blocks that follow the ground."""
        return blocks.fixed & np.isin(blocks.origin, self.ids)

    def prescribed(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        """(n, 6) step of every block: u(t) − u(t − Δt) on the moving ones, 0 elsewhere."""
        step = self.ground(ctx.time)[0] - self.ground(ctx.time - ctx.dt)[0]
        d = np.zeros((blocks.count, 6))
        d[self.moving(blocks), :2] = step
        return d

    def set_velocity(self, blocks: BlockSet, t: float) -> None:
        """Give the moving blocks the ground's velocity at t (for outputs; fixed blocks
        carry no kinetic energy)."""
        blocks.velocity[self.moving(blocks), :2] = self.ground(t)[1]
