"""Material damping: a viscous stress in every block (Kelvin–Voigt), as a fraction of
critical damping of the block's slowest elastic mode.

Each block carries, beside its elastic stress E ε, a viscous stress β E ε̇ (β in
seconds, stiffness-proportional: every strain mode of frequency ω is damped at
the ratio β ω / 2). In a step of length Δt the strain rate is the step's strain
D_s / Δt, so the step's potential gains the dissipation potential

    ½ (β / Δt) S D_sᵀ E D_s        (S the block's area)

— K_ii[3:6, 3:6] += (β / Δt) S E, no force term: convex, and it only takes
energy out (the step's work against it is (β / Δt) S D_sᵀ E D_s ≥ 0). The stress
carried to the next step stays E ε: a viscous stress is not stored.

β is set per block from ``ratio`` ξ: β = 2 ξ / ω₁ with ω₁ the slowest of the
block's three strain modes (K_s = S E against the strain part of its mass
matrix), so that a block's fundamental elastic mode is damped at ξ of critical
whatever the block's size and stiffness.

Why a real joint model needs it: an elastic block sliding on Coulomb friction
has a flutter mode (its shear deformation and the normal forces at its corners
feed each other through the friction forces, and through Poisson's ratio its
normal strain) that grows without any damping. Shi's velocity update damps
such a mode numerically, by about (γ − ½) ω Δt / 2: at Δt = 1e-3 that is 0.3 of
critical for a 1 m block with E = 1e9 Pa, at 1e-4 0.03, and the sliding block
then rocks itself apart. With ξ = ``DEFAULT_RATIO`` of material damping the
mode decays at every Δt (docs/contact.md).
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.effects.inertia import block_masses
from dda.jit import compiled_in_run, kernel

DEFAULT_RATIO = 0.2  # fraction of critical damping of each block's slowest elastic mode


def slowest_strain_frequency(stiffness: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """ω₁ of each block: √ of the smallest eigenvalue of M_s⁻¹ K_s (3 × 3 strain blocks).

    ``stiffness``: (n, 3, 3) S E; ``masses``: (n, 6, 6) mass matrices. M_s is
    symmetric positive definite, so with its Cholesky factor L the eigenvalues
    are those of the symmetric L⁻¹ K_s L⁻ᵀ. In a run with the kernels, the
    compiled twin :func:`_slowest_frequencies` (numpy's batched LAPACK calls on
    3 × 3 matrices cost about 4 µs a block: 0.4 ms a step of the 81-block slope).
    """
    if compiled_in_run(slowest_frequencies_kernel):
        return slowest_frequencies_kernel(
            np.ascontiguousarray(stiffness, np.float64), np.ascontiguousarray(masses, np.float64)
        )
    lower = np.linalg.cholesky(masses[:, 3:, 3:])
    inverse = np.linalg.inv(lower)
    symmetric = inverse @ stiffness @ np.swapaxes(inverse, 1, 2)
    return np.sqrt(np.linalg.eigvalsh(symmetric)[:, 0])


def _slowest_frequencies(stiffness, masses):
    """Compiled :func:`slowest_strain_frequency`: per block the Cholesky factor L of M_s,
    A = L⁻¹ K_s L⁻ᵀ by substitution, and A's smallest eigenvalue by cyclic Jacobi
    rotations (to round-off: the off-diagonal below 1e-15 of the diagonal)."""
    n = stiffness.shape[0]
    out = np.empty(n)
    lower = np.zeros((3, 3))
    half = np.empty((3, 3))
    a = np.empty((3, 3))
    for b in range(n):
        for i in range(3):  # M_s = L Lᵀ
            for j in range(i + 1):
                total = masses[b, 3 + i, 3 + j]
                for k in range(j):
                    total -= lower[i, k] * lower[j, k]
                lower[i, j] = np.sqrt(total) if i == j else total / lower[j, j]
        for c in range(3):  # half = L⁻¹ K_s (forward substitution, column by column)
            for i in range(3):
                total = stiffness[b, i, c]
                for k in range(i):
                    total -= lower[i, k] * half[k, c]
                half[i, c] = total / lower[i, i]
        for r in range(3):  # A = half L⁻ᵀ: row r of A solves L a_rᵀ = half_rᵀ
            for i in range(3):
                total = half[r, i]
                for k in range(i):
                    total -= lower[i, k] * a[r, k]
                a[r, i] = total / lower[i, i]
        for i in range(3):  # symmetric up to round-off: take the mean of the two halves
            for j in range(i):
                a[i, j] = a[j, i] = 0.5 * (a[i, j] + a[j, i])
        out[b] = np.sqrt(_smallest_eigenvalue(a))
    return out


def _smallest_eigenvalue(a):
    """Smallest eigenvalue of the symmetric 3 × 3 ``a`` (overwritten): cyclic Jacobi."""
    for _ in range(50):
        off = abs(a[0, 1]) + abs(a[0, 2]) + abs(a[1, 2])
        if off <= 1e-15 * (abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2])):
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            if a[p, q] == 0.0:
                continue
            theta = (a[q, q] - a[p, p]) / (2.0 * a[p, q])
            t = np.sign(theta) / (abs(theta) + np.sqrt(theta * theta + 1.0))
            if theta == 0.0:
                t = 1.0
            c = 1.0 / np.sqrt(t * t + 1.0)
            s = t * c
            for k in range(3):  # columns p, q of A J
                akp, akq = a[k, p], a[k, q]
                a[k, p], a[k, q] = c * akp - s * akq, s * akp + c * akq
            for k in range(3):  # rows p, q of Jᵀ (A J)
                apk, aqk = a[p, k], a[q, k]
                a[p, k], a[q, k] = c * apk - s * aqk, s * apk + c * aqk
    return min(a[0, 0], min(a[1, 1], a[2, 2]))


_smallest_eigenvalue = kernel(_smallest_eigenvalue) or _smallest_eigenvalue
slowest_frequencies_kernel = kernel(_slowest_frequencies)


class MaterialDamping(Effect):
    """K_ii[3:6, 3:6] += (β_i / Δt) S_i E_i with β_i = 2 ξ / ω₁ᵢ (module docstring)."""

    name = "material_damping"

    def __init__(
        self, material_elasticity: np.ndarray, density: np.ndarray, ratio: np.ndarray
    ) -> None:
        self.material_elasticity = material_elasticity
        self.density = density
        self.ratio = np.asarray(ratio, float)  # per material

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray | None:
        if ctx.static:
            return None
        elastic = blocks.area[:, None, None] * self.material_elasticity[blocks.material]
        masses = block_masses(self.density, blocks)
        beta = 2.0 * self.ratio[blocks.material] / slowest_strain_frequency(elastic, masses)
        k = np.zeros((blocks.count, 6, 6))
        k[:, 3:, 3:] = (beta / ctx.dt)[:, None, None] * elastic
        return k
