"""A whole step on band systems in one compiled call: the Newton passes and the law between.

Where a step's systems are held in band storage (:mod:`dda.solve.band_system`), the
outer loop of :func:`dda.solve.step.solve_step` — the step's first friction bounds, the
start (Π at D = 0 and at v₀Δt), the pieces remembered from the last step, the compiled
Newton passes (:mod:`dda.solve.band_newton`), and between them the contact law's
update (:mod:`dda.contact.law`: the forces and friction bounds, eq. 7's augmentation
and the variable penalty, broken bonds, the Anderson mixing of the bounds), then the
record of the step's contact states and the friction's dissipation — runs here as one
kernel, with the same operations in the same order as the Python loop, which stays its
oracle (``tests/solve/test_band_step.py``). The norms and sums over the contacts are the
kernel's own (a sum in another order than numpy's pairwise one) and the Anderson
least squares is numba's ``eigh``: the two loops agree to rounding.

Should LAPACK find a K not positive definite, the kernel stops and reports it; the step
is then solved again by the Python loop, which hands the pass to the numpy Newton.
"""

from __future__ import annotations

import numpy as np

from dda.contact import formulas, law_kernels
from dda.contact import law as contact_law
from dda.contact.formulas import (
    first_bound,
    friction_bound,
    friction_work,
    multiplier_allowance,
    remembered_pieces,
)
from dda.contact.law import UNBOUNDED, BoundIteration
from dda.contact.strength import joint_of
from dda.jit import floats, kernel
from dda.result import OPEN
from dda.solve import band_newton, contact_pieces
from dda.solve.band_arguments import (
    BandContacts,
    BandTerms,
    LawSettings,
    LoopRules,
    PassRules,
    PassStart,
    StepOutcome,
)

DEPTH = BoundIteration.DEPTH
MIXING = BoundIteration.MIXING

terms_kernel = law_kernels.terms_kernel
forces_and_bounds_kernel = law_kernels.forces_and_bounds_kernel
augment_kernel = law_kernels.augment_kernel
broken_kernel = law_kernels.broken_kernel
recorded_kernel = law_kernels.recorded_kernel
band_minimise_kernel = band_newton.band_minimise_kernel
potential_kernel = band_newton.potential_kernel


def _first_bounds(
    intact, strength, multiplier, penalty, allowance, g0, last_normal, fresh, state, friction
):  # fmt: skip
    """:func:`dda.solve.step._first_bounds`: the bounds of the larger of N(g₀) and the
    last step's N (:func:`dda.contact.formulas.friction_bound`), a contact found
    touching this step ``UNBOUNDED``; 0 without friction."""
    m = g0.shape[0]
    bound = np.zeros(m)
    if not friction:
        return bound
    for c in range(m):
        found_touching = fresh[c] and state[c] != OPEN
        bound[c] = first_bound(
            joint_of(strength, c), intact[c], state[c] == OPEN, multiplier[c], penalty[c],
            allowance, g0[c], last_normal[c], found_touching,
        )  # fmt: skip
    return bound


def _remembered(normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s, state,
                direction):  # fmt: skip
    """:func:`dda.solve.step._remembered_pieces`: the pieces at (g, s)
    (:func:`dda.solve.contact_pieces._pieces`), except that a contact closed at the last
    step's end starts elastic, one sliding then slides the same way, one locked sticks."""
    m = g.shape[0]
    normal, shear = np.empty(m, np.int8), np.empty(m, np.int8)
    _pieces(normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s, normal, shear)
    for c in range(m):
        normal[c], shear[c] = remembered_pieces(normal[c], shear[c], state[c], direction[c])
    return normal, shear


def _norm(x):
    """‖x‖₂ as ``np.linalg.norm`` computes it: √(x·x), the dot product BLAS's."""
    return np.sqrt(np.dot(x, x))


def _guessing(bound):
    """:attr:`dda.contact.law.BoundIteration.guessing`."""
    for value in bound:
        if value >= 0.5 * UNBOUNDED:
            return True
    return False


