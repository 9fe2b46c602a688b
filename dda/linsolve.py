"""Sparse symmetric solves: one factorisation serves many right-hand sides and,
through preconditioned conjugate gradients, many slightly different matrices.

K changes little from one solve to the next while the contact graph stays
the same (the geometry moves by a fraction of a block per step; a few
contacts change state). The factorisation of an earlier K is then an
excellent preconditioner for the new one: conjugate gradients converge in a
few iterations to the accuracy of a direct solve, at the cost of a few
triangular solves instead of a new factorisation. :class:`ReusingSolver`
re-factorises when that stops paying (too many iterations) or when the
contact graph, hence the sparsity pattern, changes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from contextlib import nullcontext

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

log = logging.getLogger(__name__)

RELATIVE_TOLERANCE = 1e-13  # PCG stops at ‖F - K x‖ ≤ this · ‖F‖ (a direct solve's level)
MAX_PCG_ITERATIONS = 12  # beyond this a new factorisation is cheaper (and is made)
REFRESH_AFTER = 4  # a solve that needed more iterations marks the factor stale


class Factorisation:
    """A factorised K; ``solve(F)`` re-uses it for any number of right-hand sides.

    SuperLU in symmetric mode without pivoting (K is symmetric positive
    definite), by default with the minimum-degree ordering on Aᵀ+A: about 200
    times faster than SuperLU's defaults on DDA matrices (TOOLCHAIN.md). Pass
    ``permc_spec="NATURAL"`` for a matrix already in a fill-reducing order.
    """

    def __init__(self, matrix: sp.csc_matrix, permc_spec: str = "MMD_AT_PLUS_A") -> None:
        self.size = matrix.shape[0]
        if self.size == 0:
            self._lu = None
            return
        self._lu = spla.splu(
            matrix,
            permc_spec=permc_spec,
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self._lu is None:
            return np.zeros(0)
        return self._lu.solve(rhs)


def block_ordering(nfree: int, pairs: np.ndarray) -> np.ndarray:
    """Fill-reducing order of the blocks: position of each block in K.

    Minimum degree (SuperLU's MMD on Aᵀ+A) on the block graph, with one node
    per block instead of six per block: 36 times smaller, the same quality
    (the six unknowns of a block are indistinguishable to the ordering).

    Parameters
    ----------
    nfree : number of blocks (graph nodes)
    pairs : (q, 2) edges of the graph (blocks in contact)
    """
    if nfree <= 2 or len(pairs) == 0:
        return np.arange(nfree)
    i, j = pairs[:, 0], pairs[:, 1]
    rows = np.concatenate([i, j, np.arange(nfree)])
    cols = np.concatenate([j, i, np.arange(nfree)])
    # a diagonally dominant matrix with the graph's pattern: SuperLU orders it without pivoting
    values = np.concatenate([np.full(2 * len(i), -1.0), np.full(nfree, 1.0 + 2.0 * len(i))])
    graph = sp.csc_matrix((values, (rows, cols)), shape=(nfree, nfree))
    lu = spla.splu(
        graph, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    return np.asarray(lu.perm_c, dtype=np.int64)


def pcg(
    matrix: sp.spmatrix,
    rhs: np.ndarray,
    preconditioner: Callable[[np.ndarray], np.ndarray],
    tolerance: float = RELATIVE_TOLERANCE,
    max_iterations: int = MAX_PCG_ITERATIONS,
) -> tuple[np.ndarray, int, bool]:
    """Preconditioned conjugate gradients for symmetric positive definite K x = F.

    Starts from x = M⁻¹F (one application of the preconditioner M⁻¹), so an
    exact preconditioner converges at once.

    Returns
    -------
    (x, iterations, converged) : iterations counts applications of M⁻¹;
    converged when ‖F - K x‖ ≤ tolerance · ‖F‖.
    """
    norm_f = float(np.linalg.norm(rhs))
    if norm_f == 0.0:
        return np.zeros_like(rhs), 0, True
    goal = tolerance * norm_f
    x = preconditioner(rhs)
    r = rhs - matrix @ x
    if not np.all(np.isfinite(r)):
        return x, 1, False
    if np.linalg.norm(r) <= goal:
        return x, 1, True
    z = preconditioner(r)
    p = z.copy()
    rz = float(r @ z)
    for k in range(2, max_iterations + 1):
        kp = matrix @ p
        pkp = float(p @ kp)
        if not pkp > 0.0:
            return x, k, False
        alpha = rz / pkp
        x += alpha * p
        r -= alpha * kp
        if np.linalg.norm(r) <= goal:
            # confirm with the true residual (round-off in the recurrence)
            if np.linalg.norm(rhs - matrix @ x) <= goal:
                return x, k, True
        z = preconditioner(r)
        rz_new = float(r @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, max_iterations, False


class ReusingSolver:
    """K x = F for a sequence of matrices with the same pattern, factorising rarely.

    ``solve(K, F, key)``: with no factorisation yet, or a new ``key`` (another
    sparsity pattern), factorise K. Otherwise solve directly when K is the
    matrix that was factorised, and by PCG preconditioned with the kept
    factorisation when it is a newer one; if PCG does not converge within
    ``max_iterations``, factorise K and solve directly. A solve that needed
    more than ``refresh_after`` iterations marks the factorisation stale: the
    next new matrix is factorised.

    Parameters
    ----------
    permc_spec : SuperLU column ordering ("NATURAL" when K comes pre-ordered)
    tolerance, max_iterations, refresh_after : PCG settings (see module constants)
    """

    def __init__(
        self,
        permc_spec: str = "NATURAL",
        tolerance: float = RELATIVE_TOLERANCE,
        max_iterations: int = MAX_PCG_ITERATIONS,
        refresh_after: int = REFRESH_AFTER,
    ) -> None:
        self.permc_spec = permc_spec
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.refresh_after = refresh_after
        self._factor: Factorisation | None = None
        self._factored: sp.spmatrix | None = None
        self._key: object = None
        self._stale = False
        self.factorisations = 0
        self.pcg_iterations = 0
        self.pcg_solves = 0

    def reset(self) -> None:
        """Forget the factorisation (the next solve factorises)."""
        self._factor, self._factored, self._key = None, None, None

    def solve(
        self, matrix: sp.csc_matrix, rhs: np.ndarray, key: object = None, timer=None
    ) -> np.ndarray:
        """x with K x = F to the accuracy of a direct solve.

        Parameters
        ----------
        matrix : K (symmetric positive definite, CSC)
        rhs : F
        key : identity of K's sparsity pattern (None: assume it may differ)
        timer : optional :class:`dda.timing.StageTimer` ("factorisation", "solve")
        """
        stage = timer if timer is not None else (lambda name: nullcontext())
        reusable = self._factor is not None and key is not None and key == self._key
        if reusable and matrix is self._factored:
            with stage("solve"):
                return self._factor.solve(rhs)
        if reusable and not self._stale:
            with stage("solve"):
                x, iterations, ok = pcg(
                    matrix, rhs, self._factor.solve, self.tolerance, self.max_iterations
                )
            self.pcg_iterations += iterations
            self.pcg_solves += 1
            if ok:
                self._stale = iterations > self.refresh_after
                return x
            log.debug("PCG did not converge in %d iterations: re-factorising", iterations)
        with stage("factorisation"):
            self._factor = Factorisation(matrix, self.permc_spec)
        self._factored, self._key, self._stale = matrix, key, False
        self.factorisations += 1
        with stage("solve"):
            return self._factor.solve(rhs)
