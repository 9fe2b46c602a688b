"""MKL PARDISO's C function called directly, for one analysed sparsity pattern.

pypardiso's ``_call_pardiso`` converts both index arrays to 1-based int32 and
makes eight ctypes pointers on every call (~0.05 ms; the 10x10 wall calls
PARDISO ~20 times a step, 1 ms of its ~10). :class:`PardisoCall` makes them
once per pattern and per matrix, and keeps one right-hand side and one solution
vector with their pointers: a call with one right-hand side copies it in and the
solution out, without making new ones (the equilibrium start's interior point calls
PARDISO about five times an iteration, on small systems a few tens of µs each). The
solver state (``pt``, ``iparm``, ``perm``) stays
in the pypardiso handle, which keeps loading the library and releasing
memory.
"""

from __future__ import annotations

import ctypes

import numpy as np

_INT_POINTER = ctypes.POINTER(ctypes.c_int32)
_DOUBLE_POINTER = ctypes.POINTER(ctypes.c_double)


class PardisoCall:
    """``pardiso(pt, 1, 1, mtype, phase, n, a, ia, ja, perm, nrhs, iparm, 0, b, x, error)``.

    Parameters
    ----------
    handle : a ``pypardiso.PyPardisoSolver`` (its library, ``pt``, ``iparm``,
        ``perm`` and matrix type are used and must outlive this object)
    indptr, indices : the (0-based) CSR structure of the upper triangle
    """

    def __init__(self, handle, indptr: np.ndarray, indices: np.ndarray) -> None:
        self._handle = handle  # keeps pt, iparm and perm alive while their pointers are used
        self._function = handle._mkl_pardiso
        self._defaults = handle.libmkl.pardisoinit  # pardisoinit(pt, mtype, iparm)
        self._ia = np.ascontiguousarray(indptr + 1, dtype=np.int32)
        self._ja = np.ascontiguousarray(indices + 1, dtype=np.int32)
        self._ints = {
            "one": ctypes.c_int32(1),
            "type": ctypes.c_int32(handle.mtype),
            "size": ctypes.c_int32(len(indptr) - 1),
            "quiet": ctypes.c_int32(0),
        }
        self._pt = handle.pt.ctypes.data_as(ctypes.POINTER(handle._pt_type[0]))
        self._pointers = (
            self._ia.ctypes.data_as(_INT_POINTER),
            self._ja.ctypes.data_as(_INT_POINTER),
            handle.perm.ctypes.data_as(_INT_POINTER),
        )
        self._iparm = handle.iparm.ctypes.data_as(_INT_POINTER)
        self._values: np.ndarray | None = None
        self._values_pointer = None
        size = len(indptr) - 1
        self._vectors = np.zeros(size), np.zeros(size)  # one right-hand side, its solution
        self._vector_pointers = tuple(v.ctypes.data_as(_DOUBLE_POINTER) for v in self._vectors)

    def defaults(self) -> None:
        """Fill the handle's ``iparm`` with PARDISO's defaults for its matrix type
        (``pardisoinit``; ``iparm[0]`` = 1: the caller may change any of them before the
        analysis, phase 11). It zeroes ``pt`` too: call it only on a handle that holds
        no analysis (new, or released by phase −1), else PARDISO's memory is lost."""
        self._defaults(self._pt, ctypes.byref(self._ints["type"]), self._iparm)

    def set_values(self, values: np.ndarray) -> None:
        """The matrix values (upper triangle, in the pattern's order) of the next calls."""
        self._values = np.ascontiguousarray(values, dtype=np.float64)
        self._values_pointer = self._values.ctypes.data_as(_DOUBLE_POINTER)

    def __call__(self, phase: int, rhs: np.ndarray) -> np.ndarray:
        """Run ``phase`` with right-hand side(s) ``rhs`` (n,) or (n, r); returns x (C order).

        Raises
        ------
        pypardiso's ``PyPardisoError`` : PARDISO reported an error (its code)
        """
        one = rhs.ndim == 1 and rhs.shape[0] == self._vectors[0].shape[0]
        if one:
            b, x = self._vectors
            b[:] = rhs
            b_pointer, x_pointer = self._vector_pointers
        else:
            b = np.asfortranarray(rhs, dtype=np.float64)
            x = np.zeros_like(b)
            b_pointer, x_pointer = (
                b.ctypes.data_as(_DOUBLE_POINTER),
                x.ctypes.data_as(_DOUBLE_POINTER),
            )
        error = ctypes.c_int32(0)
        ints = self._ints
        ia, ja, perm = self._pointers
        self._function(
            self._pt,
            ctypes.byref(ints["one"]),
            ctypes.byref(ints["one"]),
            ctypes.byref(ints["type"]),
            ctypes.byref(ctypes.c_int32(phase)),
            ctypes.byref(ints["size"]),
            self._values_pointer,
            ia,
            ja,
            perm,
            ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])),
            self._iparm,
            ctypes.byref(ints["quiet"]),
            b_pointer,
            x_pointer,
            ctypes.byref(error),
        )
        if error.value != 0:
            from pypardiso.pardiso_wrapper import PyPardisoError

            raise PyPardisoError(error.value)
        return x.copy() if one else np.ascontiguousarray(x)
