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
It has also converged when the gradient of Π is within the policy's
``newton_tolerance`` of the forces that make it up (:class:`dda.solve.policy.StepPolicy`).
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
from dda.solve.policy import DEFAULT

log = logging.getLogger(__name__)


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
    rate: float = DEFAULT.chord_rate,
    chord_first: bool = False,
    start_gaps: tuple[np.ndarray, np.ndarray] | None = None,
    conjugate: bool = False,
    forces_from_rows: bool = False,
    tolerance: float = DEFAULT.newton_tolerance,
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
    (:meth:`dda.solve.policy.StepPolicy.size_rules`); then a Newton iteration again.
    ``chord_first``: the first direction is the chord direction at ``start`` too (a
    pass that goes on from where the last one stopped, on slightly other contact data:
    the kept factorisation still fits it). ``start_gaps``: (g, s) at ``start`` when the
    caller has them.
    ``conjugate``: successive chord steps are conjugated (:func:`_conjugated`).
    ``iterates``: a list to which every iterate D is appended (diagnostics).
    ``forces_from_rows``: ``contact_vector`` is Σ N∇g + Σ F∇s over ``geometry``'s rows
    and blocks, so that each line step may be the compiled one
    (:mod:`dda.solve.line_step`, where the kernels are used and K₀ is block-diagonal).
    ``tolerance``: converged once ‖∇Π‖ is within this fraction of the forces that make it
    up (the policy's ``newton_tolerance``).
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
        if size <= tolerance * scale:
            return NewtonResult(d, solves, True, chords, gaps=(g, s))
        log.debug("Newton %d, chord %d: α = %.3g", solves, chords, alpha)
        shrunk = gradient is None or size <= rate * np.linalg.norm(gradient)
        gradient = residual if chord is not None and shrunk else None
    return NewtonResult(d, solves, False, chords, gradient is not None, (g, s))


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
