"""Every threshold of a step in one place: :class:`StepPolicy`, and the environment
variables read into it.

A run reads its policy once, at its start (:meth:`StepPolicy.from_environment`); the
step, its systems and the sparse solver take each threshold from it
(:class:`dda.solve.step.LinearCache` carries it). The numbers were measured on the
benchmark walls and the shipped cases; the comment above each field says how.
docs/design.md lists them in one table.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, replace

from dda.jit import NO_NUMBA_VARIABLE
from dda.solve import thread_policy

THREADS_VARIABLE = "DDA_THREADS"  # threads of PARDISO's factorisation
SOLVER_VARIABLE, SOLVER_CHOICES = "DDA_SOLVER", ("pardiso", "superlu")  # sparse solver
# every step's systems on the sparse block pattern (the path of large models), whatever
# the model's size: for checking that path on small models (dda verify's cradle_sparse)
SYSTEMS_VARIABLE, SYSTEMS_CHOICES = "DDA_SYSTEMS", ("sparse",)
NO_NUMBA_CHOICES = ("0", "1")  # of DDA_NO_NUMBA (dda.jit.numba_enabled reads it)


@dataclass(frozen=True)
class SizeRules:
    """How a step of a system of a given size spends its linear solves.

    rate : chord steps go on while each leaves at most this fraction of ‖∇Π‖
    chord_first : a pass on new friction bounds or multipliers that goes on from an
        unfinished one, or from a converged one the law's update moved, starts with a
        chord step (``minimise(chord_first=True)``), not a Newton iteration
    bounds_every_solve : the friction bounds follow the normal forces after every
        linear solve (else after :attr:`StepPolicy.inner_solves`)
    conjugate : successive chord steps are conjugated (``minimise(conjugate=True)``)
    """

    rate: float
    chord_first: bool
    bounds_every_solve: bool
    conjugate: bool = False


@dataclass(frozen=True)
class StepPolicy:
    """The thresholds of a step and the environment's choices (module docstring)."""

    # ---------------------------------------------------------------- the outer loop
    # Newton iterations and chord steps on one set of friction bounds before the bounds
    # follow the normal forces (measured, tunnel 0.3 s / 50x50 wall: 3 gives 24 solves a
    # step and no cut step / 152 ms a step; 2 gives 30 and one cut step / 147 ms)
    inner_solves: int = 3
    # ... and on a step's first bounds while some are a guess (contacts found touching, no
    # force known): measured on the tunnel, the staged tunnel and the slope (solves a step,
    # cut steps): 3 gives 21.0, 10.3, 4.37 and 3 cuts (one of them the tunnel's step 1);
    # 6 gives 17.7, 13.6, 4.46 and 1 (the tunnel's step 71, bounds that stall); to
    # convergence 18.9, 14.5, 4.42 and 1 (the staged tunnel's step 1, out of iterations)
    guessed_bound_solves: int = 6

    # ---------------------------------------------------------------- Newton
    # converged when ‖∇Π‖ ≤ this · (‖K₀D‖ + ‖F₀‖ + ‖contact forces‖)
    newton_tolerance: float = 1e-4
    # a chord step that leaves more than this fraction of ‖∇Π‖ is followed by a Newton
    # iteration (the 30x30 wall: 0.25 measured no better)
    chord_rate: float = 0.5
    # from this many rows (below large_rows), in dynamic steps: conjugated chord steps
    # and a pass on new bounds starting with one, while each leaves at most
    # mid_chord_rate. The 265-block tunnel (1,590 rows; its hard steps are many passes
    # on friction bounds whose pieces flip) takes 4.73 Newton iterations a step instead
    # of 6.39 (1 thread; 3.75 instead of 6.17 with 2) and 14.7 linear solves instead of
    # 11.1, at about the same CPU time (three interleaved runs each, loaded machine:
    # 15.5 / 17.5 / 17.6 s against 15.1 / 17.5 / 14.8 s); the staged tunnel 2.03
    # instead of 2.82. At 0.7 it was 5.98, at 0.99 4.08 with 18.9 solves
    mid_rows: int = 1_000
    mid_chord_rate: float = 0.85
    # in systems of this many rows or more, where a factorisation costs many
    # back-substitutions and a Newton iteration's other work, conjugated chord steps go
    # on while each leaves at most large_chord_rate (interleaved dda bench runs, two
    # each: 30x30 wall 29.7 / 28.8 -> 26.6 / 25.2 ms/step with 1.95 factorisations a
    # step instead of 3.4; at 0.95 27.7-28.2 with 2.3; unconjugated at 0.97 it was 10 %
    # slower than at 0.85; 20x20, 2,400 rows, 16.2 / 15.1 -> 14.4 / 12.9 with 1.9
    # instead of 4.0; 10x10, 600 rows, 7.15 / 7.07 -> 7.34 / 7.48 with 3.0 instead of
    # 5.0. The 265-block tunnel, 1,590 rows, is no faster with conjugated chord steps
    # at 0.99 (four runs each: 8.1 s -> 8.2 s) and slower with a pass starting with a
    # chord step, so smaller systems keep plain chord steps at chord_rate)
    large_rows: int = 2_000
    large_chord_rate: float = 0.99
    # from this many rows, where a factorisation costs tens of chord steps, the friction
    # bounds follow the normal forces after every solve and chord steps go on while they
    # make any headway (interleaved dda bench runs against the conjugated rules above,
    # two each: 50x50 wall, 15,000 rows, 99.0/105.3 against 93.5/87.8 ms/step; 60x60,
    # 21,600 rows, 153.7/176.7 against 145.0/159.1; 70x70, 29,400 rows, 176.0/191.7
    # against 184.1/203.0; 100x100 503.5/545.7 against 527.0/567.7)
    huge_rows: int = 25_000
    huge_chord_rate: float = 0.99
    # Band systems, whose Newton passes and law updates run compiled (dda.solve.band_step),
    # pay for a factorisation with about ten chord steps at any size: in dynamic steps they
    # take the mid rules below mid_rows and the large ones from there (CPU ms a step, one
    # solver thread, three interleaved runs each, medians, small / mid / large rules:
    # 3 x 3 wall 1.41 / 1.19 / 1.48, 5 x 5 1.79 / 1.66 / 1.75, 7 x 7 2.42 / 1.87 / 2.40,
    # 10 x 10 5.75 / 5.05 / 5.04, the rock slope 3.29 / 2.85 / 2.68; from 1,000 rows,
    # mid / large: 15 x 15 13.4 / 11.4, the tunnel 20.3 / 19.0)

    # ---------------------------------------------------------------- the systems
    # largest number of free unknowns the numpy Newton holds dense (30 blocks): a dense
    # Cholesky costs n³/3 flops against the block pattern's set-up; CPU a step,
    # interleaved runs: the 5x5 wall (150 unknowns) 10-15 % less held dense, the 6x6
    # (210) even, the 8x8 (384) 1.9x more
    dense_system_rows: int = 180
    # largest n kd² of a band system (a factorisation's flops): above it the sparse path
    # (measured with the step's loop compiled, docs/benchmarks.md: the 25 x 25 wall,
    # 9.0e7, is 10-20 % faster in band, the 30 x 30, 1.85e8, 27 % slower)
    band_work: float = 1e8
    # a band numbering is made again when the band it gives has grown past this factor
    # of its own
    reorder_growth: float = 1.5
    # a new block pattern keeps the old one's pairs up to this many per needed pair
    spare_pairs: float = 1.25
    # a new block pattern holds the pairs of boxes this close (x search distance)
    neighbour_margin: float = 0.1

    # ---------------------------------------------------------------- the sparse solver
    # up to this many rows an assembled K is factorised by a dense Cholesky. 150 rows
    # (5x5 wall): 0.07 ms against SuperLU's 0.22-0.32 (its set-up dominates); 294 rows:
    # 0.30 against 0.55-0.63, but each solve then costs 0.045 against 0.029 and PCG on a
    # kept factorisation no longer pays. Larger systems: PARDISO. It factorises 4-5x
    # faster than SuperLU from 600 rows up (10x10 wall: 0.38 against 1.7 ms; tunnel
    # case, 1200 rows: 0.45 against 2.5 ms) and solves as fast, but analyses each new
    # pattern; at 294 rows (7x7 wall, 100 steps, one thread, six interleaved runs) the
    # run takes 7.5-10.5 ms a step against SuperLU's 9.2-12.2. SuperLU factorises where
    # PARDISO is not installed (or DDA_SOLVER asks for it)
    dense_factor_rows: int = 240
    # up to this many rows a dense K is solved by numpy's LU at each solve (LAPACK gesv:
    # 5-12 µs at 12-36 rows against 2-6 µs for scipy's Cholesky and its solve), so that
    # a run of a few blocks never imports scipy (0.13 s of a small run's process)
    numpy_solve_rows: int = 36
    # PCG stops at ‖F - K x‖ ≤ this · ‖F‖ (a direct solve's level)
    pcg_tolerance: float = 1e-13
    # beyond this a new factorisation is cheaper (and is made)
    max_pcg_iterations: int = 12
    # PCG iterations that cost as much as a factorisation, per backend: measured on the
    # wall benchmark (SuperLU up to 10x10 blocks: 9-12; PARDISO at 30x30: 3-4). Fixed
    # numbers rather than timings taken during the run, so that a run's result never
    # depends on how busy the machine was. A dense factorisation costs about 5 of its
    # back-substitutions and a PCG iteration's Python ~0.03 ms on top: PCG is not tried
    pcg_budget_superlu: int = 12
    pcg_budget_pardiso: int = 3
    # a factorisation grows faster with the size than a back-substitution: at 60,000
    # rows (100x100 wall) PARDISO's factorisation and solve cost ~5.5 back-substitutions
    pardiso_large_rows: int = 20_000
    pcg_budget_pardiso_large: int = 5
    # a solve that needed more PCG iterations marks the factorisation stale
    refresh_after: int = 4
    # contact springs changed since the factorisation beyond which K is factorised again
    # at once (PCG no longer pays)
    max_changed_for_pcg: int = 6
    # low-rank updates of the factorisation (dda.solve.low_rank): changed springs beyond
    # which a new factorisation is cheaper (30x30 wall) ...
    low_rank_columns: int = 16
    # ... only for K of this many rows or more (a factorisation of a smaller one costs
    # ~6 back-substitutions, and each one here carries Python's overhead): 10x10 wall
    # (600 rows) even or 7 % slower, tunnel case (1200 rows) 5 % faster, 20x20 (2400)
    # 8 %, 30x30 (5400) 17-20 %
    low_rank_min_rows: int = 1000
    # with the exact inverse of K_f + U c Uᵀ, PCG ends in one
    low_rank_pcg_iterations: int = 3

    # ------------------------------------ the equilibrium start's interior point
    # (dda.solve.interior_point) iterations (factorisations) before it gives up
    interior_iterations: int = 80
    # each step goes this fraction of the way to the nearest bound of its unknowns
    interior_step_to_boundary: float = 0.995
    # it has converged when μ is within this fraction of f² (f: a typical contact
    # force) ... (looser ends cost more: the Newton that finishes then finds other
    # pieces; the tunnel's start, without centrality correctors, 113 and 169 Newton
    # iterations at 1e-8 and 1e-6 against 82)
    interior_complementarity_end: float = 1e-10
    # ... and every residual within this fraction of its force (at least f) ...
    interior_residual_end: float = 1e-9
    # ... plus this fraction of the large terms it is the difference of (round-off)
    interior_round_off: float = 1e-13
    # the first iterate's contact unknowns lie this many f inside their bounds (0.1, 0.3
    # and 3 took more iterations on the 20 x 20 and 40 x 40 walls and the rock slope)
    interior_start_shift: float = 1.0
    # a step that the bounds cut below this fraction of the Newton step is a stall: the
    # iterate's slacks w, u, v are far smaller than the solution's (blocks that cannot
    # stand, whose contacts open and slide by their load over the regulariser). The
    # tunnel's and the rock slope's starts stalled at 1e-3 to 0.05 for about 20
    # iterations (the sliding block's and the wet slope's raise too: 15 to 13, 25 to 24);
    # the bench walls (10 x 10 to 60 x 60), the jointed slope and the staged tunnel never
    # step below 0.14 ...
    interior_stall_step: float = 0.05
    # ... and the first stall raises them to at least this many f (a "big M": an
    # interior point takes short steps where it starts far inside the solution's slacks,
    # not where it starts outside them). A block its contacts cannot hold moves by its
    # load over the regulariser, about 1 / RELATIVE_REGULARISER of the equilibrium start
    # (1e-8) times its elastic settlement, and the slacks of its contacts grow with it:
    # the tunnel's start 31 factorisations against 59, the rock slope's 22 against 40
    # (1e6: 34 and 23; 1e10: 33 and 24; a stall at 0.02 or 0.1: 31-32 and 22-23)
    interior_stall_shift: float = 1e8
    # Gondzio's centrality correctors after Mehrotra's (each one solve with the
    # iteration's factorisation), while each lengthens the step
    interior_centrality_correctors: int = 2
    # relative increment of N for the slope b'(N) of the friction bound
    interior_slope_step: float = 1e-6
    # PARDISO's fill-reducing ordering of its unsymmetric matrix (iparm[1]): 0 minimum
    # degree, 2 or 3 nested dissection (METIS, its default). The 60 x 60 wall's matrix
    # (21,600 rows, 20 factorisations): 3.69e6 values in L and U and 709 Mflop a
    # factorisation by minimum degree, 4.45e6 and 1,027 by METIS; its start 1.35 s
    # against 1.51, the 40 x 40's 0.43 against 0.46, the 30 x 30's 0.172 against 0.187
    # (the same iterations; AMD EPYC, threads by the thread policy, the fastest of three).
    # The step's symmetric K keeps METIS: by minimum degree, fewer flops but slower
    # back-substitutions, the unloaded 60 x 60 wall's steps took 164 ms against 138
    interior_ordering: int = 0

    # ---------------------------------------------------------------- the environment
    solver: str = ""  # DDA_SOLVER: "pardiso", "superlu" or "" (PARDISO where installed)
    systems: str = ""  # DDA_SYSTEMS: "sparse" or "" (band, dense or sparse by size)
    threads: int | None = None  # DDA_THREADS: PARDISO's threads (None: the thread policy)
    # the band systems' outer loop as one compiled call (False: the Python loop over the
    # same systems, which the tests compare it with)
    band_loop_compiled: bool = True

    @classmethod
    def from_environment(cls, environ: Mapping[str, str] | None = None) -> StepPolicy:
        """The defaults with ``DDA_SOLVER``, ``DDA_SYSTEMS`` and ``DDA_THREADS`` read in
        (``environ``: ``os.environ`` when None). ``DDA_NO_NUMBA``, whether the kernels are
        built at all, is :mod:`dda.jit`'s (:func:`dda.jit.numba_enabled`); here its value
        is checked (1 or 0, or unset).

        Raises
        ------
        ValueError : a variable holds a value it cannot take (a misspelt choice would
            otherwise go unnoticed), named with the values it can
        """
        environ = os.environ if environ is None else environ
        _choice(environ, NO_NUMBA_VARIABLE, NO_NUMBA_CHOICES)  # read by dda.jit
        return replace(
            DEFAULT,
            solver=_choice(environ, SOLVER_VARIABLE, SOLVER_CHOICES),
            systems=_choice(environ, SYSTEMS_VARIABLE, SYSTEMS_CHOICES),
            threads=_threads(environ),
        )

    def size_rules(self, rows: int, dynamic: bool = True, band: bool = False) -> SizeRules:
        """The :class:`SizeRules` of a system of ``rows`` unknowns: the larger the system,
        the more back-substitutions a factorisation costs, and the longer chord steps
        pay. ``dynamic``: False for static steps (and the equilibrium start's
        pseudo-steps), which move blocks much further than a time step and keep the
        small systems' rules up to ``large_rows`` (with the mid rules the tunnel's start
        did not settle with two solver threads). ``band``: the step's systems are band
        systems, their passes compiled: dynamic steps take the mid rules below
        ``mid_rows``, the large ones from there."""
        if rows >= self.huge_rows:
            return SizeRules(self.huge_chord_rate, chord_first=True, bounds_every_solve=True)
        if rows >= self.large_rows or (band and dynamic and rows >= self.mid_rows):
            return SizeRules(self.large_chord_rate, True, False, conjugate=True)
        if (rows >= self.mid_rows or band) and dynamic:
            return SizeRules(self.mid_chord_rate, True, False, conjugate=True)
        return SizeRules(self.chord_rate, chord_first=False, bounds_every_solve=False)

    def solver_threads(self) -> int:
        """Threads for PARDISO: ``DDA_THREADS`` if set, else the cores the machine can
        give now (:mod:`dda.solve.thread_policy`: the usable cores less those other
        processes kept busy over the last second).

        On the idle 2-core benchmark machine two threads factorise the 30x30 wall's K in
        4.3 ms instead of 9.5; with another process busy on one core, one thread is the
        faster (docs/benchmarks.md). ``DDA_THREADS=1`` makes a run repeat bit for bit;
        processes that share the cores (``dda tradeoff``'s workers) set it.
        """
        return self.threads if self.threads is not None else thread_policy.POLICY.threads()

    def pcg_budget(self, kind: str, rows: int) -> int:
        """PCG iterations that cost no more than a factorisation of ``kind`` ("dense",
        "pardiso", "superlu") of ``rows`` rows; at most ``max_pcg_iterations``."""
        if kind == "dense":
            return 0
        if kind == "pardiso":
            large = rows >= self.pardiso_large_rows
            budget = self.pcg_budget_pardiso_large if large else self.pcg_budget_pardiso
        else:
            budget = self.pcg_budget_superlu
        return min(self.max_pcg_iterations, budget)

    def band_pays(self, free_rows: int, width: int) -> bool:
        """True when a system of ``free_rows`` unknowns and half-width ``width`` (kd) is
        held in band: n kd² ≤ ``band_work``."""
        return free_rows * width * width <= self.band_work


DEFAULT = StepPolicy()


def current_policy() -> StepPolicy:
    """The policy of the environment as it is now (:meth:`StepPolicy.from_environment`)."""
    return StepPolicy.from_environment()


def _choice(environ: Mapping[str, str], variable: str, choices: tuple[str, ...]) -> str:
    """``variable``'s value, lower case, blanks stripped: one of ``choices`` or ""."""
    text = environ.get(variable, "").strip().lower()
    if text and text not in choices:
        listed = " or ".join(choices)
        raise ValueError(f"{variable}={text!r}: expected {listed} (or leave it unset)")
    return text


def _threads(environ: Mapping[str, str]) -> int | None:
    """``DDA_THREADS`` as a positive integer, None when unset."""
    text = environ.get(THREADS_VARIABLE, "").strip()
    if not text:
        return None
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"{THREADS_VARIABLE}={text!r}: expected a positive integer (threads)")
    return int(text)
