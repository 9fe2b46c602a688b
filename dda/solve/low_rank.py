"""Solves with a kept factorisation after a few contacts changed state (Woodbury).

Within a step the contact rows are fixed, and from one solve to the next
only the springs of the contacts that changed state change:

    K = K_f + U diag(c) Uᵀ,

one column of U per changed spring (the contact's gradient [r_i r_j] on its
two blocks, in the matrix order) and c the change of that spring. The
Sherman–Morrison–Woodbury identity gives

    K⁻¹ b = y − Z (diag(1/c) + Uᵀ Z)⁻¹ Uᵀ y,   y = K_f⁻¹ b,  Z = K_f⁻¹ U,

for the price of one back-substitution per column of U (PARDISO solves many
columns at once: 32 for less than one factorisation at 30x30). Z's columns
are kept per contact and kind while K_f is, so an iteration pays only for the
contacts that changed since the last one. The identity loses digits when a
stiff spring is taken out (c = -p): it serves as PCG's preconditioner, and
PCG checks the residual.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy

from dda.contact.rows import ContactRows
from dda.solve.assembly import BLOCK, BlockPattern
from dda.solve.linsolve import pcg
from dda.solve.policy import DEFAULT, StepPolicy


class StepUpdates:
    """The factorised K of this step and the columns K_f⁻¹U computed so far.

    Parameters
    ----------
    factored : K_f, the factorised matrix (assembled this step)
    springs : (2, m) normal and shear springs K_f holds, per contact of the step's list
    pattern : the pattern K_f was assembled on
    rows : the step's contact rows
    block_a, block_b : (m,) blocks of each contact
    solve_many : X = K_f⁻¹ B for an (n, r) array B
    policy : ``low_rank_min_rows``, ``low_rank_columns``, ``low_rank_pcg_iterations``
        and ``pcg_tolerance`` (:class:`dda.solve.policy.StepPolicy`; its defaults when None)
    """

    def __init__(
        self,
        factored: scipy.sparse.spmatrix,
        springs: np.ndarray,
        pattern: BlockPattern,
        rows: ContactRows,
        block_a: np.ndarray,
        block_b: np.ndarray,
        solve_many: Callable[[np.ndarray], np.ndarray],
        policy: StepPolicy | None = None,
    ) -> None:
        self.policy = DEFAULT if policy is None else policy
        self.factored = factored
        self.springs = springs
        self.pattern = pattern
        self._row_of = pattern.block_of_row
        self._gradients = (
            (rows.normal_i, rows.normal_j),
            (rows.shear_i, rows.shear_j),
        )
        self._a, self._b = block_a, block_b
        self._solve_many = solve_many
        self._size = factored.shape[0]
        self._z: dict[tuple[int, int], np.ndarray] = {}
        self._last: tuple[scipy.sparse.spmatrix, Callable] | None = None

    def applies(self, factored: scipy.sparse.spmatrix | None, pattern: BlockPattern) -> bool:
        """True while K_f is the kept factorisation and K has K_f's pattern (matrix order),
        for K of at least the policy's ``low_rank_min_rows`` rows."""
        big = self._size >= self.policy.low_rank_min_rows
        return big and factored is self.factored and pattern is self.pattern

    def changes(self, springs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(kind, contact, Δk) of every spring that differs from K_f's."""
        kind, contact = np.nonzero(springs != self.springs)
        return kind, contact, (springs - self.springs)[kind, contact]

    def solve(
        self, matrix: scipy.sparse.spmatrix, rhs: np.ndarray, springs: np.ndarray
    ) -> np.ndarray | None:
        """x with K x = F by PCG preconditioned with (K_f + U c Uᵀ)⁻¹; None when the
        change has more than the policy's ``low_rank_columns`` springs or PCG does not
        converge."""
        precondition = self._preconditioner(matrix, springs)
        if precondition is None:
            return None
        policy = self.policy
        x, _, converged = pcg(
            matrix, rhs, precondition, policy.pcg_tolerance, policy.low_rank_pcg_iterations
        )
        return x if converged else None

    def _preconditioner(self, matrix, springs) -> Callable[[np.ndarray], np.ndarray] | None:
        """(K_f + U c Uᵀ)⁻¹ as a function, kept for the same K (augmentations of the
        multipliers solve again with an unchanged K)."""
        if self._last is not None and self._last[0] is matrix:
            return self._last[1]
        kind, contact, change = self.changes(springs)
        if len(change) == 0 or len(change) > self.policy.low_rank_columns:
            return None
        at, values = self._columns(kind, contact)
        z = self._inverse_columns(kind, contact, at, values)
        capacitance = np.diag(1.0 / change) + np.einsum("qk,qkr->qr", values, z[at])
        try:
            factors = scipy.linalg.lu_factor(capacitance)
        except (ValueError, scipy.linalg.LinAlgError):
            return None

        solve_many = self._solve_many  # not self: no reference cycle through the closure

        def precondition(b: np.ndarray) -> np.ndarray:
            y = solve_many(b[:, None])[:, 0]
            w = scipy.linalg.lu_solve(factors, np.einsum("qk,qk->q", values, y[at]))
            return y - np.einsum("nr,r->n", z, w)

        self._last = (matrix, precondition)
        return precondition

    def _columns(self, kind: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """U, sparse: for each changed spring the 12 matrix rows of its two blocks and
        its gradient there (a fixed block's rows point at row 0 with zeros)."""
        normal = (kind == 0)[:, None]
        at, values = [], []
        for side, blocks in ((0, self._a), (1, self._b)):
            grad = np.where(
                normal, self._gradients[0][side][contact], self._gradients[1][side][contact]
            )
            row = self._row_of[blocks[contact]]
            free = (row >= 0)[:, None]
            at.append(np.where(free, BLOCK * np.maximum(row, 0)[:, None] + np.arange(BLOCK), 0))
            values.append(np.where(free, grad, 0.0))
        return np.concatenate(at, axis=1), np.concatenate(values, axis=1)

    def _inverse_columns(self, kind, contact, at, values) -> np.ndarray:
        """Z = K_f⁻¹ U (n, r), solving only for the springs not seen before."""
        keys = list(zip(kind.tolist(), contact.tolist(), strict=True))
        new = [q for q, key in enumerate(keys) if key not in self._z]
        if new:
            u = np.zeros((self._size, len(new)), order="F")
            # unbuffered: a fixed block's entries (row 0, value 0) may share row 0 with the
            # other block's (a buffered += kept whichever came last, the zero)
            columns = np.broadcast_to(np.arange(len(new))[:, None], at[new].shape)
            np.add.at(u, (at[new], columns), values[new])
            for q, solved in zip(new, self._solve_many(u).T, strict=True):
                self._z[keys[q]] = solved
        return np.column_stack([self._z[key] for key in keys])
