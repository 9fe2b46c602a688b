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
import scipy.sparse as sp
from scipy.linalg import lapack
from threadpoolctl import ThreadpoolController

from dda.solve import thread_policy
from dda.solve.pardiso_call import PardisoCall

log = logging.getLogger(__name__)

RELATIVE_TOLERANCE = 1e-13  # PCG stops at ‖F - K x‖ ≤ this · ‖F‖ (a direct solve's level)
MAX_PCG_ITERATIONS = 12  # beyond this a new factorisation is cheaper (and is made)
# PCG iterations that cost as much as a factorisation, per backend: measured on
# the wall benchmark (SuperLU up to 10x10 blocks: 9-12; PARDISO at 30x30: 3-4).
# Fixed numbers rather than timings taken during the run, so that a run's
# result never depends on how busy the machine was.
# A dense factorisation costs about 5 of its back-substitutions and a PCG iteration's Python
# ~0.03 ms on top: PCG does not pay (budget 0, it is not tried).
PCG_BUDGET = {"superlu": MAX_PCG_ITERATIONS, "pardiso": 3, "dense": 0}
# A factorisation grows faster with the size than a back-substitution: at 60,000 rows
# (100x100 wall) PARDISO's factorisation and solve cost ~5.5 back-substitutions.
PARDISO_LARGE = 20_000  # rows from which the larger budget applies
PCG_BUDGET_PARDISO_LARGE = 5
REFRESH_AFTER = 4  # a solve that needed more iterations marks the factor stale
# up to this many rows: a dense Cholesky. 150 rows (5x5 wall): 0.07 ms against SuperLU's
# 0.22-0.32 (its set-up dominates); 294 rows: 0.30 against 0.55-0.63, but each solve then
# costs 0.045 against 0.029 and PCG on a kept factorisation no longer pays
DENSE_MAX_SIZE = 240
# larger systems: PARDISO. It factorises 4-5x faster than SuperLU from 600 rows up (10x10
# wall: 0.38 against 1.7 ms; tunnel case, 1200 rows: 0.45 against 2.5 ms) and solves as
# fast, but analyses each new pattern; at 294 rows (7x7 wall, 100 steps, one thread, six
# interleaved runs) the run takes 7.5-10.5 ms a step against SuperLU's 9.2-12.2. SuperLU
# factorises where PARDISO is not installed (or DDA_SOLVER asks for it)
PARDISO_MIN_SIZE = DENSE_MAX_SIZE + 1
THREADS_VARIABLE = "DDA_THREADS"  # environment variable: threads of PARDISO's factorisation
SOLVER_VARIABLE, SOLVER_CHOICES = "DDA_SOLVER", ("pardiso", "superlu")  # sparse solver
# every step's systems on the sparse block pattern (the path of large models), whatever
# the model's size: for checking that path on small models (dda verify's cradle_sparse)
SYSTEMS_VARIABLE, SYSTEMS_CHOICES = "DDA_SYSTEMS", ("sparse",)


