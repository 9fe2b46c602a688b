"""Body force from gravity."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext


class Gravity(Effect):
    """F_i[0:2] += m g, m = ρ S₀ the block's mass (a uniform body force acts at the
    centroid; S₀ its area when made: mass is conserved as it strains)."""

    name = "gravity"

    def __init__(self, material_density: np.ndarray, gravity: tuple[float, float]) -> None:
        self.material_density = material_density
        self.gravity = np.asarray(gravity, dtype=float)

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        f = np.zeros((blocks.count, 6))
        mass = blocks.masses(self.material_density)
        f[:, 0:2] = mass[:, None] * self.gravity[None, :]
        return f

    def potential_energy(self, blocks: BlockSet) -> float:
        """-Σ m g·x_c (zero at the origin)."""
        mass = blocks.masses(self.material_density)
        return float(-np.sum(mass * (blocks.centroid @ self.gravity)))
