"""A step's linear systems in band storage, its Newton passes compiled.

On the sparse block pattern each linear solve costs a few dozen Python and numpy
calls; a dense K costs n³/3 flops a factorisation. With the blocks numbered so that
blocks in contact (or joined by a rock bolt) lie close — reverse Cuthill–McKee on
their graph — K is a band matrix of half-width kd = 6 × (the largest distance
between two such blocks) + 5, factorised by LAPACK in about n kd² flops, and a whole
Newton pass is one compiled call (:mod:`dda.solve.band_newton`). A step takes this
path where the kernels are used and the factorisation's n kd² stays within
the policy's ``band_work`` (:class:`dda.solve.policy.StepPolicy`), whatever the model's
size.

The numbering is kept from step to step (:class:`BandOrder`) while the blocks are
the same and it keeps kd within the policy's ``reorder_growth`` of the kd it was made
with.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dda.jit import compiled, floats, kernel
from dda.solve import band_newton, band_step
from dda.solve.band_arguments import BandGeometry, BandTerms, Factor, PassRules, PassStart
from dda.solve.dense_system import contact_columns
from dda.solve.newton import NewtonResult
from dda.solve.policy import DEFAULT


def band_order(
    fixed: np.ndarray, block_a: np.ndarray, block_b: np.ndarray, *more: np.ndarray
) -> np.ndarray:
    """Position of each block in the band numbering (−1 for fixed blocks): reverse
    Cuthill–McKee on the graph of the free blocks paired in (block_a, block_b) and in
    the further pairs (i, j) of ``more`` (bolts)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    if more:
        block_a = np.concatenate([block_a, *more[0::2]])
        block_b = np.concatenate([block_b, *more[1::2]])
    free = np.flatnonzero(~fixed)
    rank = np.full(len(fixed), -1, np.int64)
    rank[free] = np.arange(len(free))
    i, j = rank[block_a], rank[block_b]
    both = (i >= 0) & (j >= 0)
    i, j = i[both], j[both]
    n = len(free)
    graph = coo_matrix(
        (np.ones(2 * len(i) + n), (np.r_[i, j, np.arange(n)], np.r_[j, i, np.arange(n)])),
        shape=(n, n),
    ).tocsr()
    order = reverse_cuthill_mckee(graph, symmetric_mode=True)
    position = np.full(len(fixed), -1, np.int64)
    position[free[order]] = np.arange(n)
    return position


def half_width(columns: np.ndarray) -> int:
    """kd: the largest |row − column| of K's entries (the 6 × 6 blocks, the springs' of
    the (m, 12) ``columns``)."""
    big = np.iinfo(np.int64).max
    low = np.where(columns >= 0, columns, big).min(axis=1, initial=big)
    high = columns.max(axis=1, initial=-1)
    moving = high >= 0
    spread = (high[moving] - low[moving]).max(initial=0)
    return int(max(spread, 5))


class Numbering(NamedTuple):
    """A step's band numbering: each block's position (−1 fixed), the (m, 12) columns of
    the contacts' and the (q, 12) of the bolts' unknowns, and the half-width kd."""

    position: np.ndarray
    contacts: np.ndarray
    bolts: np.ndarray
    width: int


class BandOrder:
    """The band numbering kept between steps (module docstring); ``reorder_growth``: the
    policy's (:class:`dda.solve.policy.StepPolicy`)."""

    def __init__(self, reorder_growth: float = DEFAULT.reorder_growth) -> None:
        self.reorder_growth = reorder_growth
        self.position: np.ndarray | None = None
        self._fixed: np.ndarray | None = None
        self._made_width = 0

    def numbering(self, fixed, block_a, block_b, bolt_i, bolt_j) -> Numbering:
        """This step's :class:`Numbering` in the kept numbering, or in a new one when the
        blocks changed or the band grew past ``reorder_growth`` times its first kd."""
        new = not self._numbers(fixed)
        if new:
            self._fixed = fixed.copy()
            self.position = band_order(fixed, block_a, block_b, bolt_i, bolt_j)
        made = self._in_order(block_a, block_b, bolt_i, bolt_j)
        if not new and made.width > self.reorder_growth * self._made_width:
            self.position = band_order(fixed, block_a, block_b, bolt_i, bolt_j)
            made, new = self._in_order(block_a, block_b, bolt_i, bolt_j), True
        if new:
            self._made_width = made.width
        return made

    def made_width(self, fixed: np.ndarray) -> int:
        """kd of the kept numbering when it numbers these blocks, else 5 (a 6 × 6 block:
        the narrowest band): a model whose numbering gave a band too wide to pay is not
        numbered again at every step."""
        return self._made_width if self._numbers(fixed) else 5

    def _numbers(self, fixed: np.ndarray) -> bool:
        return self.position is not None and np.array_equal(fixed, self._fixed)

    def _in_order(self, block_a, block_b, bolt_i, bolt_j) -> Numbering:
        if compiled(_columns_kernel):
            position = self.position
            contacts, contacts_width = _columns_kernel(position, _int64(block_a), _int64(block_b))
            bolts, bolts_width = _columns_kernel(position, _int64(bolt_i), _int64(bolt_j))
            return Numbering(position, contacts, bolts, max(contacts_width, bolts_width))
        contacts = contact_columns(self.position, block_a, block_b)
        bolts = contact_columns(self.position, bolt_i, bolt_j)
        width = max(half_width(contacts), half_width(bolts))
        return Numbering(self.position, contacts, bolts, width)