class Factorisation:
    """A factorised K; ``solve(F)`` re-uses it for any number of right-hand sides.

    SuperLU in symmetric mode without pivoting (K is symmetric positive
    definite), by default with the minimum-degree ordering on Aᵀ+A: about 200
    times faster than SuperLU's defaults on DDA matrices (docs/design.md). Pass
    ``permc_spec="NATURAL"`` for a matrix already in a fill-reducing order.
    """

    def __init__(self, matrix: sp.csc_matrix, permc_spec: str = "MMD_AT_PLUS_A") -> None:
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
    0.22-0.32 ms (:data:`DENSE_MAX_SIZE`). Should LAPACK find K not positive
    definite by round-off (a nearly singular K), SuperLU factorises it, as it
    did before there was a dense path (``permc_spec`` is its ordering). ``matrix``
    is sparse, or a dense array (the small steps' dense systems), left as it is.
    """

    def __init__(self, matrix: sp.spmatrix | np.ndarray, permc_spec: str = "NATURAL") -> None:
        self.size = matrix.shape[0]
        self._fallback: Factorisation | None = None
        dense = matrix.toarray() if sp.issparse(matrix) else np.array(matrix, dtype=float)
        self._lower, info = lapack.dpotrf(dense, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            log.debug("dense Cholesky failed (info %d): SuperLU factorises K", info)
            self._fallback = Factorisation(sp.csc_matrix(matrix), permc_spec)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """x with K x = b; ``rhs`` may also be (n, r): X with K X = B."""
        if self._fallback is not None:
            return self._fallback.solve_many(rhs) if rhs.ndim == 2 else self._fallback.solve(rhs)
        return lapack.dpotrs(self._lower, rhs, lower=1)[0]

    solve_many = solve


class PardisoFactorisation:
    """MKL PARDISO through ``pypardiso`` (optional): SPD Cholesky, METIS ordering.

    The symbolic analysis (ordering, elimination tree) is done once for a
    sparsity pattern; :meth:`factor` then only repeats the numeric phase for
    every new matrix with that pattern. Iterative refinement is off: PCG in
    :class:`ReusingSolver` checks the residual itself.

    Parameters
    ----------
    matrix : a symmetric matrix whose CSR (= CSC) arrays give the pattern
    handle : a ``pypardiso.PyPardisoSolver`` to re-use (its memory is released
        first); creating one looks for the MKL library, which takes a while
    """

    def __init__(self, matrix: sp.spmatrix, handle=None) -> None:
        self.size = matrix.shape[0]
        if handle is None:
            handle = new_pardiso_handle()
        else:
            handle.set_phase(-1)
            handle._call_pardiso(sp.csr_matrix((0, 0)), np.zeros(0))
        self._solver = handle
        rows = np.repeat(np.arange(self.size), np.diff(matrix.indptr))
        self._upper = np.flatnonzero(matrix.indices >= rows)
        counts = np.bincount(rows[self._upper], minlength=self.size)
        indptr = np.zeros(self.size + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        self._call = PardisoCall(handle, indptr, matrix.indices[self._upper])
        self._call.set_values(self._upper_values(matrix))
        self._call(11, np.zeros(self.size))  # analysis; iparm[0] = 0: PARDISO's defaults ...
        # ... among them iparm[7] = 2, two steps of iterative refinement in every solve
        # (3-4 back-substitutions' cost); set after the defaults are in, so that it holds
        self._solver.iparm[7] = 0

    def _upper_values(self, matrix: sp.spmatrix) -> np.ndarray:
        return np.asarray(matrix.data)[self._upper]

    def factor(self, matrix: sp.spmatrix) -> None:
        """Numeric factorisation of a matrix with the analysed pattern, on the threads
        :func:`solver_threads` gives now."""
        _set_mkl_threads(self._solver.libmkl, solver_threads())
        self._call.set_values(self._upper_values(matrix))
        self._call(22, np.zeros(self.size))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self._call(33, rhs)

    def solve_many(self, columns: np.ndarray) -> np.ndarray:
        """X (n, r) with K X = B, all columns in one call (cheaper per column)."""
        return self._call(33, columns)


_PARDISO_PROTOTYPE = None  # first handle made: later ones copy it (loading MKL takes a while)


def new_pardiso_handle():
    """A PARDISO solver handle for symmetric positive definite matrices (defaults unset).

    The calling thread's MKL threads are set to :func:`solver_threads` each time
    (MKL keeps the count per thread: a dask worker's task threads differ).
    """
    global _PARDISO_PROTOTYPE
    if _PARDISO_PROTOTYPE is None:
        _point_pypardiso_at_mkl()  # before the import: pypardiso looks for MKL as it loads
        import pypardiso

        _PARDISO_PROTOTYPE = pypardiso.PyPardisoSolver(mtype=2)  # real SPD
    _set_mkl_threads(_PARDISO_PROTOTYPE.libmkl, solver_threads())
    handle = copy.copy(_PARDISO_PROTOTYPE)  # shares the library, not the solver state
    handle.pt = np.zeros_like(_PARDISO_PROTOTYPE.pt)
    handle.iparm = np.zeros_like(_PARDISO_PROTOTYPE.iparm)
    handle.perm = np.zeros(0, dtype=np.int32)
    return handle


def solver_threads() -> int:
    """Threads for PARDISO: ``DDA_THREADS`` if set, else the cores the machine can give
    now (:mod:`dda.solve.thread_policy`: the usable cores less those other processes
    kept busy over the last second).

    On the idle 2-core benchmark machine two threads factorise the 30x30 wall's K in
    4.3 ms instead of 9.5; with another process busy on one core, one thread is the
    faster (docs/benchmarks.md). ``DDA_THREADS=1`` makes a run repeat bit for bit;
    processes that share the cores (``dda tradeoff``'s workers) set it.

    Raises
    ------
    ValueError : ``DDA_THREADS`` is not a positive integer
    """
    text = os.environ.get(THREADS_VARIABLE, "").strip()
    if not text:
        return thread_policy.POLICY.threads()
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"{THREADS_VARIABLE}={text!r}: expected a positive integer (threads)")
    return int(text)


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Within the block numpy's and scipy's OpenBLAS use one thread; restored after.

    The engine's BLAS calls are small (dot products of one K-sized vector,
    16 x 16 capacitance matrices), but a vector of 60,000 numbers wakes
    OpenBLAS's threads, which then spin on the cores PARDISO's threads solve
    on (at 10,000 blocks a back-substitution took twice as long). MKL, which
    PARDISO uses, keeps its own count (:func:`solver_threads`).
    """
    with ThreadpoolController().select(internal_api="openblas").limit(limits=1):
        yield


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
    """Threads of this thread's MKL calls (see :func:`solver_threads`)."""
    try:
        set_threads = library.MKL_Set_Num_Threads_Local
    except AttributeError:  # pragma: no cover - older MKL
        log.debug("MKL_Set_Num_Threads_Local not available")
        return
    set_threads.argtypes, set_threads.restype = [ctypes.c_int], ctypes.c_int
    set_threads(threads)


def pardiso_available() -> bool:
    """True when ``pypardiso`` is installed and ``DDA_SOLVER`` does not ask for SuperLU.

    Nothing is imported: pypardiso (and MKL) load when a system of
    ``PARDISO_MIN_SIZE`` rows is first factorised, so small runs never pay for them.
    """
    if solver_choice() == "superlu":
        return False
    return importlib.util.find_spec("pypardiso") is not None


def solver_choice() -> str:
    """``DDA_SOLVER`` (lower case, blanks stripped): "pardiso", "superlu" or "" (not set:
    PARDISO when installed).

    Raises
    ------
    ValueError : any other value (a misspelt choice would otherwise go unnoticed)
    """
    text = os.environ.get(SOLVER_VARIABLE, "").strip().lower()
    if text and text not in SOLVER_CHOICES:
        choices = " or ".join(SOLVER_CHOICES)
        raise ValueError(f"{SOLVER_VARIABLE}={text!r}: expected {choices} (or leave it unset)")
    return text


def systems_choice() -> str:
    """``DDA_SYSTEMS`` (lower case, blanks stripped): "sparse" (every step's systems on
    the sparse block pattern) or "" (not set: band, dense or sparse by the step's size
    and whether the kernels are used, :mod:`dda.solve.step`).

    Raises
    ------
    ValueError : any other value
    """
    text = os.environ.get(SYSTEMS_VARIABLE, "").strip().lower()
    if text and text not in SYSTEMS_CHOICES:
        choices = " or ".join(SYSTEMS_CHOICES)
        raise ValueError(f"{SYSTEMS_VARIABLE}={text!r}: expected {choices} (or leave it unset)")
    return text


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
    lu = _splu(
        graph, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    return np.asarray(lu.perm_c, dtype=np.int64)


def _splu(matrix: sp.spmatrix, **options):
    """SuperLU (``scipy.sparse.linalg.splu``), imported at the first use: a run of one or
    two free blocks with a dense K never needs it."""
    from scipy.sparse.linalg import splu

    return splu(matrix, **options)


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
    ``max_iterations`` and :attr:`pcg_budget` (the iterations that cost as much
    as a factorisation, ``PCG_BUDGET``), factorise K and solve directly. A solve that needed
    more than ``refresh_after`` iterations marks the factorisation stale: the
    next new matrix is factorised. A caller that knows the new K is far from
    the factorised one (many contacts changed state) says ``similar=False``
    and skips the PCG attempt.

    The factorisation is PARDISO's (numeric phase only, analysis once per
    pattern) when ``pypardiso`` is installed and K has at least
    ``PARDISO_MIN_SIZE`` rows, else SuperLU's (:func:`pardiso_available`).
    Chosen automatically (``backend=None``), a K of at most ``DENSE_MAX_SIZE``
    rows gets a dense Cholesky instead, and every new K is factorised.

    Parameters
    ----------
    permc_spec : SuperLU column ordering ("NATURAL" when K comes pre-ordered)
    tolerance, max_iterations, refresh_after : PCG settings (see module constants)
    backend : "pardiso", "superlu" (for every size they cover) or None
        (dense for small K, then PARDISO when available)
    """

    def __init__(
        self,
        permc_spec: str = "NATURAL",
        tolerance: float = RELATIVE_TOLERANCE,
        max_iterations: int = MAX_PCG_ITERATIONS,
        refresh_after: int = REFRESH_AFTER,
        backend: str | None = None,
    ) -> None:
        self.permc_spec = permc_spec
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.refresh_after = refresh_after
        self.automatic = backend is None  # small K: dense
        if backend is None:
            backend = "pardiso" if pardiso_available() else "superlu"
        self.backend = backend
        self._factor: Factorisation | DenseFactorisation | PardisoFactorisation | None = None
        self._factored: sp.spmatrix | None = None
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

    def refactor(self, matrix: sp.csc_matrix, key: object, stale: bool = False) -> None:
        """Make ``matrix``, of pattern ``key``, the kept factorisation, as a run had it.

        A run resumed from a checkpoint (:mod:`dda.run.checkpoint`) factorises the
        matrix the interrupted run had factorised: its next solves (PCG on
        that factorisation) repeat those of the uninterrupted run. Counts of
        factorisations and PCG iterations are left as they were.
        """
        made = self.factorisations
        self.reset()
        self._factorise(matrix, key)
        self._stale, self.factorisations = stale, made

    @property
    def pcg_budget(self) -> int:
        """PCG iterations that cost no more than a factorisation of the kept kind.

        At most ``max_iterations``; 0 or 1 means PCG does not pay (then it is not tried).
        """
        if isinstance(self._factor, DenseFactorisation):
            budget = PCG_BUDGET["dense"]
        elif isinstance(self._factor, PardisoFactorisation):
            large = self._factor.size >= PARDISO_LARGE
            budget = PCG_BUDGET_PARDISO_LARGE if large else PCG_BUDGET["pardiso"]
        else:
            budget = PCG_BUDGET["superlu"]
        return min(self.max_iterations, budget)

    def solve_many(self, columns: np.ndarray) -> np.ndarray:
        """X (n, r) with K_f X = B, K_f the factorised matrix."""
        return self._factor.solve_many(columns)

    def solve_kept(self, rhs: np.ndarray, key: object) -> np.ndarray | None:
        """K_f⁻¹ F with the kept factorisation K_f when it is of pattern ``key``, else None."""
        if self._factor is None or key is None or key != self._key:
            return None
        return self._factor.solve(rhs)

    @property
    def factored(self) -> sp.spmatrix | None:
        """The matrix of the kept factorisation."""
        return self._factored

    def solve(
        self,
        matrix: sp.csc_matrix,
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
                x, iterations, ok = pcg(matrix, rhs, self._factor.solve, self.tolerance, budget)
            self.pcg_iterations += iterations
            self.pcg_solves += 1
            if ok:
                self._stale = iterations > self.refresh_after
                return x
            log.debug("PCG did not converge in %d iterations: re-factorising", iterations)
        with stage("factorisation"):
            self._factorise(matrix, key)
        with stage("solve"):
            return self._factor.solve(rhs)

    def _factorise(self, matrix: sp.csc_matrix, key: object) -> None:
        if self.backend == "pardiso" and matrix.shape[0] >= PARDISO_MIN_SIZE:
            fresh = not isinstance(self._factor, PardisoFactorisation)
            if fresh or key is None or key != self._analysed_key:
                if self._handle is None:
                    self._handle = new_pardiso_handle()
                self._factor = PardisoFactorisation(matrix, self._handle)
                self._analysed_key = key
            self._factor.factor(matrix)
        elif self.automatic and 0 < matrix.shape[0] <= DENSE_MAX_SIZE:
            self._factor = DenseFactorisation(matrix, self.permc_spec)
        else:
            self._factor = Factorisation(matrix, self.permc_spec)
        self._factored, self._key, self._stale = matrix, key, False
        self.factorisations += 1
