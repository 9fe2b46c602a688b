"""Elastic strain energy and the stress carried from step to step."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext


def elasticity_matrices(young: np.ndarray, poisson: np.ndarray, plane: str) -> np.ndarray:
    """(n, 3, 3) constitutive matrices for (ex, ey, gxy) -> (sxx, syy, sxy).

    Plane stress: E/(1-ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1-ν)/2]].
    Plane strain: E/((1+ν)(1-2ν)) [[1-ν, ν, 0], [ν, 1-ν, 0], [0, 0, (1-2ν)/2]].
    """
    e, nu = np.asarray(young, float), np.asarray(poisson, float)
    out = np.zeros((len(e), 3, 3))
    if plane == "strain":
        f = e / ((1 + nu) * (1 - 2 * nu))
        out[:, 0, 0] = out[:, 1, 1] = f * (1 - nu)
        out[:, 0, 1] = out[:, 1, 0] = f * nu
        out[:, 2, 2] = f * (1 - 2 * nu) / 2
    else:
        f = e / (1 - nu * nu)
        out[:, 0, 0] = out[:, 1, 1] = f
        out[:, 0, 1] = out[:, 1, 0] = f * nu
        out[:, 2, 2] = f * (1 - nu) / 2
    return out


class Elastic(Effect):
    """K_ii[3:6, 3:6] += S·E and F_i[3:6] -= S·σ (stress at the step start)."""

    name = "elastic"

    def __init__(self, material_elasticity: np.ndarray) -> None:
        self.material_elasticity = material_elasticity  # (n_materials, 3, 3)

    def block_elasticity(self, blocks: BlockSet) -> np.ndarray:
        return self.material_elasticity[blocks.material]

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        k = np.zeros((blocks.count, 6, 6))
        k[:, 3:, 3:] = blocks.area[:, None, None] * self.block_elasticity(blocks)
        return k

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        f = np.zeros((blocks.count, 6))
        f[:, 3:] = -blocks.area[:, None] * blocks.stress
        return f

    def stress_increment(self, blocks: BlockSet, d: np.ndarray) -> np.ndarray:
        """Δσ = E (ex, ey, gxy) for each block."""
        return np.einsum("nij,nj->ni", self.block_elasticity(blocks), d[:, 3:])
