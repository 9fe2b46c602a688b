"""Inertia (dynamic analysis, and the damping of static analysis)."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.jit import compiled_in_run, formula, kernel


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
    fill_mass_matrix(m, s, ixx, iyy, ixy)
    return scale[:, None, None] * m


@formula
def fill_mass_matrix(m, s, ixx, iyy, ixy):
    """Write M / ρ (docs/theory.md §3) into ``m``'s last two axes (zeros elsewhere kept):
    S, S, Ixx + Iyy on the first diagonal entries, Ixx, Iyy, (Ixx + Iyy)/4 on the last,
    −Ixy, Ixy, (Ixx − Iyy)/2 between rotation and strains, Ixy/2 between the normal and
    shear strains. ``m`` (n, 6, 6) with arrays in numpy, one block's (6, 6) with its
    numbers in the kernel."""
    m[..., 0, 0] = s
    m[..., 1, 1] = s
    m[..., 2, 2] = ixx + iyy
    m[..., 2, 3] = m[..., 3, 2] = -ixy
    m[..., 2, 4] = m[..., 4, 2] = ixy
    m[..., 2, 5] = m[..., 5, 2] = (ixx - iyy) / 2
    m[..., 3, 3] = ixx
    m[..., 4, 4] = iyy
    m[..., 3, 5] = m[..., 5, 3] = ixy / 2
    m[..., 4, 5] = m[..., 5, 4] = ixy / 2
    m[..., 5, 5] = (ixx + iyy) / 4


def _masses(scale, s, ixx, iyy, ixy):
    """Compiled :func:`mass_matrices`: every entry, the zeros too, times the block's ρ."""
    n = s.shape[0]
    m = np.zeros((n, 6, 6))
    for i in range(n):
        fill_mass_matrix(m[i], s[i], ixx[i], iyy[i], ixy[i])
        for j in range(6):
            for k in range(6):
                m[i, j, k] = scale[i] * m[i, j, k]
    return m


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
