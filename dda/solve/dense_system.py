"""A small step's linear systems held dense: K = K₀ + Gᵀ diag(k) G, Cholesky by LAPACK.

Below the policy's ``dense_system_rows`` unknowns (:class:`dda.solve.policy.StepPolicy`)
a step's systems are cheaper held as dense matrices than on a sparse block pattern: the
contacts' gradient rows over the free blocks' unknowns form one dense matrix per kind,
G (m, 6 n_free), made once a step (the rows are fixed within it), and each Newton
iteration's

    K = K₀ + G_nᵀ diag(k_n) G_n + G_sᵀ diag(k_s) G_s + G_bᵀ diag(k_b) G_b,
    F = F₀ − G_nᵀ N₀ − G_sᵀ T₀

(normal and shear springs k and offsets N₀, T₀ of the contacts' pieces; k_b the
springs between blocks, rock bolts) is a few calls — F by two products with
G; K by scattering each contact's 12 x 12 outer product [r_i r_j]ᵀ[r_i r_j]
into its two blocks' 12 unknowns (one weighted ``bincount``) — factorised by dense Cholesky
(:class:`dda.solve.linsolve.DenseFactorisation`) whenever the springs change,
with no pattern, ordering or scatter indices to keep. These are the systems of the
numpy Newton on a small model (a run too short for the kernels; where the kernels
are used a step's systems are in band storage, :mod:`dda.solve.band_system`, and
these are the fallback should LAPACK's banded Cholesky refuse K). It has the
interface of the sparse system in :mod:`dda.solve.step` (a
:data:`dda.solve.newton.PieceSolver`, a chord solver and the contacts' force vector),
and solves the same equations to round-off.
"""

from __future__ import annotations

import numpy as np

from dda.effects.pair_springs import PairSprings
from dda.solve.linsolve import DenseFactorisation
from dda.solve.systems import NumpyPasses


def gradient_matrix(
    position: np.ndarray,
    block_i: np.ndarray,
    block_j: np.ndarray,
    row_i: np.ndarray,
    row_j: np.ndarray,
    free_count: int,
) -> np.ndarray:
    """G (m, 6 n_free): row c holds ``row_i[c]`` in the columns of block_i[c] and
    ``row_j[c]`` in those of block_j[c]; fixed blocks (``position`` −1) have no columns."""
    m = len(block_i)
    g = np.zeros((m, free_count, 6))
    for blocks, rows in ((block_i, row_i), (block_j, row_j)):
        at = position[blocks]
        moving = np.flatnonzero(at >= 0)
        g[moving, at[moving]] += rows[moving]
    return g.reshape(m, 6 * free_count)


def contact_columns(position: np.ndarray, block_i: np.ndarray, block_j: np.ndarray) -> np.ndarray:
    """(m, 12) the unknowns' columns of each contact's two blocks, −1 for a fixed block."""
    offsets = np.arange(6)
    columns = [
        np.where(position[b][:, None] >= 0, 6 * position[b][:, None] + offsets, -1)
        for b in (block_i, block_j)
    ]
    return np.concatenate(columns, axis=1)


def outer_targets(columns: np.ndarray, size: int) -> np.ndarray:
    """(m·144,) flat entries of K (``size`` x ``size``) of every contact's 12 x 12 outer
    product; ``size²`` (one past K) where either column is a fixed block's."""
    rows, cols = columns[:, :, None], columns[:, None, :]
    flat = np.where((rows >= 0) & (cols >= 0), rows * size + cols, size * size)
    return flat.ravel()


def outer_products(rows: np.ndarray) -> np.ndarray:
    """(m, 144) [r_i r_j]ᵀ[r_i r_j] of every contact's (12,) ``rows``, row-major."""
    return (rows[:, :, None] * rows[:, None, :]).reshape(len(rows), 144)


def _set_up(position, block_a, block_b, normal_i, normal_j, shear_i, shear_j, base_free):
    """G_n, G_s (m, 6 n_free), the contacts' columns (m, 12), their rows [r_i r_j] (m, 12)
    normal and shear, and K₀ (6 n_free, 6 n_free) block-diagonal (numpy)."""
    count = len(base_free)
    normal = gradient_matrix(position, block_a, block_b, normal_i, normal_j, count)
    shear = gradient_matrix(position, block_a, block_b, shear_i, shear_j, count)
    columns = contact_columns(position, block_a, block_b)
    normal_rows = np.concatenate([normal_i, normal_j], axis=1)
    shear_rows = np.concatenate([shear_i, shear_j], axis=1)
    return normal, shear, columns, normal_rows, shear_rows, _block_diagonal(base_free)


