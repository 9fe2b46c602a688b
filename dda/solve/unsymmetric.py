"""Sparse LU of a general (unsymmetric) matrix whose pattern stays fixed over many
factorisations: MKL PARDISO's real unsymmetric factorisation (matrix type 11, with its
default weighted matching and scaling) where it is installed and not turned off
(``DDA_SOLVER=superlu``), else SuperLU. The fill-reducing ordering is the policy's
``interior_ordering`` (minimum degree). PARDISO's default two steps of iterative
refinement in every solve are off: the interior point computes its residuals afresh
each iteration (the same factorisations on the bench walls and the shipped cases; the
60 × 60 wall's start 4.1 s against 5.1).

The interior-point solve of the equilibrium start (:mod:`dda.solve.interior_point`)
factorises one such matrix per iteration: Coulomb's bound depends on the normal force,
so its Newton matrix is not symmetric.
"""

from __future__ import annotations

import numpy as np
import scipy

from dda.solve.linsolve import new_pardiso_handle, pardiso_available
from dda.solve.pardiso_call import PardisoCall
from dda.solve.policy import current_policy

UNSYMMETRIC = 11  # PARDISO's matrix type: real and unsymmetric


class UnsymmetricLU:
    """Factorise matrices of one CSR ``pattern`` (sorted column indices) and solve with
    the last factorisation. The symbolic analysis is done once, at the first
    :meth:`factor`."""

    def __init__(self, pattern: scipy.sparse.csr_matrix) -> None:
        self.pattern = pattern
        self._pardiso: PardisoCall | None = None
        self._lu = None
        self.analysed = False
        if pardiso_available():
            handle = new_pardiso_handle(current_policy().solver_threads())
            handle.mtype = UNSYMMETRIC
            self._handle = handle
            self._pardiso = PardisoCall(handle, pattern.indptr, pattern.indices)

    def factor(self, values: np.ndarray) -> None:
        """Factorise the matrix of the pattern with the CSR ``values``."""
        if self._pardiso is None:
            matrix = scipy.sparse.csr_matrix((values, self.pattern.indices, self.pattern.indptr),
                                   shape=self.pattern.shape)  # fmt: skip
            from scipy.sparse.linalg import splu

            self._lu = splu(matrix.tocsc())
            return
        self._pardiso.set_values(values)
        if not self.analysed:
            self._pardiso.defaults()
            self._handle.iparm[1] = current_policy().interior_ordering
            self._handle.iparm[7] = 0  # no iterative refinement
            self._pardiso(11, np.zeros(self.pattern.shape[0]))
            self.analysed = True
        self._pardiso(22, np.zeros(self.pattern.shape[0]))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """x with A x = ``rhs``, A the last matrix factorised."""
        if self._pardiso is None:
            return self._lu.solve(rhs)
        return self._pardiso(33, rhs)

    def release(self) -> None:
        """Free PARDISO's memory (phase -1)."""
        if self._pardiso is not None and self.analysed:
            self._pardiso(-1, np.zeros(self.pattern.shape[0]))
            self.analysed = False