def _advance(bound, target, points, residuals, count):
    """:meth:`dda.contact.law.BoundIteration.advance`: the next bounds from ``target`` =
    G(``bound``) and the last iterates kept in ``points``, ``residuals`` (DEPTH + 1, m;
    the first ``count`` rows, oldest first). Returns (bounds, count)."""
    if _guessing(bound):
        return target.copy(), 0
    m = bound.shape[0]
    if count == DEPTH + 1:
        for row in range(DEPTH):
            for c in range(m):
                points[row, c], residuals[row, c] = points[row + 1, c], residuals[row + 1, c]
        count -= 1
    for c in range(m):
        points[count, c], residuals[count, c] = bound[c], target[c] - bound[c]
    count += 1
    mean_point, mean_residual = points[count - 1].copy(), residuals[count - 1].copy()
    if count > 1:
        point_steps = points[1:count] - points[: count - 1]
        residual_steps = residuals[1:count] - residuals[: count - 1]
        gamma = _least_squares(residual_steps, residuals[count - 1])
        mean_point = mean_point - _combination(gamma, point_steps)
        mean_residual = mean_residual - _combination(gamma, residual_steps)
    return np.maximum(mean_point + MIXING * mean_residual, 0.0), count


def _dissipation(shear_base, shear_penalty, bound, s):
    """:func:`dda.contact.law.friction_dissipation`: Σ b ⟨|λt + ps s| − b⟩₊ / ps."""
    work = 0.0
    for c in range(s.shape[0]):
        work += friction_work(shear_base[c], shear_penalty[c], bound[c], s[c])
    return work