class DenseSystem(NumpyPasses):
    """The linear systems of one step, K(springs) D = F(offsets), held dense.

    Parameters
    ----------
    fixed : (n,) bool, the blocks that do not move
    block_a, block_b : (m,) the contacts' blocks
    rows : the contacts' :class:`dda.contact.rows.ContactRows`
    base_k, base_f : (n, 6, 6), (n, 6): K₀'s blocks and F₀ of the effects
    friction : whether K holds the shear springs (else only their offsets enter F)
    couplings : springs between blocks (rock bolts), or None
    timer : a :class:`dda.solve.timing.StageTimer`
    numpy_rows : up to this many unknowns K is solved by numpy's LU
        (:class:`dda.solve.linsolve.DenseFactorisation`; the policy's ``numpy_solve_rows``)
    """

    def __init__(
        self,
        fixed: np.ndarray,
        block_a: np.ndarray,
        block_b: np.ndarray,
        rows,
        base_k: np.ndarray,
        base_f: np.ndarray,
        friction: bool,
        couplings: PairSprings | None,
        timer,
        numpy_rows: int = 0,
    ) -> None:
        self.free = np.flatnonzero(~fixed)
        self.numpy_rows = numpy_rows
        position = np.full(len(fixed), -1, np.int64)
        position[self.free] = np.arange(len(self.free))
        count = len(self.free)
        gradients = (rows.normal_i, rows.normal_j, rows.shear_i, rows.shear_j)
        made = _set_up(position, block_a, block_b, *gradients, base_k[self.free])
        self.normal, self.shear, self.columns, self.normal_rows, self.shear_rows = made[:5]
        self.base = made[5]
        self.size = 6 * count
        if couplings is not None and len(couplings):
            bolts = gradient_matrix(
                position,
                couplings.block_i,
                couplings.block_j,
                couplings.row_i,
                couplings.row_j,
                count,
            )
            self.base += (bolts.T * couplings.stiffness) @ bolts
        self.forces = base_f[self.free].ravel()
        self.friction, self.timer, self.shape = friction, timer, base_f.shape
        self.factorisations = 0
        self._factor: DenseFactorisation | None = None
        self._springs: tuple[np.ndarray, np.ndarray] | None = None
        self._outer: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.g0, self.s0 = rows.penetration, rows.slip

    def __call__(self, kn, ks, offset_n, offset_t) -> np.ndarray:
        """D (n, 6) minimising the quadratic of springs (kn, ks) and offsets (N₀, T₀)."""
        if self._springs is None or not (
            np.array_equal(kn, self._springs[0]) and np.array_equal(ks, self._springs[1])
        ):
            with self.timer("assembly"):
                k = self._stiffness(kn, ks if self.friction else np.zeros_like(ks))
            with self.timer("factorisation"):
                self._factor = DenseFactorisation(k, numpy_rows=self.numpy_rows)
            self._springs = (kn, ks)
            self.factorisations += 1
        with self.timer("assembly"):
            rhs = self.forces - offset_n @ self.normal - offset_t @ self.shear
        with self.timer("solve"):
            return self._spread(self._factor.solve(rhs))

    def _stiffness(self, kn: np.ndarray, ks: np.ndarray) -> np.ndarray:
        """K₀ + Σ kn r_n r_nᵀ + ks r_s r_sᵀ (dense)."""
        k = self.base.copy()
        if self._outer is None:  # one weighted bincount
            self._outer = (
                outer_targets(self.columns, self.size),
                outer_products(self.normal_rows),
                outer_products(self.shear_rows),
            )
        targets, normal, shear = self._outer
        weights = (kn[:, None] * normal + ks[:, None] * shear).ravel()
        n = self.size
        return k + np.bincount(targets, weights, n * n + 1)[: n * n].reshape(n, n)

    def chord(self, residual: np.ndarray) -> np.ndarray | None:
        """K_f⁻¹ r (n, 6) with the last factorisation K_f of this step, or None before one."""
        if self._factor is None:
            return None
        with self.timer("solve"):
            return self._spread(self._factor.solve(residual[self.free].ravel()))

    def contact_vector(self, normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
        """Σ N ∇g + Σ F ∇s over the contacts, (n, 6) (0 on fixed blocks)."""
        return self._spread(normal @ self.normal + shear @ self.shear)

    def _spread(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.shape)
        out[self.free] = x.reshape(-1, 6)
        return out


def _block_diagonal(blocks: np.ndarray) -> np.ndarray:
    """The (6n, 6n) matrix with the (n, 6, 6) ``blocks`` on its diagonal."""
    n = len(blocks)
    out = np.zeros((n, 6, n, 6))
    out[np.arange(n), :, np.arange(n), :] = blocks
    return out.reshape(6 * n, 6 * n)