def _int64(values: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(values, np.int64)


def _columns(position, block_i, block_j):
    """Compiled :func:`dda.solve.dense_system.contact_columns` and :func:`half_width` of
    its result, in one pass."""
    m = block_i.shape[0]
    columns = np.empty((m, 12), np.int64)
    spread = 0
    for c in range(m):
        low, high = np.iinfo(np.int64).max, -1
        for side, b in enumerate((block_i[c], block_j[c])):
            at = position[b]
            for r in range(6):
                column = 6 * at + r if at >= 0 else -1
                columns[c, 6 * side + r] = column
                if column >= 0:
                    low, high = min(low, column), max(high, column)
        if high >= 0:
            spread = max(spread, high - low)
    return columns, max(spread, 5)


_columns_kernel = kernel(_columns)


class BandSystem:
    """One step's systems in band storage (a :class:`dda.solve.systems.StepSystems`);
    :meth:`minimise` is one compiled call, :meth:`solve_loop` the whole outer loop.

    Built only where the band kernel is used (:func:`dda.jit.compiled`). ``couplings``:
    the springs between blocks (rock bolts), or None. Should LAPACK find a K not
    positive definite (round-off), the pass and the rest of the step go to the
    ``fallback`` system that ``make_fallback()`` returns (dense or sparse), which the
    numpy Newton drives.
    """

    compiled_passes = True
    sums_by_rows = True

    def __init__(
        self, fixed, block_a, block_b, rows, base_k, base_f, friction, couplings, numbering,
        timer, make_fallback,
    ) -> None:  # fmt: skip
        position, self.columns, bolt_columns, width = numbering
        free = np.flatnonzero(position >= 0)
        self.order = free[np.argsort(position[free])]  # the free blocks in band order
        self.blocks = np.ascontiguousarray(base_k[self.order], np.float64)
        self.forces = np.ascontiguousarray(base_f[self.order].ravel(), np.float64)
        self.normal_rows = np.ascontiguousarray(np.concatenate([rows.normal_i, rows.normal_j], 1))
        self.shear_rows = np.ascontiguousarray(np.concatenate([rows.shear_i, rows.shear_j], 1))
        self.g0, self.s0 = rows.penetration, rows.slip
        self.geometry = BandGeometry(
            self.blocks, *_bolts(couplings, bolt_columns), self.forces, self.columns,
            self.normal_rows, self.shear_rows, floats(self.g0), floats(self.s0),
        )  # fmt: skip
        self.size, self.width = len(self.forces), width
        self.friction, self.timer, self.shape = friction, timer, base_f.shape
        self._make_fallback = make_fallback
        self._fallback = None
        self._own_factorisations = 0
        self.restart()

    def restart(self) -> None:
        """No factorisation kept: the next pass factorises its K."""
        self._state = Factor(
            np.zeros((self.size, self.width + 1)),
            np.full((2, len(self.g0)), np.nan),
            np.zeros(3, np.int64),
        )

    @property
    def factor(self) -> Factor:
        """The kept factorisation, the springs of its K and :mod:`dda.solve.band_newton`'s
        state flags, which the kernels update in place."""
        return self._state

    def count_factorisations(self, made: int) -> None:
        """Count ``made`` factorisations of a kernel given :attr:`factor`."""
        self._own_factorisations += made

    @property
    def factorisations(self) -> int:
        fallback = 0 if self._fallback is None else self._fallback.factorisations
        return self._own_factorisations + fallback

    def minimise(
        self,
        terms,
        start: np.ndarray,
        max_solves: int,
        first_pieces=None,
        max_steps: int | None = None,
        rate: float = 0.5,
        chord_first: bool = False,
        start_gaps=None,
        conjugate: bool = False,
        tolerance: float = DEFAULT.newton_tolerance,
    ) -> NewtonResult | None:
        """:func:`dda.solve.newton.minimise` in one compiled call, or None once LAPACK
        found K not positive definite (the numpy Newton on the fallback system)."""
        if self._fallback is not None:
            return None
        state = self._state.state
        have_gaps = start_gaps is not None
        gaps = start_gaps if have_gaps else (self.g0, self.s0)  # else computed by the kernel
        first = first_pieces is not None
        none = np.zeros(len(self.g0), np.int8)
        normal_piece, shear_piece = first_pieces if first else (none, none)
        made = int(state[band_newton.FACTORISATIONS])
        begin = PassStart(
            floats(start[self.order].ravel()), floats(gaps[0]), floats(gaps[1]), have_gaps,
            np.ascontiguousarray(normal_piece, np.int8),
            np.ascontiguousarray(shear_piece, np.int8), first,
        )  # fmt: skip
        rules = PassRules(
            int(max_solves), -1 if max_steps is None else int(max_steps), float(rate),
            bool(chord_first), bool(conjugate), float(tolerance),
        )  # fmt: skip
        with self.timer("solve"):  # K, its factorisations and solves: the "solve" stage
            out = band_newton.band_minimise_kernel(
                self.geometry, band_terms(terms), self.friction, begin, rules, self._state
            )
        self._own_factorisations += int(state[band_newton.FACTORISATIONS]) - made
        if state[band_newton.FAILED]:
            self._fallback = self._make_fallback()
            return None
        d, g, s, solves, chords, converged, chord_next, finite = out
        full = self.spread(d)
        if not finite:
            return NewtonResult(full, solves, False, chords)
        return NewtonResult(full, solves, converged, chords, chord_next, (g, s))

    def better_start(self, terms, candidates: list[np.ndarray]) -> np.ndarray:
        """:func:`dda.solve.newton.better_start` by the compiled Π."""
        frozen = band_terms(terms)
        values = [
            band_newton.potential_kernel(self.geometry, frozen, floats(d[self.order].ravel()))
            for d in candidates
        ]
        return candidates[int(np.argmin(values))]

    def solve_loop(self, loop) -> tuple[np.ndarray, int, int, bool, float] | None:
        """The step's outer loop in one compiled call (:func:`dda.solve.band_step.solve_on_band`)
        unless the loop's policy asks for the Python loop (``band_loop_compiled``); None
        then, or when LAPACK found a K not positive definite."""
        if not loop.policy.band_loop_compiled:
            return None
        return band_step.solve_on_band(self, loop)

    def gaps(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(g, s) after the step ``d`` (n, 6), summed as the compiled passes sum them."""
        x = np.ascontiguousarray(d[self.order].ravel(), np.float64)
        along = band_newton._along
        return self.g0 + along(self.columns, self.normal_rows, x), self.s0 + along(
            self.columns, self.shear_rows, x
        )

    def __call__(self, kn, ks, offset_n, offset_t) -> np.ndarray:
        """The fallback system's solve (the numpy Newton's, after a failed pass)."""
        return self._fallback(kn, ks, offset_n, offset_t)

    def chord(self, residual: np.ndarray) -> np.ndarray | None:
        return None if self._fallback is None else self._fallback.chord(residual)

    def contact_vector(self, normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
        return self._fallback.contact_vector(normal, shear)

    def spread(self, x: np.ndarray) -> np.ndarray:
        """(n, 6) unknowns of every block from the band-ordered vector ``x``."""
        out = np.zeros(self.shape)
        out[self.order] = x.reshape(-1, 6)
        return out


def _bolts(couplings, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bolts' (q, 12) columns, (q, 12) rows [r_i r_j] and (q,) stiffnesses."""
    if couplings is None or not len(couplings):
        return np.full((0, 12), -1, np.int64), np.zeros((0, 12)), np.zeros(0)
    rows = np.concatenate([couplings.row_i, couplings.row_j], axis=1)
    stiffness = np.asarray(couplings.stiffness, np.float64)
    return columns, np.ascontiguousarray(rows, np.float64), stiffness


def band_terms(terms) -> BandTerms:
    """The kernels' :class:`~dda.solve.band_arguments.BandTerms` of a
    :class:`dda.contact.potential.ContactTerms`."""
    return BandTerms(*terms.kernel_arrays())


def band_kernels() -> bool:
    """Whether the band path's kernels are used in this run."""
    return compiled(band_newton.band_minimise_kernel)
