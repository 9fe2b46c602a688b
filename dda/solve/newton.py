"""Newton's method with an exact line search on a step's incremental potential.

The step D (n, 6) of Shi's scheme minimises

    Π(D) = ½ Dᵀ K₀ D − F₀ᵀ D + Σ_c φn(g_c(D)) + Σ_c φt(s_c(D))

K₀, F₀: inertia (2M/Δt², 2M v0/Δt), elasticity, initial stress, loads,
gravity and fixed-point springs, block-diagonal, and rock bolts, linear
springs that couple two blocks (:mod:`dda.effects.pair_springs`); φn, φt: the contact terms of
:mod:`dda.contact.potential`, with the contact data frozen; g, s linear in D
(paper eqs. 9-13). Π is strictly convex (K₀ is positive definite through the
mass), C¹ and piecewise quadratic.

An iteration takes the pieces of every contact at the current D, solves the
quadratic of those pieces (K₀ plus the contact springs of those pieces: the
linear system of Shi's open–close iteration), and, unless every contact is on
its assumed piece at that minimiser (then it is Π's minimiser, exactly), moves
along the direction to the minimum of Π on that line
(:func:`dda.contact.line_search.line_minimum`). Π decreases in every
iteration, so no set of contact states can recur: the iteration cannot cycle.
After a Newton iteration, chord steps along −K_f⁻¹∇Π (K_f the factorisation
just made: a back-substitution, no factorisation) take over while they make
progress. In large systems they are conjugated (preconditioned nonlinear
conjugate gradients, Polak–Ribière+): with z = K_f⁻¹∇Π,

    p = −z + β p_prev,   β = max(0, zᵀ(∇Π − ∇Π_prev) / (z_prevᵀ ∇Π_prev)),

which on a quadratic is conjugate gradients preconditioned by K_f: it
converges in about as many steps as K_f has contact springs of other pieces
than Π's, where steepest descent in the K_f metric creeps. The line search is
exact, so ∇Π·p_prev = 0 and p is a descent direction (checked; else β = 0).
It has also converged when the gradient of Π is within ``RELATIVE_TOLERANCE``
of the forces that make it up.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from dda.contact.line_search import line_minimum
from dda.contact.potential import ContactTerms
from dda.contact.rows import ContactRows, gaps_after
from dda.effects.pair_springs import PairSprings
from dda.jit import compiled
from dda.solve import line_step

log = logging.getLogger(__name__)

RELATIVE_TOLERANCE = 1e-4  # ‖∇Π‖ against ‖K₀D‖ + ‖F₀‖ + ‖contact forces‖
# a chord step that leaves more than this fraction of ‖∇Π‖ is followed by a Newton
# iteration (the 30x30 wall: 0.25 measured no better)
CHORD_RATE = 0.5
# ... and in systems of this many rows or more, where a factorisation costs many
# back-substitutions and a Newton iteration's other work, conjugated chord steps go on
# while each leaves at most this fraction (interleaved dda bench runs, two each: 30x30
# wall 29.7 / 28.8 -> 26.6 / 25.2 ms/step with 1.95 factorisations a step instead of
# 3.4; at 0.95 27.7-28.2 with 2.3; unconjugated at 0.97 it was 10 % slower than at
# 0.85; 20x20, 2,400 rows, 16.2 / 15.1 -> 14.4 / 12.9 with 1.9 instead of 4.0; 10x10,
# 600 rows, 7.15 / 7.07 -> 7.34 / 7.48 with 3.0 instead of 5.0. The 265-block tunnel,
# 1,590 rows, is no faster with conjugated chord steps at 0.99 (four runs each: 8.1 s
# -> 8.2 s) and slower with a pass starting with a chord step, so smaller systems keep
# plain chord steps at CHORD_RATE)
LARGE_CHORD_RATE, LARGE_ROWS = 0.99, 2_000
# ... and from this many rows (below LARGE_ROWS), in dynamic steps, the same:
# conjugated chord steps and a pass on new bounds starting with one, while each leaves
# at most this fraction. The 265-block tunnel (1,590 rows; its hard steps are many
# passes on friction bounds whose pieces flip) takes 4.73 Newton iterations a step
# instead of 6.39 (1 thread; 3.75 instead of 6.17 with 2) and 14.7 linear solves
# instead of 11.1, at about the same CPU time (three interleaved runs each, loaded
# machine: 15.5 / 17.5 / 17.6 s against 15.1 / 17.5 / 14.8 s); the staged tunnel
# 2.03 instead of 2.82. At 0.7 it was 5.98, at 0.99 4.08 with 18.9 solves
MID_CHORD_RATE, MID_ROWS = 0.85, 1_000
# ... and from this many rows, where a factorisation costs tens of chord steps, the
# friction bounds follow the normal forces after every solve and chord steps go on
# while they make any headway (interleaved dda bench runs against the conjugated rules
# above, two each: 50x50 wall, 15,000 rows, 99.0/105.3 against 93.5/87.8 ms/step;
# 60x60, 21,600 rows, 153.7/176.7 against 145.0/159.1; 70x70, 29,400 rows, 176.0/191.7
# against 184.1/203.0; 100x100 503.5/545.7 against 527.0/567.7)
HUGE_CHORD_RATE, HUGE_ROWS = 0.99, 25_000
# Band systems, whose Newton passes and law updates run compiled (dda.solve.band_step),
# pay for a factorisation with about ten chord steps at any size: in dynamic steps they
# take the mid rules below MID_ROWS and the large ones from there (CPU ms a step, one
# solver thread, three interleaved runs each, medians, small / mid / large rules:
# 3 x 3 wall 1.41 / 1.19 / 1.48, 5 x 5 1.79 / 1.66 / 1.75, 7 x 7 2.42 / 1.87 / 2.40,
# 10 x 10 5.75 / 5.05 / 5.04, the rock slope 3.29 / 2.85 / 2.68; from 1,000 rows, mid /
# large: 15 x 15 13.4 / 11.4, the tunnel 20.3 / 19.0)


@dataclass(frozen=True)
class SizeRules:
    """How a step of a system of a given size spends its linear solves.

    rate : chord steps go on while each leaves at most this fraction of ‖∇Π‖
    chord_first : a pass on new friction bounds or multipliers that goes on from an
        unfinished one, or from a converged one the law's update moved, starts with a
        chord step (``minimise(chord_first=True)``), not a Newton iteration
    bounds_every_solve : the friction bounds follow the normal forces after every
        linear solve (else after a few, :data:`dda.solve.step.INNER_SOLVES`)
    conjugate : successive chord steps are conjugated (``minimise(conjugate=True)``)
    """

    rate: float
    chord_first: bool
    bounds_every_solve: bool
    conjugate: bool = False


def size_rules(rows: int, dynamic: bool = True, band: bool = False) -> SizeRules:
    """The :class:`SizeRules` of a system of ``rows`` unknowns: the larger the system,
    the more back-substitutions a factorisation costs, and the longer chord steps pay.
    ``dynamic``: False for static steps (and the equilibrium start's pseudo-steps), which
    move blocks much further than a time step and keep the small systems' rules up to
    ``LARGE_ROWS`` (with the mid rules the tunnel's start did not settle with two
    solver threads). ``band``: the step's systems are band systems, their passes
    compiled: dynamic steps take the mid rules below ``MID_ROWS``, the large ones from
    there."""
    if rows >= HUGE_ROWS:
        return SizeRules(HUGE_CHORD_RATE, chord_first=True, bounds_every_solve=True)
    if rows >= LARGE_ROWS or (band and dynamic and rows >= MID_ROWS):
        return SizeRules(
            LARGE_CHORD_RATE, chord_first=True, bounds_every_solve=False, conjugate=True
        )
    if (rows >= MID_ROWS or band) and dynamic:
        return SizeRules(MID_CHORD_RATE, chord_first=True, bounds_every_solve=False, conjugate=True)
    return SizeRules(CHORD_RATE, chord_first=False, bounds_every_solve=False)


@dataclass(frozen=True)
class BlockQuadratic:
    """½ Dᵀ K₀ D − F₀ᵀ D with one 6x6 block of K₀ per block (fixed blocks: D = 0),
    plus the springs that couple two blocks (rock bolts, :mod:`dda.effects.pair_springs`):
    K₀ = blockdiag + Σ k [r_i r_j]ᵀ[r_i r_j]."""

    stiffness: np.ndarray  # (n, 6, 6)
    forces: np.ndarray  # (n, 6)
    free: np.ndarray  # (n,) bool: the blocks that move
    couplings: PairSprings | None = None

    def product(self, d: np.ndarray) -> np.ndarray:
        """K₀ D, (n, 6)."""
        out = np.einsum("nij,nj->ni", self.stiffness, d)
        if self.couplings is not None:
            out += self.couplings.product(d)
        return out

    def value(self, d: np.ndarray) -> float:
        """½ Dᵀ K₀ D − F₀ᵀ D."""
        return float(np.sum(d * (0.5 * self.product(d) - self.forces)))

    def along(
        self, product: np.ndarray, direction: np.ndarray, direction_product: np.ndarray
    ) -> tuple[float, float]:
        """(a, c) of the line D + α ΔD: a = ΔDᵀ(K₀ D − F₀), c = ΔDᵀ K₀ ΔD, from
        ``product`` = K₀ D and ``direction_product`` = K₀ ΔD."""
        a = float(np.vdot(direction, product - self.forces))
        return a, float(np.vdot(direction, direction_product))

    @cached_property
    def load_norm(self) -> float:
        """‖F₀‖ over the free blocks."""
        return float(np.linalg.norm(self.forces[self.free]))


@dataclass(frozen=True)
class ContactGeometry:
    """The contacts' distances as linear functions of D (eqs. 9-13)."""

    rows: ContactRows
    block_a: np.ndarray
    block_b: np.ndarray

    def at(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(g, s): penetration and shear motion of every contact after the step D."""
        return gaps_after(self.rows, self.block_a, self.block_b, d)

    def rates(self, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∇g·ΔD, ∇s·ΔD)."""
        g, s = self.at(direction)
        return g - self.rows.penetration, s - self.rows.slip


@dataclass
class NewtonResult:
    d: np.ndarray
    solves: int  # Newton iterations (assembled and solved quadratics)
    converged: bool
    chords: int = 0  # chord steps (back-substitutions with the kept factorisation)
    # the next direction would be a chord direction: the last step was a Newton
    # iteration, or a chord step that left at most the chord rate of ‖∇Π‖
    chord_next: bool = False
    gaps: tuple[np.ndarray, np.ndarray] | None = None  # (g, s) at d (None: d not finite)


# solve(normal springs, shear springs, normal offsets, shear offsets) -> D: the minimiser
# of the quadratic whose contact forces are offset + spring · (∇g·D)
PieceSolver = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
# chord(r) -> K_f⁻¹ r (n, 6) with a kept factorisation K_f, or None when there is none
ChordSolver = Callable[[np.ndarray], np.ndarray | None]
# contact_vector(normal forces, shear forces) -> Σ N ∇g + Σ F ∇s as (n, 6)
ForceVector = Callable[[np.ndarray, np.ndarray], np.ndarray]


def minimise(
    quadratic: BlockQuadratic,
    geometry: ContactGeometry,
    terms: ContactTerms,
    solve: PieceSolver,
    contact_vector: ForceVector,
    start: np.ndarray,
    max_solves: int,
    first_pieces: tuple[np.ndarray, np.ndarray] | None = None,
    iterates: list | None = None,
    chord: ChordSolver | None = None,
    max_steps: int | None = None,
    rate: float = CHORD_RATE,
    chord_first: bool = False,
    start_gaps: tuple[np.ndarray, np.ndarray] | None = None,
    conjugate: bool = False,
    forces_from_rows: bool = False,
) -> NewtonResult:
    """Minimise Π from ``start`` with at most ``max_solves`` Newton iterations and
    at most ``max_steps`` iterations in all (Newton iterations and chord steps).

    ``first_pieces``: (normal, shear) pieces for the first iteration's quadratic
    instead of those at ``start`` (e.g. the contact states at the end of the
    last step). Any pieces give a descent direction; the quadratic's minimiser
    is Π's exactly when every contact is on the piece assumed for it there.
    ``chord``: r ↦ K_f⁻¹ r with the factorisation the solver keeps (None when
    it has none for this pattern). After a Newton iteration the next direction
    is the chord direction −K_f⁻¹ ∇Π(D): one back-substitution, no assembly and
    no factorisation, and a descent direction for any positive definite K_f.
    Chord steps go on while each shrinks ‖∇Π‖ to at most ``rate`` of what it was
    (:func:`size_rules`); then a Newton iteration again. ``chord_first``: the first
    direction is the chord direction at ``start`` too (a pass that goes on from where
    the last one stopped, on slightly other contact data: the kept factorisation
    still fits it). ``start_gaps``: (g, s) at ``start`` when the caller has them.
    ``conjugate``: successive chord steps are conjugated (:func:`_conjugated`).
    ``iterates``: a list to which every iterate D is appended (diagnostics).
    ``forces_from_rows``: ``contact_vector`` is Σ N∇g + Σ F∇s over ``geometry``'s rows
    and blocks, so that each line step may be the compiled one
    (:mod:`dda.solve.line_step`, where the kernels are used and K₀ is block-diagonal).
    """
    lines_compiled = (
        forces_from_rows and quadratic.couplings is None and compiled(line_step.line_step_kernel)
    )
    d = start
    g0, s0 = geometry.rows.penetration, geometry.rows.slip
    g, s = geometry.at(d) if start_gaps is None else start_gaps
    kd = quadratic.product(d)  # K₀ D, carried along the lines like g and s
    pieces = first_pieces
    gradient = None  # ∇Π at d when the next direction is a chord direction
    if chord_first and chord is not None:
        gradient = _residual(quadratic, terms, contact_vector, kd, g, s)[0]
    solves = chords = 0
    last_chord = None  # (direction, ∇Π, K_f⁻¹∇Π) of the last chord step
    while solves < max_solves and (max_steps is None or solves + chords < max_steps):
        preconditioned = None if gradient is None else chord(gradient)
        rates = None  # (∇g·ΔD, ∇s·ΔD) when known
        if preconditioned is not None:
            direction, chords = -preconditioned, chords + 1
            if conjugate and last_chord is not None:
                direction = _conjugated(direction, gradient, preconditioned, last_chord)
            last_chord = (direction, gradient, preconditioned)
        else:
            last_chord = None
            solves += 1
            if pieces is None:
                pieces = terms.pieces(g, s)
            kn, ks = terms.springs(*pieces)
            offset_n, offset_t = terms.offsets(*pieces, g0, s0)
            target = solve(kn, ks, offset_n, offset_t)
            if not np.all(np.isfinite(target)):
                return NewtonResult(target, solves, False, chords)
            at_target = geometry.at(target)
            if terms.same_pieces(pieces, terms.pieces(*at_target)):
                if iterates is not None:
                    iterates.append(target)
                # the quadratic was Π's there
                return NewtonResult(target, solves, True, chords, gaps=at_target)
            direction, pieces = target - d, None
            rates = (at_target[0] - g, at_target[1] - s)
        if lines_compiled:
            d, g, s, kd, residual, size, scale, alpha = _compiled_line_step(
                quadratic, geometry, terms, d, g, s, kd, direction, rates
            )
        else:
            dg, ds = geometry.rates(direction) if rates is None else rates
            kp = quadratic.product(direction)
            a, c = quadratic.along(kd, direction, kp)
            alpha, _ = line_minimum(terms, a, c, g, dg, s, ds)
            # g, s and K₀D are linear in D: step them along the line with D
            d, g, s, kd = d + alpha * direction, g + alpha * dg, s + alpha * ds, kd + alpha * kp
            residual, scale = _residual(quadratic, terms, contact_vector, kd, g, s)
            size = np.linalg.norm(residual)
        if iterates is not None:
            iterates.append(d)
        if size <= RELATIVE_TOLERANCE * scale:
            return NewtonResult(d, solves, True, chords, gaps=(g, s))
        log.debug("Newton %d, chord %d: α = %.3g", solves, chords, alpha)
        shrunk = gradient is None or size <= rate * np.linalg.norm(gradient)
        gradient = residual if chord is not None and shrunk else None
    return NewtonResult(d, solves, False, chords, gradient is not None, (g, s))


class NumpyPasses:
    """Systems whose Newton passes are :func:`minimise`'s: no compiled pass, no compiled
    start (the band systems' are, :class:`dda.solve.band_system.BandSystem`)."""

    def minimise(self, *args, **kwargs) -> None:
        """None: the caller runs :func:`minimise` on this system."""
        return None

    def better_start(self, terms, candidates) -> None:
        """None: :func:`better_start` chooses the start."""
        return None


def _compiled_line_step(quadratic, geometry, terms, d, g, s, kd, direction, rates):
    """:func:`dda.solve.line_step.line_step_kernel` from :func:`minimise`'s state:
    (D, g, s, K₀D, ∇Π, ‖∇Π‖, scale, α)."""
    rows, t = geometry.rows, terms
    none = np.empty(0)
    dg, ds = (none, none) if rates is None else rates
    floats = (
        rows.normal_i, rows.normal_j, rows.shear_i, rows.shear_j,
        t.normal_base, t.penalty, t.tension, t.shear_base, t.shear_penalty, t.bound,
    )  # fmt: skip
    floats = tuple(np.ascontiguousarray(x, np.float64) for x in floats)
    return line_step.line_step_kernel(
        np.ascontiguousarray(quadratic.stiffness, np.float64),
        np.ascontiguousarray(quadratic.forces, np.float64),
        np.ascontiguousarray(quadratic.free, np.bool_),
        *floats[:4],
        np.asarray(geometry.block_a, np.int64),
        np.asarray(geometry.block_b, np.int64),
        *floats[4:],
        float(quadratic.load_norm),
        *(np.ascontiguousarray(x, np.float64) for x in (d, g, s, kd, direction, dg, ds)),
        rates is not None,
    )


def _conjugated(
    steepest: np.ndarray,
    gradient: np.ndarray,
    preconditioned: np.ndarray,
    last: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> np.ndarray:
    """p = −z + β p_prev, β = max(0, zᵀ(∇Π − ∇Π_prev) / (z_prevᵀ ∇Π_prev)) (Polak–Ribière+,
    preconditioned: z = K_f⁻¹∇Π); ``steepest`` = −z. Falls back to −z when p would not
    descend (∇Π·p ≥ 0: the last line minimum was at an end of its range)."""
    last_direction, last_gradient, last_preconditioned = last
    scale = float(np.vdot(last_preconditioned, last_gradient))
    if scale <= 0.0:
        return steepest
    beta = max(0.0, float(np.vdot(preconditioned, gradient - last_gradient)) / scale)
    direction = steepest + beta * last_direction
    return direction if float(np.vdot(gradient, direction)) < 0.0 else steepest


def potential(
    quadratic: BlockQuadratic, geometry: ContactGeometry, terms: ContactTerms, d: np.ndarray
) -> float:
    """Π(D)."""
    return quadratic.value(d) + terms.energy(*geometry.at(d))


def better_start(
    quadratic: BlockQuadratic,
    geometry: ContactGeometry,
    terms: ContactTerms,
    candidates: list[np.ndarray],
) -> np.ndarray:
    """The candidate start with the lowest Π (e.g. D = 0 and D = v0 Δt)."""
    values = [potential(quadratic, geometry, terms, d) for d in candidates]
    return candidates[int(np.argmin(values))]


def _residual(quadratic, terms, contact_vector, kd, g, s) -> tuple[np.ndarray, float]:
    """∇Π(D) = K₀D − F₀ + Σ N∇g + Σ F∇s (n, 6; zero on fixed blocks), and the scale
    ‖K₀D‖ + ‖F₀‖ + ‖Σ N∇g + Σ F∇s‖ (over the free blocks) it is measured against;
    ``kd`` = K₀D; ``g``, ``s``: the contacts' penetration and shear motion at D."""
    contact = contact_vector(terms.normal_force(g), terms.shear_force(s))
    free = quadratic.free[:, None]
    residual = np.where(free, kd - quadratic.forces + contact, 0.0)
    norms = [np.linalg.norm(np.where(free, x, 0.0)) for x in (kd, contact)]
    return residual, float(sum(norms)) + quadratic.load_norm