def _band_step(geometry, contacts, law, loop, velocity_step, factor):
    """The outer loop of :func:`dda.solve.step.solve_step` on band systems (module
    docstring); the vectors in band order, the contacts' arrays not changed.

    ``geometry``: a :class:`~dda.solve.band_arguments.BandGeometry`; ``contacts``: the
    contacts' :class:`~dda.solve.band_arguments.BandContacts`; ``law``:
    :class:`~dda.solve.band_arguments.LawSettings`; ``loop``:
    :class:`~dda.solve.band_arguments.LoopRules`; ``velocity_step``: v₀Δt; ``factor``: the
    kept :class:`~dda.solve.band_arguments.Factor`. Returns a
    :class:`~dda.solve.band_arguments.StepOutcome`: the contacts' new data (what
    :func:`dda.contact.law.update` and :func:`dda.contact.law.record` write; the carried
    λt is F) and the counts."""
    g0, s0, forces = geometry.g0, geometry.s0, geometry.forces
    strength, breakable, fresh, state = (
        contacts.strength, contacts.breakable, contacts.fresh, contacts.state
    )  # fmt: skip
    direction, last_normal, penetration = (
        contacts.direction, contacts.last_normal, contacts.penetration
    )  # fmt: skip
    normal_multiplier, shear_multiplier = contacts.normal_multiplier, contacts.shear_multiplier
    penalty = contacts.penalty
    friction, augmented, friction_tolerance = law.friction, law.augmented, law.friction_tolerance
    allowance = multiplier_allowance(law.tolerance, law.persistent)
    budget = loop.budget
    m, n = g0.shape[0], forces.shape[0]
    intact = contacts.intact.copy()
    normal_force, shear_force = last_normal.copy(), np.zeros(m)
    new_state, new_direction = state.copy(), direction.copy()
    bound = _first_bounds(
        intact, strength, normal_multiplier, penalty, allowance, g0, last_normal, fresh,
        state, friction,
    )  # fmt: skip
    points, residuals = np.zeros((DEPTH + 1, m)), np.zeros((DEPTH + 1, m))
    history = 0
    d, g, s = np.zeros(n), g0.copy(), s0.copy()
    previous_g, has_previous = g0.copy(), False
    solves = chords = 0
    goes_on = converged = finite = failed = False
    none = np.zeros(m, np.int8)
    dissipated = 0.0
    while solves < budget:
        terms_penalty = penalty  # the terms' p: the law's update makes a new array
        normal_base, tension, shear_base, shear_penalty, bounds = terms_kernel(
            intact, state, strength, normal_multiplier, shear_multiplier, penalty,
            law.shear_ratio, bound, friction, allowance,
        )  # fmt: skip
        terms = BandTerms(normal_base, penalty, tension, shear_base, shear_penalty, bounds)
        first = solves == 0
        first_normal, first_shear = none, none
        if first:
            if loop.dynamic:
                here = potential_kernel(geometry, terms, d)
                moving = potential_kernel(geometry, terms, velocity_step)
                if not np.isnan(here) and (np.isnan(moving) or moving < here):
                    d = velocity_step.copy()
            g = g0 + _along(geometry.columns, geometry.normal_rows, d)
            s = s0 + _along(geometry.columns, geometry.shear_rows, d)
            first_normal, first_shear = _remembered(
                normal_base, penalty, tension, shear_base, shear_penalty, bounds, g, s, state,
                direction,
            )  # fmt: skip
        inner = -1
        if friction:
            inner = loop.guessed_solves if _guessing(bound) else loop.between_bounds
        chord_start = loop.chord_first and goes_on and chords < budget
        rules = PassRules(
            budget - solves, inner, loop.rate, chord_start, loop.conjugate, loop.tolerance
        )
        start = PassStart(d, g, s, True, first_normal, first_shear, first)
        d, g, s, pass_solves, pass_chords, pass_converged, chord_next, finite = (
            band_minimise_kernel(geometry, terms, friction, start, rules, factor)
        )
        if factor.state[band_newton.FAILED]:
            failed = True
            break
        goes_on = pass_converged or chord_next
        solves += pass_solves
        chords += pass_chords
        finite = finite and np.all(np.isfinite(d))
        if not finite:
            break
        if not pass_converged:
            if solves >= budget:
                break
            target = np.empty(m)
            for c in range(m):  # the bounds of this pass's normal forces
                normal = formulas.normal_force(normal_base[c], terms_penalty[c], tension[c], g[c])
                target[c] = friction_bound(joint_of(strength, c), normal, intact[c])
            bound, history = _advance(bound, target, points, residuals, history)
            continue
        normal, target, changed = forces_and_bounds_kernel(
            normal_base, terms_penalty, tension, shear_base, shear_penalty, bounds, g, s,
            intact, strength, friction,
        )  # fmt: skip
        settled = True
        if friction:
            settled = _norm(changed) <= friction_tolerance * _norm(target)
        if augmented:
            new_n, new_t, new_p, count, _ = augment_kernel(
                normal_base, terms_penalty, tension, shear_base, shear_penalty, bounds, g, s,
                previous_g, has_previous, fresh, penetration, shear_multiplier, law.tolerance,
                law.shrink_target, law.max_penalty, law.growth, law.persistent,
            )  # fmt: skip
            normal_multiplier, shear_multiplier = new_n, new_t
            if has_previous:
                penalty = new_p
            settled = settled and count == 0
        if settled:  # bonds are judged on consistent forces only
            lost = broken_kernel(
                normal_base, terms_penalty, tension, shear_base, shear_penalty, bounds, g, s,
                intact, breakable,
            )  # fmt: skip
            for c in range(m):
                if lost[c]:
                    intact[c] = False
                    settled = False
        normal_force = normal
        if settled:
            converged = True
            break
        bound, history = _advance(bound, target, points, residuals, history)
        previous_g, has_previous = g, True
    finite = finite and not failed
    if finite:
        if friction:
            dissipated = _dissipation(shear_base, shear_penalty, bounds, s)
        new_state, normal_multiplier, new_direction, normal_force, shear_force = (
            recorded_kernel(
                normal_base, terms_penalty, tension, shear_base, shear_penalty, bounds, g, s,
                normal_multiplier, friction_tolerance, law.persistent,
            )
        )  # fmt: skip
    return StepOutcome(
        d, g, s, intact, normal_multiplier, penalty, new_state, new_direction, normal_force,
        shear_force, dissipated, solves, chords, converged, finite, failed,
    )  # fmt: skip


