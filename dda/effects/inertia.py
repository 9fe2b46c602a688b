"""Inertia (dynamic analysis, and the damping of static analysis)."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.jit import compiled_in_run, kernel


def mass_matrices(density: np.ndarray, blocks: BlockSet) -> np.ndarray:
    """M_i = ρ_i ∫ T_iᵀ T_i dA about the centroid (docs/theory.md §3), (n, 6, 6), with the
    current density ρ_i = ``density`` × mass_area / area: the mass ρ S₀ is conserved
    as the block strains (:class:`dda.blocks.BlockSet`); in a run with the kernels, its
    compiled twin :func:`_masses`."""
    s, ixx, iyy, ixy = blocks.area, blocks.ixx, blocks.iyy, blocks.ixy
    scale = density * blocks.density_ratio
    if compiled_in_run(masses_kernel):
        return masses_kernel(*(np.asarray(a, np.float64) for a in (scale, s, ixx, iyy, ixy)))
    m = np.zeros((blocks.count, 6, 6))
    for (row, column), value in zip(MASS_ENTRIES, mass_entries(s, ixx, iyy, ixy), strict=True):
        m[:, row, column] = value
    return scale[:, None, None] * m


# the entries of M / ρ that are not zero, in the order mass_entries gives them
MASS_ENTRIES = (
    (0, 0), (1, 1), (2, 2), (2, 3), (3, 2), (2, 4), (4, 2), (2, 5), (5, 2),
    (3, 3), (4, 4), (3, 5), (5, 3), (4, 5), (5, 4), (5, 5),
)  # fmt: skip


def mass_entries(s, ixx, iyy, ixy):
    """M / ρ's entries at :data:`MASS_ENTRIES` (docs/theory.md §3): S, S, Ixx + Iyy, −Ixy
    (twice), Ixy (twice), (Ixx − Iyy)/2 (twice), Ixx, Iyy, Ixy/2 (four times),
    (Ixx + Iyy)/4. Arithmetic only: arrays in numpy, one block's numbers in the kernel."""
    half_difference, half_ixy = (ixx - iyy) / 2, ixy / 2
    return (
        s, s, ixx + iyy, -ixy, -ixy, ixy, ixy, half_difference, half_difference,
        ixx, iyy, half_ixy, half_ixy, half_ixy, half_ixy, (ixx + iyy) / 4,
    )  # fmt: skip


def _masses(scale, s, ixx, iyy, ixy):
    """Compiled :func:`mass_matrices`: every entry, the zeros too, times the block's ρ."""
    n = s.shape[0]
    m = np.zeros((n, 6, 6))
    for i in range(n):
        values = _mass_entries(s[i], ixx[i], iyy[i], ixy[i])
        for e in range(len(MASS_ENTRIES)):
            m[i, MASS_ENTRIES[e][0], MASS_ENTRIES[e][1]] = values[e]
        for j in range(6):
            for k in range(6):
                m[i, j, k] = scale[i] * m[i, j, k]
    return m


_mass_entries = kernel(mass_entries) or mass_entries
masses_kernel = kernel(_masses)


def block_masses(material_density: np.ndarray, blocks: BlockSet) -> np.ndarray:
    """:func:`mass_matrices` of the blocks' materials (read-only), kept on ``blocks`` while
    the densities and the blocks' moments are the same arrays: inertia's K₀ and F₀ and the
    material damping of a step share one computation."""
    return blocks.kept(
        "_masses",
        lambda: mass_matrices(material_density[blocks.material], blocks),
        material_density, blocks.material, blocks.mass_area,
        blocks.area, blocks.ixx, blocks.iyy, blocks.ixy,
    )  # fmt: skip


class Inertia(Effect):
    """Shi's constant-acceleration scheme: K += (2/Δt²) M, F += (2/Δt) M v0.

    Static analysis sets v0 = 0 at every step (the mass term then only
    damps the approach to equilibrium).
    """

    name = "inertia"

    def __init__(self, material_density: np.ndarray) -> None:
        self.material_density = material_density

    def masses(self, blocks: BlockSet) -> np.ndarray:
        return block_masses(self.material_density, blocks)

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        return (2.0 / ctx.dt**2) * self.masses(blocks)

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray | None:
        if ctx.static:
            return None
        return (2.0 / ctx.dt) * np.einsum("nij,nj->ni", self.masses(blocks), blocks.velocity)
