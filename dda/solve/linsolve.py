"""Sparse symmetric solves: one factorisation serves many right-hand sides and,
through preconditioned conjugate gradients, many slightly different matrices.

K changes little from one solve to the next while the contact graph stays
the same (the geometry moves by a fraction of a block per step; a few
contacts change state). The factorisation of an earlier K is then an
excellent preconditioner for the new one: conjugate gradients converge in a
few iterations to the accuracy of a direct solve, at the cost of a few
triangular solves instead of a new factorisation. :class:`ReusingSolver`
re-factorises when that stops paying (too many iterations) or when the
contact graph, hence the sparsity pattern, changes. A small K (a few dozen
blocks) is cheaper to factorise again, densely, than to solve by PCG.
"""

from __future__ import annotations

import copy
import ctypes
import glob
import importlib.util
import logging
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext

import numpy as np
import scipy
from threadpoolctl import ThreadpoolController

from dda.io.environment_variable import environment_variable
from dda.solve.pardiso_call import PardisoCall
from dda.solve.policy import StepPolicy, current_policy

log = logging.getLogger(__name__)

PARDISO_CHOICE = "pardiso"


class Factorisation:
    """A factorised K; ``solve(F)`` re-uses it for any number of right-hand sides.

    SuperLU in symmetric mode without pivoting (K is symmetric positive
    definite), by default with the minimum-degree ordering on Aᵀ+A: about 200
    times faster than SuperLU's defaults on DDA matrices (docs/design.md). Pass
    ``permc_spec="NATURAL"`` for a matrix already in a fill-reducing order.
    """

    def __init__(self, matrix: scipy.sparse.csc_matrix, permc_spec: str = "MMD_AT_PLUS_A") -> None:
        self.size = matrix.shape[0]
        if self.size == 0:
            self._lu = None
            return
        self._lu = _splu(
            matrix,
            permc_spec=permc_spec,
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self._lu is None:
            return np.zeros(0)
        return self._lu.solve(rhs)

    def solve_many(self, columns: np.ndarray) -> np.ndarray:
        """X (n, r) with K X = B for the columns of B."""
        if self._lu is None:
            return np.zeros((0, columns.shape[1]))
        return self._lu.solve(np.asfortranarray(columns))


class DenseFactorisation:
    """K = L Lᵀ by LAPACK's dense Cholesky (``dpotrf``), for small K.

    n³/3 flops and no sparse set-up: at 150 rows 0.07 ms against SuperLU's
    0.22-0.32 ms (the policy's ``dense_factor_rows``). Should LAPACK find K not positive
    definite by round-off (a nearly singular K), SuperLU factorises it, as it
    did before there was a dense path (``permc_spec`` is its ordering). ``matrix``
    is sparse, or a dense array (the small steps' dense systems), left as it is.

    A K of at most ``numpy_rows`` rows (the policy's ``numpy_solve_rows``) is kept as
    it is and each solve is numpy's LU of it (``numpy.linalg.solve``, LAPACK's
    ``dgesv``), so that a run of a few blocks never imports scipy; SuperLU takes a K
    that numpy finds singular.
    """

    def __init__(
        self,
        matrix: scipy.sparse.spmatrix | np.ndarray,
        permc_spec: str = "NATURAL",
        numpy_rows: int = 0,
    ) -> None:
        self.size = matrix.shape[0]
        self.permc_spec = permc_spec
        self._fallback: Factorisation | None = None
        self._matrix: np.ndarray | None = None
        dense = (
            np.array(matrix, dtype=float) if isinstance(matrix, np.ndarray) else matrix.toarray()
        )
        if self.size <= numpy_rows:
            self._matrix = dense
            return
        self._lower, info = scipy.linalg.lapack.dpotrf(dense, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            log.debug("dense Cholesky failed (info %d): SuperLU factorises K", info)
            self._fallback = Factorisation(scipy.sparse.csc_matrix(matrix), permc_spec)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """x with K x = b; ``rhs`` may also be (n, r): X with K X = B."""
        if self._matrix is not None:
            try:
                return np.linalg.solve(self._matrix, rhs)
            except np.linalg.LinAlgError:
                log.debug("numpy found K singular: SuperLU factorises it")
                matrix, self._matrix = self._matrix, None
                self._fallback = Factorisation(scipy.sparse.csc_matrix(matrix), self.permc_spec)
        if self._fallback is not None:
            return self._fallback.solve_many(rhs) if rhs.ndim == 2 else self._fallback.solve(rhs)
        return scipy.linalg.lapack.dpotrs(self._lower, rhs, lower=1)[0]

    solve_many = solve


class PardisoFactorisation:
    """MKL PARDISO through ``pypardiso`` (optional): SPD Cholesky, METIS ordering.

    The symbolic analysis (ordering, elimination tree) is done once for a
    sparsity pattern; :meth:`factor` then only repeats the numeric phase for
    every new matrix with that pattern. Iterative refinement is off: PCG in
    :class:`ReusingSolver` checks the residual itself.

    PARDISO factorises and solves on the threads it analysed with: with fewer it
    factorises wrongly (measured: a 30,000-unknown grid analysed on two threads and
    factorised on one solved to a residual of 174 against 3e-13), and MKL's threaded
    layer was seen to crash reading past its arrays. So every phase runs on the
    analysis' threads, and a factorisation asked for on another count analyses the
    pattern again on that count first.

    Parameters
    ----------
    matrix : a symmetric matrix whose CSR (= CSC) arrays give the pattern
    handle : a ``pypardiso.PyPardisoSolver`` to re-use (its memory is released
        first); creating one looks for the MKL library, which takes a while
    threads : the analysis' threads (the environment's policy when None)
    """

    def __init__(
        self, matrix: scipy.sparse.spmatrix, handle=None, threads: int | None = None
    ) -> None:
        self.size = matrix.shape[0]
        self.threads = current_policy().solver_threads() if threads is None else threads
        if handle is None:
            handle = new_pardiso_handle(self.threads)
        else:
            handle.set_phase(-1)
            handle._call_pardiso(scipy.sparse.csr_matrix((0, 0)), np.zeros(0))
        self._solver = handle
        rows = np.repeat(np.arange(self.size), np.diff(matrix.indptr))
        self._upper = np.flatnonzero(matrix.indices >= rows)
        counts = np.bincount(rows[self._upper], minlength=self.size)
        indptr = np.zeros(self.size + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        self._call = PardisoCall(handle, indptr, matrix.indices[self._upper])
        self._call.set_values(self._upper_values(matrix))
        self._analyse(self.threads)

    def _analyse(self, threads: int) -> None:
        """PARDISO's analysis (phase 11) of the pattern on ``threads``."""
        self.threads = threads
        self._solver.iparm[0] = 0  # PARDISO's defaults ...
        self._on_threads()
        self._call(11, np.zeros(self.size))
        # ... among them iparm[7] = 2, two steps of iterative refinement in every solve
        # (3-4 back-substitutions' cost); set after the defaults are in, so that it holds
        self._solver.iparm[7] = 0

    def _on_threads(self) -> None:
        """This thread's MKL calls on the analysis' threads (MKL keeps the count per thread)."""
        _set_mkl_threads(self._solver.libmkl, self.threads)

    def _upper_values(self, matrix: scipy.sparse.spmatrix) -> np.ndarray:
        return np.asarray(matrix.data)[self._upper]

    def factor(self, matrix: scipy.sparse.spmatrix, threads: int) -> None:
        """Numeric factorisation of a matrix with the analysed pattern, on ``threads``
        (:meth:`dda.solve.policy.StepPolicy.solver_threads`): the pattern is analysed
        again first when they are not the analysis' threads."""
        self._call.set_values(self._upper_values(matrix))
        if threads != self.threads:
            self._analyse(threads)
        self._on_threads()
        self._call(22, np.zeros(self.size))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        self._on_threads()
        return self._call(33, rhs)

    def solve_many(self, columns: np.ndarray) -> np.ndarray:
        """X (n, r) with K X = B, all columns in one call (cheaper per column)."""
        self._on_threads()
        return self._call(33, columns)


_PARDISO_PROTOTYPE = None  # first handle made: later ones copy it (loading MKL takes a while)


def new_pardiso_handle(threads: int):
    """A PARDISO solver handle for symmetric positive definite matrices (defaults unset).

    The calling thread's MKL threads are set to ``threads`` each time (MKL keeps the
    count per thread: a dask worker's task threads differ).
    """
    global _PARDISO_PROTOTYPE
    if _PARDISO_PROTOTYPE is None:
        _point_pypardiso_at_mkl()  # before the import: pypardiso looks for MKL as it loads
        import pypardiso

        _PARDISO_PROTOTYPE = pypardiso.PyPardisoSolver(mtype=2)  # real SPD
    _set_mkl_threads(_PARDISO_PROTOTYPE.libmkl, threads)
    handle = copy.copy(_PARDISO_PROTOTYPE)  # shares the library, not the solver state
    handle.pt = np.zeros_like(_PARDISO_PROTOTYPE.pt)
    handle.iparm = np.zeros_like(_PARDISO_PROTOTYPE.iparm)
    handle.perm = np.zeros(0, dtype=np.int32)
    return handle


OPENBLAS_THREADS = "OPENBLAS_NUM_THREADS"  # read by an OpenBLAS as it loads


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Within the block numpy's and scipy's OpenBLAS use one thread; restored after.

    The engine's BLAS calls are small (dot products of one K-sized vector,
    16 x 16 capacitance matrices), but a vector of 60,000 numbers wakes
    OpenBLAS's threads, which then spin on the cores PARDISO's threads solve
    on (at 10,000 blocks a back-substitution took twice as long). MKL, which
    PARDISO uses, keeps its own count (:meth:`dda.solve.policy.StepPolicy.solver_threads`).
    The controller limits the libraries loaded when it is made; an OpenBLAS that the run
    loads (scipy's, with ``scipy.linalg``) reads ``OPENBLAS_NUM_THREADS``, set to 1 for
    the block, and is given the threads of the others after it (left to its default,
    it ran the first run of a process that loaded it on two threads, whose sums differ
    from one thread's in the last bits: that run was not repeated by the next).
    """
    controller = _openblas_pools()
    known = {pool.filepath for pool in controller.lib_controllers}
    threads = max((pool.num_threads for pool in controller.lib_controllers), default=None)
    try:
        with environment_variable(OPENBLAS_THREADS, "1"), controller.limit(limits=1):
            yield
    finally:
        for pool in _openblas_pools().lib_controllers:
            if pool.filepath not in known and threads is not None:
                pool.set_num_threads(threads)


_OPENBLAS_POOLS: dict[str, object] = {"modules": -1, "controller": None}


def _openblas_pools() -> ThreadpoolController:
    """The process's OpenBLAS thread pools, looked for again only when a module has been
    imported since the last look (a library loads with the module that needs it).

    threadpoolctl finds them by a walk over every loaded library: 1.5 ms, done twice a
    run, where a 32-block slope's equilibrium start takes 15 ms."""
    if len(sys.modules) != _OPENBLAS_POOLS["modules"]:
        _OPENBLAS_POOLS["controller"] = ThreadpoolController().select(internal_api="openblas")
        _OPENBLAS_POOLS["modules"] = len(sys.modules)
    return _OPENBLAS_POOLS["controller"]


def _point_pypardiso_at_mkl() -> None:
    """Name the MKL library pip installs beside Python in ``PYPARDISO_MKL_RT``.

    pip puts ``libmkl_rt.so`` in ``<prefix>/lib`` of the environment whose
    ``site-packages`` holds the ``mkl`` package: this one's, or another one's that
    this environment sees through a ``.pth`` file or ``PYTHONPATH``. Without it
    pypardiso searches only the whole of ``sys.prefix/lib`` (~0.3 s per process
    here) and misses the second case; an existing ``PYPARDISO_MKL_RT`` is kept.
    """
    if os.environ.get("PYPARDISO_MKL_RT"):
        return
    prefixes = [sys.prefix, sys.base_prefix]
    prefixes += [
        os.path.dirname(os.path.dirname(os.path.dirname(entry)))  # <prefix>/lib/pythonX.Y/...
        for entry in sys.path
        if os.path.basename(entry) == "site-packages"
    ]
    for prefix in dict.fromkeys(prefixes):
        found = sorted(glob.glob(os.path.join(prefix, "lib", "libmkl_rt.so*")), key=len)
        if found:
            os.environ["PYPARDISO_MKL_RT"] = found[0]
            return


def _set_mkl_threads(library, threads: int) -> None:
    """Threads of this thread's MKL calls (:meth:`dda.solve.policy.StepPolicy.solver_threads`)."""
    try:
        set_threads = library.MKL_Set_Num_Threads_Local
    except AttributeError:  # pragma: no cover - older MKL
        log.debug("MKL_Set_Num_Threads_Local not available")
        return
    set_threads.argtypes, set_threads.restype = [ctypes.c_int], ctypes.c_int
    set_threads(threads)


def pardiso_available(policy: StepPolicy | None = None) -> bool:
    """True when ``pypardiso`` is installed and the policy's ``DDA_SOLVER`` does not ask
    for SuperLU (``policy``: the environment's when None).

    Nothing is imported: pypardiso (and MKL) load when a system of more than
    ``dense_factor_rows`` rows is first factorised, so small runs never pay for them.
    """
    policy = current_policy() if policy is None else policy
    if policy.solver == "superlu":
        return False
    return importlib.util.find_spec("pypardiso") is not None


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
    graph = scipy.sparse.csc_matrix((values, (rows, cols)), shape=(nfree, nfree))
    lu = _splu(
        graph, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    return np.asarray(lu.perm_c, dtype=np.int64)


def _splu(matrix: scipy.sparse.spmatrix, **options):
    """SuperLU (``scipy.sparse.linalg.splu``), imported at the first use: a run of one or
    two free blocks with a dense K never needs it."""
    from scipy.sparse.linalg import splu

    return splu(matrix, **options)


def pcg(
    matrix: scipy.sparse.spmatrix,
    rhs: np.ndarray,
    preconditioner: Callable[[np.ndarray], np.ndarray],
    tolerance: float,
    max_iterations: int,
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
    the policy's ``max_pcg_iterations`` and :attr:`pcg_budget` (the iterations that cost as much
    as a factorisation, :meth:`~dda.solve.policy.StepPolicy.pcg_budget`), factorise K
    and solve directly. A solve that needed more than the policy's ``refresh_after`` iterations
    marks the factorisation stale: the next new matrix is factorised. A caller that
    knows the new K is far from the factorised one (many contacts changed state) says
    ``similar=False`` and skips the PCG attempt.

    The factorisation is PARDISO's (numeric phase only, analysis once per
    pattern) when ``pypardiso`` is installed and K has more than the policy's
    ``dense_factor_rows`` rows, else SuperLU's (:func:`pardiso_available`).
    Chosen automatically (``backend=None``), a K of at most ``dense_factor_rows``
    rows gets a dense Cholesky instead, and every new K is factorised.

    Parameters
    ----------
    permc_spec : SuperLU column ordering ("NATURAL" when K comes pre-ordered)
    backend : "pardiso", "superlu" (for every size they cover) or None
        (dense for small K, then PARDISO when available)
    policy : the PCG settings, the dense size and the solver's threads
        (:class:`dda.solve.policy.StepPolicy`; the environment's when None)
    """

    def __init__(
        self,
        permc_spec: str = "NATURAL",
        backend: str | None = None,
        policy: StepPolicy | None = None,
    ) -> None:
        self.policy = current_policy() if policy is None else policy
        self.permc_spec = permc_spec
        self.automatic = backend is None  # small K: dense
        if backend is None:
            backend = PARDISO_CHOICE if pardiso_available(self.policy) else "superlu"
        self.backend = backend
        self._factor: Factorisation | DenseFactorisation | PardisoFactorisation | None = None
        self._factored: scipy.sparse.spmatrix | None = None
        self._key: object = None
        self._analysed_key: object = None
        self._stale = False
        self._handle = None
        self.factorisations = 0
        self.pcg_iterations = 0
        self.pcg_solves = 0

    def reset(self) -> None:
        """Forget the factorisation (the next solve factorises)."""
        self._factor, self._factored, self._key, self._analysed_key = None, None, None, None

    def learned(self) -> dict[str, object]:
        """What the solver learned that a resumed run needs (:mod:`dda.run.checkpoint`):
        the kept factorisation's pattern key, whether it is stale, and the PCG counts."""
        return {
            "key": self._key,
            "stale": self._stale,
            "pcg_iterations": self.pcg_iterations,
            "pcg_solves": self.pcg_solves,
        }

    def resume(self, learned: dict[str, object], matrix: scipy.sparse.csc_matrix | None) -> None:
        """The state :meth:`learned` gave, with ``matrix`` (the one the interrupted run had
        factorised, or None) factorised again: the resumed run's next solves (PCG on that
        factorisation) repeat those of the uninterrupted run. The count of
        factorisations is left as it was."""
        if matrix is not None:
            made = self.factorisations
            self.reset()
            self._factorise(matrix, learned["key"])
            self._stale, self.factorisations = bool(learned["stale"]), made
        self.pcg_iterations = int(learned["pcg_iterations"])
        self.pcg_solves = int(learned["pcg_solves"])

    @property
    def pcg_budget(self) -> int:
        """PCG iterations that cost no more than a factorisation of the kept kind.

        At most the policy's ``max_pcg_iterations``; 0 or 1 means PCG does not pay (then
        it is not tried).
        """
        if isinstance(self._factor, DenseFactorisation):
            return self.policy.pcg_budget("dense", self._factor.size)
        if isinstance(self._factor, PardisoFactorisation):
            return self.policy.pcg_budget("pardiso", self._factor.size)
        size = 0 if self._factored is None else self._factored.shape[0]
        return self.policy.pcg_budget("superlu", size)

    def solve_many(self, columns: np.ndarray) -> np.ndarray:
        """X (n, r) with K_f X = B, K_f the factorised matrix."""
        return self._factor.solve_many(columns)

    def solve_kept(self, rhs: np.ndarray, key: object) -> np.ndarray | None:
        """K_f⁻¹ F with the kept factorisation K_f when it is of pattern ``key``, else None."""
        if self._factor is None or key is None or key != self._key:
            return None
        return self._factor.solve(rhs)

    @property
    def factored(self) -> scipy.sparse.spmatrix | None:
        """The matrix of the kept factorisation."""
        return self._factored

    def solve(
        self,
        matrix: scipy.sparse.csc_matrix,
        rhs: np.ndarray,
        key: object = None,
        timer=None,
        similar: bool = True,
    ) -> np.ndarray:
        """x with K x = F to the accuracy of a direct solve.

        Parameters
        ----------
        matrix : K (symmetric positive definite, CSC)
        rhs : F
        key : identity of K's sparsity pattern (None: assume it may differ)
        timer : optional :class:`dda.solve.timing.StageTimer` ("factorisation", "solve")
        similar : False when K is known to differ much from the factorised matrix
        """
        stage = timer if timer is not None else (lambda name: nullcontext())
        reusable = self._factor is not None and key is not None and key == self._key
        if reusable and matrix is self._factored:
            with stage("solve"):
                return self._factor.solve(rhs)
        budget = self.pcg_budget
        if reusable and similar and not self._stale and budget >= 2:
            with stage("solve"):
                x, iterations, ok = pcg(
                    matrix, rhs, self._factor.solve, self.policy.pcg_tolerance, budget
                )
            self.pcg_iterations += iterations
            self.pcg_solves += 1
            if ok:
                self._stale = iterations > self.policy.refresh_after
                return x
            log.debug("PCG did not converge in %d iterations: re-factorising", iterations)
        with stage("factorisation"):
            self._factorise(matrix, key)
        with stage("solve"):
            return self._factor.solve(rhs)

    def _factorise(self, matrix: scipy.sparse.csc_matrix, key: object) -> None:
        dense_rows = self.policy.dense_factor_rows
        if self.backend == PARDISO_CHOICE and matrix.shape[0] > dense_rows:
            threads = self.policy.solver_threads()  # once: the analysis' and the factor's
            fresh = not isinstance(self._factor, PardisoFactorisation)
            if fresh or key is None or key != self._analysed_key:
                if self._handle is None:
                    self._handle = new_pardiso_handle(threads)
                self._factor = PardisoFactorisation(matrix, self._handle, threads)
                self._analysed_key = key
            self._factor.factor(matrix, threads)
        elif self.automatic and 0 < matrix.shape[0] <= dense_rows:
            self._factor = DenseFactorisation(matrix, self.permc_spec, self.policy.numpy_solve_rows)
        else:
            self._factor = Factorisation(matrix, self.permc_spec)
        self._factored, self._key, self._stale = matrix, key, False
        self.factorisations += 1