_along = band_newton._along
_pieces = contact_pieces._pieces
_first_bounds = kernel(_first_bounds) or _first_bounds
_remembered = kernel(_remembered) or _remembered
_norm = kernel(_norm) or _norm
_guessing = kernel(_guessing) or _guessing
# the law's Anderson least squares by rows and combination, compiled: the same code, the same
# numbers as the Python loop's on band systems (BoundIteration(by_rows=True))
_least_squares = kernel(contact_law._least_squares_by_rows) or contact_law._least_squares_by_rows
_combination = kernel(contact_law._combination) or contact_law._combination
_advance = kernel(_advance) or _advance
_dissipation = kernel(_dissipation) or _dissipation
band_step_kernel = kernel(_band_step)


def solve_on_band(system, loop) -> tuple[np.ndarray, int, int, bool, float] | None:
    """The step's outer loop (``loop``: a :class:`dda.solve.step._StepLoop` on the
    :class:`dda.solve.band_system.BandSystem` ``system``) in one compiled call.

    Returns what :meth:`~dda.solve.step._StepLoop.solve` does, (D, Newton iterations,
    chord steps, converged, dissipation), with the contacts' law data and states
    written; or None, the contacts untouched, when LAPACK found a K not positive
    definite (the Python loop then solves the step, on the fallback systems).
    """
    contacts, joints, law, rules = loop.contacts, loop.joints, loop.law, loop.rules
    factor = system.factor
    made = int(factor.state[band_newton.FACTORISATIONS])
    velocity_step = loop.blocks.velocity[system.order] * loop.ctx.dt
    start = BandContacts(
        np.ascontiguousarray(contacts.intact, np.bool_), joints.kernel_strength(),
        np.ascontiguousarray(joints.breakable, np.bool_), floats(contacts.normal_multiplier),
        floats(contacts.shear_multiplier), floats(contacts.penalty),
        np.ascontiguousarray(contacts.fresh, np.bool_),
        np.ascontiguousarray(contacts.state, np.int8), floats(contacts.slide_direction),
        floats(contacts.normal_force), floats(contacts.penetration),
    )  # fmt: skip
    settings = LawSettings(
        bool(law.friction), bool(law.augmented), float(law.shear_ratio), float(law.tolerance),
        float(law.shrink_target), float(law.max_penalty), float(law.penalty_growth),
        float(law.friction_tolerance), bool(law.persistent),
    )  # fmt: skip
    loop_rules = LoopRules(
        not loop.ctx.static, int(loop.budget), int(loop.between_bounds),
        int(loop.guessed_bound_solves), float(rules.rate), bool(rules.chord_first),
        bool(rules.conjugate), float(loop.policy.newton_tolerance),
    )  # fmt: skip
    with loop.timer("solve"):  # the passes and the law between them
        out = band_step_kernel(
            system.geometry, start, settings, loop_rules, floats(velocity_step.ravel()), factor
        )
    system.count_factorisations(int(factor.state[band_newton.FACTORISATIONS]) - made)
    if out.failed:
        system.restart()
        return None
    if out.finite:
        contacts.intact, contacts.penalty = out.intact, out.penalty
        contacts.normal_multiplier, contacts.shear_multiplier = (
            out.normal_multiplier,
            out.shear_force,
        )
        contacts.state, contacts.slide_direction = out.state, out.direction
        contacts.normal_force, contacts.shear_force = out.normal_force, out.shear_force
        contacts.penetration, contacts.slip = out.g, out.s
    return system.spread(out.d), out.solves, out.chords, out.converged, out.dissipated
