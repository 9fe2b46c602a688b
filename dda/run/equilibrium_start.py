"""The equilibrium start: a dynamic run starts from the state its scene is drawn in,
loaded.

A scene gives blocks where they touch, at rest and unstressed. Released like that
(Shi's start, ``[analysis] start = "unloaded"``), every contact spring and every
block starts unloaded under the full loads: the blocks drop onto their springs and
ring about their static state, whose force they overshoot up to twice; friction
slips whenever the normal force dips, and a sliding block leaves that start with
extra speed (at Δt ≤ 1e-4 a block on a 30° slope at 1.05 of its friction slid 48 %
further in 1 s than ½ g (sin θ − cos θ tan φ) t²). The scene's geometry is meant as
the loaded one, so by default (``start = "equilibrium"``) a dynamic run starts from
the state of the scene's geometry under its loads at t = 0:

* D* solves the static step: the step's equations with the inertia term 2M/Δt²
  replaced by a regulariser r_i M_i, at ``RELATIVE_REGULARISER`` of each block's
  E_i / m_i (the limit of a static step as Δt → ∞). It is found by pseudo-steps, each
  from the D of the last, by a primal–dual interior-point method
  (:mod:`dda.solve.interior_point`: Coulomb's bound solved with the normal forces, in a
  number of factorisations that does not follow the number of contacts that change
  state), at the regularisers ``INTERIOR_REGULARISERS``: where touching contacts hold
  bonds (cohesion, tension, a residual friction), the first, 1e-2 E/m, holds the
  blocks at 1 % of their elastic stiffness while the loads go into the contacts (the
  bonds that path breaks are broken, each solve repeated with them, as the step's
  passes do), then the last; without bonds the last alone (:func:`_holds_bonds`: one
  solve, 5 fewer factorisations on the bench walls). The step's Newton (:func:`dda.solve.step.
  solve_step`) then finishes at the last regulariser from there (one iteration on the
  bench walls: its pieces are the solution's), and goes on lowering the regulariser
  tenfold a pseudo-step if it did not stand. First, though, where the touching
  contacts carry forces at t = 0 (or none touch), that continuation is tried alone
  within ``FEW_NEWTON_ITERATIONS`` Newton iterations: a scene drawn in equilibrium
  (its contacts carry its in-situ field) stands at once. Where an
  interior-point solve does not settle, the start is that continuation alone, from
  ``FIRST_REGULARISER``, tenfold a pseudo-step: it stops as soon as a pseudo-step has
  moved the blocks by nothing that matters (its regulariser forces ‖r M ΔD‖, the static
  residual at its end, within ``STANDING`` of the loads: every block stands; one that
  cannot goes on moving by about its unbalanced load / r, and takes the continuation to
  the last regulariser). ``summary["start_method"]`` says which settled it.
  The gaps are linear in D (paper eqs. 9-13), so the pseudo-steps accumulate D* with
  the geometry of t = 0.
* The blocks are not moved. The contacts that touch at t = 0 carry the forces of D*
  at the start geometry (λn = N − p g0: the normal force at zero penetration, for
  the augmented Lagrangian and, as a preload, for the penalty method too; λt = F,
  the shear force carried), the blocks the stresses σ0 + E ε(D*), and the effects'
  springs (fixed points, rock bolts) the stretch of D* (``Effect.preload``).

A block that can stand is in equilibrium from t = 0, to the regulariser and the
solve's tolerance (the stick matrix of tests/standing/test_stick_slip.py moves by
1e-13 to 2e-8 m in 0.5 s), at any Δt, penalty and contact method. A block that
cannot (it slides, topples, falls) gets from the limit the forces of rigid contact
at the instant of its release (its D* grows without bound, ~ load / regulariser,
and is never applied): a sliding block starts with N = W cos θ and F = tan φ N, and
follows ½ g (sin θ − cos θ tan φ) t² from t = 0 (to 3e-8 relative at 1 s).

A pseudo-step of the continuation that does not settle within ``BUDGET_FACTOR`` ×
``[contact] max_iterations`` Newton iterations is tried again at a larger regulariser,
halfway back (geometrically) to the last one that settled. If that fails ``RETRIES``
times in a row, or the continuation has spent ``CONTINUATION_BUDGETS`` such budgets,
the run starts unloaded: a warning, and both
``summary["start"]`` and the closing line of ``dda run`` say so (no shipped case and
no ``dda bench`` wall from 10 × 10 to 60 × 60 comes to that).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from dda.blocks import BlockSet
from dda.contact import law as contact_law
from dda.contact.contact_set import ContactSet
from dda.effects.base import Effect, StepContext
from dda.effects.inertia import Inertia
from dda.model import Model
from dda.result import OPEN
from dda.solve.interior_point import NewtonMatrix, solve_interior
from dda.solve.step import solve_step, static_contact_problem
from dda.solve.timing import StageTimer

log = logging.getLogger(__name__)

# the first solve's regulariser over each block's E_i / m_i, of the interior point's and
# the continuation's: it holds the blocks at 1 % of their elastic stiffness while the
# loads go into the contacts (cases/jointed_slope_fos.toml's stored factor of safety
# holds with 1e-2, not with 1e-3 or 1e-1, nor with one solve at the last: a slope at its
# limit stands or not by the equilibrium the start finds, docs/contact.md)
FIRST_REGULARISER = 1e-2
# the last regulariser's stiffness over each block's Young's modulus: small enough that
# the forces are those of the limit (to this fraction)
RELATIVE_REGULARISER = 1e-8
# each solve's regulariser is this fraction of the last one's, so each solve starts
# from the pieces and friction bounds of one that changed fewer of them
REGULARISER_STEP = 0.1
# ... the last one as it comes out of those steps (RELATIVE_REGULARISER to round-off)
LAST_REGULARISER = RELATIVE_REGULARISER * (1.0 + 1e-9)
# Newton iterations each pseudo-step may take, as a multiple of the scene's
# [contact] max_iterations (a pseudo-step moves the blocks much further than a step)
BUDGET_FACTOR = 5
# the continuation's Newton iterations in all, as a multiple of a pseudo-step's budget:
# beyond them it gives up (a 5,000-block slope whose interior point had stalled spent
# 5,463 Newton iterations, 14 minutes, in pseudo-steps tried again before it did; the
# continuation alone settles the 60 × 60 wall of dda bench in 466, one solver thread)
CONTINUATION_BUDGETS = 2
# a pseudo-step that does not settle within its budget is tried again at a larger
# regulariser (``_backed_off``), up to this many times in a row
RETRIES = 3
# the blocks stand once a solve's regulariser forces ‖r M ΔD‖, the static residual at
# its end, are within this fraction of the loads ‖F₀‖: as close to the limit as the
# last regulariser takes a block that stands
STANDING = RELATIVE_REGULARISER
# the interior-point pseudo-steps' regularisers over each block's E_i / m_i (the last
# RELATIVE_REGULARISER; none: the continuation alone). The first, where touching contacts
# hold bonds, holds the blocks while the loads go into the contacts, as the
# continuation's first does: the bonds that path breaks are broken
# (cases/jointed_slope_fos.toml's stored factor of safety holds with it, not with one
# solve at the last regulariser); without bonds the last alone
INTERIOR_REGULARISERS = (FIRST_REGULARISER, RELATIVE_REGULARISER)
# interior-point solves of one pseudo-step: each after the first with the bonds the
# last one broke (contacts that slip lose their cohesion, as in the step's passes)
BOND_ROUNDS = 10
# a start whose contacts carry forces at t = 0 (``_may_stand``) first tries the
# continuation within this many Newton iterations in all (0: not at all): a scene drawn in
# equilibrium (an in-situ field its contacts carry) stands at once (cases/tunnel_deep.toml:
# 3, 0.04 s; its interior-point start 31, 0.25 s)
FEW_NEWTON_ITERATIONS = 4
# how the limit solve settled (``Settled.method``, the run's summary["start_method"]):
# Newton pseudo-steps alone (within FEW_NEWTON_ITERATIONS, or in full where no contact
# touches: an interior point has nothing to solve), the interior point, or the
# continuation after an interior-point solve that did not settle
FEW_NEWTON = "newton"
INTERIOR_POINT = "interior point"
CONTINUATION = "continuation"


class Proximal(Effect):
    """K_i += r_i M_i, F_i −= K_lin,i D_k: the step ΔD from the accumulated D_k of the
    earlier solves, held by the regulariser r_i M_i (the inertia term of a static step of
    Δt = √(2 / r_i)); K_lin D_k: the forces of the block-diagonal springs (elasticity,
    fixed points) at D_k. Gaps are measured at D_k (``StepContext.prescribed``)."""

    name = "proximal"

    def __init__(self, masses: np.ndarray, scale: np.ndarray, offset: np.ndarray) -> None:
        self.masses, self.scale, self.offset = masses, scale, offset

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        return self.scale[:, None, None] * self.masses

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray:
        return self.offset


class StartInterrupted(Exception):
    """The run was asked to stop (a signal) while its equilibrium start ran."""


@dataclass(frozen=True)
class Unsettled:
    """What a start that did not settle spent (the run then starts unloaded)."""

    newton_iterations: int
    method: str  # the last solve tried: INTERIOR_POINT or CONTINUATION (or FEW_NEWTON)


@dataclass(frozen=True)
class Settled:
    """What the equilibrium start gives the run."""

    contacts: ContactSet  # the contacts at t = 0, loaded
    stress: np.ndarray  # (n, 3) the blocks' stresses
    newton_iterations: int
    method: str  # FEW_NEWTON, INTERIOR_POINT or CONTINUATION


def settle(
    model: Model,
    blocks: BlockSet,
    contacts: ContactSet,
    timer: StageTimer,
    report: Callable[[int], None] | None = None,
) -> Settled | Unsettled:
    """The loaded start of ``blocks`` and ``contacts`` (found at t = 0), or what was spent
    (:class:`Unsettled`) when the limit solve does not settle (the run then starts
    unloaded). ``report``: told the Newton iterations spent so far after each solve and
    each interior-point iteration (a long start's progress; what it raises stops the
    start). The effects'
    springs (fixed points, rock bolts) are preloaded in place (``Effect.preload``).

    The limit solve (module docstring): the continuation within
    ``FEW_NEWTON_ITERATIONS`` where the scene may stand as drawn (:func:`_may_stand`);
    else the interior-point pseudo-steps at
    ``INTERIOR_REGULARISERS`` finished by the step's Newton (:func:`_by_interior_point`);
    else the continuation alone (:func:`_by_continuation`). The Newton iterations it
    reports count the interior-point solves' factorisations too."""
    touching = np.flatnonzero(contacts.state != OPEN)
    start = contacts.subset(touching)
    limit = _Limit.of(model, blocks, report=report)
    stiffness = _young(model)[blocks.material] / limit.masses[:, 0, 0]  # E_i / m_i
    found, newton, method = None, 0, FEW_NEWTON
    if not len(start):  # no contact: nothing for an interior point, Newton pseudo-steps
        found, newton = _by_continuation(limit, blocks, start, stiffness, timer)
        if found is None:
            log.warning("the equilibrium start did not settle: the run starts unloaded")
            return Unsettled(newton, method)
    if found is None and INTERIOR_REGULARISERS and FEW_NEWTON_ITERATIONS and _may_stand(start):
        quick = _Limit.of(model, blocks, budget=FEW_NEWTON_ITERATIONS, report=report)
        found, newton = _by_continuation(quick, blocks, start, stiffness, timer, at_most=True)
        limit.spent = quick.spent  # the progress goes on from the iterations spent
    if found is None and INTERIOR_REGULARISERS:
        method = INTERIOR_POINT
        try:
            found, more = _by_interior_point(limit, blocks, start, stiffness, timer)
        finally:
            limit.release()
        newton += more
        if found is None:
            log.info("the interior-point start did not settle: it goes on by continuation")
    if found is None:
        found, more = _by_continuation(limit, blocks, start, stiffness, timer)
        newton, method = newton + more, CONTINUATION
        if found is None:
            log.warning("the equilibrium start did not settle: the run starts unloaded")
            return Unsettled(newton, method)
    d, current = found
    for effect in model.effects:
        effect.preload(blocks, d)
    loaded = _loaded(contacts, touching, current, start.penetration)
    stress = blocks.stress + model.elastic.stress_increment(blocks, d)
    return Settled(loaded, stress, newton, method)


def _may_stand(touching: ContactSet) -> bool:
    """True when the scene may stand as it is drawn, so that the start tries a few Newton
    iterations first: its touching contacts carry forces at t = 0 (an in-situ field,
    :mod:`dda.contact.preload`), or none touch. Contacts that start unloaded carry the
    loads only once the limit solve has found their forces: the interior point, at once
    (the few Newton iterations failed on every shipped case whose contacts start unloaded,
    four iterations spent each time: 53 ms of the tunnel's 0.39 s start)."""
    if not len(touching):
        return True
    carried = (touching.normal_multiplier != 0.0) | (touching.shear_multiplier != 0.0)
    return bool(np.any(carried))


def _by_interior_point(limit, blocks, start, stiffness, timer):
    """((D*, the contacts solved), Newton iterations and factorisations) of interior-point
    pseudo-steps at the regularisers ``INTERIOR_REGULARISERS``, then a pseudo-step of the
    step's Newton at the last of them from there (its pieces are the solution's: one
    iteration on the bench walls); (None, the iterations spent) when one does not
    settle."""
    d = np.zeros((blocks.count, 6))
    contacts, newton = start, 0
    regularisers = INTERIOR_REGULARISERS
    if not _holds_bonds(limit.model, blocks, start):
        regularisers = regularisers[-1:]  # nothing for a first pseudo-step to break
    for fraction in regularisers:
        with timer("interior_point"):
            step, recorded, iterations = limit.interior(blocks, contacts, fraction * stiffness, d)
        newton += iterations
        limit.count(iterations)
        if recorded is None:
            return None, newton
        d = d + np.where(~blocks.fixed[:, None], step, 0.0)
        contacts = _restarted(start, recorded)
    found, more = _by_continuation(limit, blocks, start, stiffness, timer, (d, recorded, fraction))
    return found, newton + more


def _holds_bonds(model: Model, blocks: BlockSet, touching: ContactSet) -> bool:
    """Some touching contact holds a bond: a strength that changes when it slips or opens
    (:attr:`dda.contact.strength.JointProperties.breakable`: cohesion, tension, a
    residual friction), which the start's first pseudo-step may break."""
    contact = model.contact
    if contact is None or not len(touching):
        return False
    joints = contact.joints
    rows = joints.rows_for(blocks, touching)
    strengths = joints.properties(rows, np.ones(len(rows)))
    return bool(np.any(touching.intact & strengths.breakable))


def _by_continuation(limit, blocks, start, stiffness, timer, reached=None, at_most=False):
    """((D*, the contacts solved), Newton iterations) of the continuation: pseudo-steps of
    the step's Newton from ``FIRST_REGULARISER`` down to the last (module docstring), or
    from ``reached`` = (D, the contacts solved, the regulariser) of an earlier solve;
    (None, the iterations spent) when it does not settle. ``at_most``: within the
    limit's Newton budget in all, no pseudo-step tried again."""
    free = ~blocks.fixed
    d = np.zeros((blocks.count, 6))
    current, newton = start.copy(), 0
    fraction, settled, failed = FIRST_REGULARISER, None, 0  # r_i / (E_i / m_i)
    if reached is not None:
        d, current, fraction = reached
    while True:
        scale = fraction * stiffness
        solution = limit.solve(blocks, _restarted(start, current), scale, d, timer)
        newton += solution.newton_iterations
        limit.count(solution.newton_iterations)
        if not solution.converged or not np.all(np.isfinite(solution.d)):
            failed += 1
            if failed > RETRIES or at_most or newton >= CONTINUATION_BUDGETS * limit.budget:
                return None, newton
            fraction = _backed_off(fraction, settled)
            continue
        failed = 0
        step = np.where(free[:, None], solution.d, 0.0)
        d, current = d + step, solution.contacts
        if limit.stands(scale, step) or fraction <= LAST_REGULARISER:
            return (d, current), newton
        if newton >= (1 if at_most else CONTINUATION_BUDGETS) * limit.budget:
            return None, newton
        settled, fraction = fraction, max(fraction * REGULARISER_STEP, RELATIVE_REGULARISER)


@dataclass
class _Limit:
    """The static solves of the start: the run's model without inertia, pure penalty,
    ``BUDGET_FACTOR`` times its Newton budget, the regulariser :class:`Proximal` in
    place of the inertia."""

    model: Model
    effects: list[Effect]  # the run's, less inertia
    linear: np.ndarray  # (n, 6, 6) their block-diagonal springs
    masses: np.ndarray  # (n, 6, 6)
    loads: float  # ‖F₀‖ over the free blocks: the effects' forces at the start
    budget: int  # Newton iterations of each solve
    matrix: NewtonMatrix | None = None  # the interior-point solves' (one contact set)
    report: Callable[[int], None] | None = None  # told the iterations spent so far
    spent: int = 0

    @classmethod
    def of(
        cls,
        model: Model,
        blocks: BlockSet,
        budget: int | None = None,
        report: Callable[[int], None] | None = None,
    ) -> _Limit:
        """The limit solves of ``model``, each with ``budget`` Newton iterations (None:
        ``BUDGET_FACTOR`` times the scene's ``max_iterations``), ``report`` told the
        iterations spent so far after each."""
        contact = model.contact
        if contact is not None:
            contact = replace(contact, law=replace(contact.law, augmented=False))
        if budget is None:
            budget = BUDGET_FACTOR * model.scene.contact.max_iterations
        scene = replace(model.scene, contact=replace(model.scene.contact, max_iterations=budget))
        static = replace(model, scene=scene, contact=contact)
        kept = [e for e in model.effects if not isinstance(e, Inertia)]
        ctx = _context(model)
        linear, forces = np.zeros((blocks.count, 6, 6)), np.zeros((blocks.count, 6))
        for effect in kept:
            if (k := effect.stiffness(blocks, ctx)) is not None:
                linear += k
            if (f := effect.forces(blocks, ctx)) is not None:
                forces += f
        loads = float(np.linalg.norm(forces[~blocks.fixed]))
        masses = model.inertia.masses(blocks)
        return cls(static, kept, linear, masses, loads, budget, report=report)

    def count(self, iterations: int) -> None:
        """Add ``iterations`` to those spent, and report the sum."""
        self.spent += iterations
        self.tell(0)

    def tell(self, under_way: int) -> None:
        """Report the iterations spent and ``under_way`` more of a solve not ended (the
        report may stop the start: an interior-point solve is asked after each of its
        iterations, not only at its end)."""
        if self.report is not None:
            self.report(self.spent + under_way)

    def solve(self, blocks, contacts, scale, d, timer):
        """The step ΔD from the accumulated ``d`` held by the regulariser ``scale`` r_i."""
        offset = -np.einsum("nij,nj->ni", self.linear, d)
        effects = [Proximal(self.masses, scale, offset), *self.effects]
        model = replace(self.model, effects=effects)
        ctx = _context(model)
        ctx.prescribed = d
        return solve_step(model, blocks, contacts, ctx, timer)

    def interior(self, blocks, contacts, scale, d):
        """(ΔD, the contacts with the states and forces at d + ΔD, factorisations) of the
        interior-point solve of the step from the accumulated ``d`` held by the regulariser
        ``scale`` (as :meth:`solve`), each repeated with the bonds the last broke; the
        contacts None when one did not converge."""
        offset = -np.einsum("nij,nj->ni", self.linear, d)
        effects = [Proximal(self.masses, scale, offset), *self.effects]
        model = replace(self.model, effects=effects)
        ctx = _context(model)
        ctx.prescribed = d
        work, iterations = contacts.copy(), 0
        for _ in range(BOND_ROUNDS):
            problem = static_contact_problem(model, blocks, work, ctx)
            if self.matrix is None or not self.matrix.fits(problem):
                self.release()
                self.matrix = NewtonMatrix(problem)
            tell = partial(_shifted, self.tell, iterations)  # this call's earlier rounds
            solution = solve_interior(problem, self.matrix, after_iteration=tell)
            iterations += solution.iterations
            if not solution.converged:
                return solution.d, None, iterations
            g, s = problem.geometry.at(solution.d)
            terms = replace(problem.terms, bound=problem.bound(solution.normal))
            if problem.joints is None or not contact_law.break_bonds(
                work, terms, problem.joints, g, s
            ):
                break
        else:
            return solution.d, None, iterations
        band = 0.0 if model.contact is None else model.contact.law.friction_tolerance
        contact_law.record(work, terms, g, s, band)
        return solution.d, work, iterations

    def release(self) -> None:
        """Free the interior-point solves' matrix (PARDISO's memory)."""
        if self.matrix is not None:
            self.matrix.release()
            self.matrix = None

    def stands(self, scale: np.ndarray, step: np.ndarray) -> bool:
        """True when the regulariser forces of the solve ``step``, the static residual
        r M ΔD at its end, are within ``STANDING`` of the loads: every block stands
        (one that cannot goes on moving by about its unbalanced load / r)."""
        held = scale[:, None] * np.einsum("nij,nj->ni", self.masses, step)
        return bool(np.linalg.norm(held) <= STANDING * self.loads)


def _shifted(tell: Callable[[int], None], earlier: int, under_way: int) -> None:
    """``tell`` the iterations under way after ``earlier`` ones."""
    tell(earlier + under_way)


def _backed_off(fraction: float, settled: float | None) -> float:
    """The regulariser (over E / m) to try again a pseudo-step at ``fraction`` that did not
    settle: halfway back (geometrically) to ``settled``, the last one that did, or
    tenfold for the first pseudo-step (a larger regulariser changes fewer pieces)."""
    if settled is None:
        return fraction / REGULARISER_STEP
    return float(np.sqrt(fraction * settled))


def _context(model: Model) -> StepContext:
    """The static solves' step context at t = 0."""
    return StepContext(dt=model.max_time_step, time=0.0, step=0, static=True)


def _restarted(start: ContactSet, solved: ContactSet) -> ContactSet:
    """``start`` (no forces carried: the gaps are measured from the start geometry) with
    the pieces, normal forces and bonds of the last solve ``solved`` (same rows)."""
    out = start.copy()
    for name in ("state", "slide_direction", "normal_force", "intact"):
        setattr(out, name, getattr(solved, name).copy())
    out.fresh[:] = False
    return out


def _young(model: Model) -> np.ndarray:
    """Young's modulus of each material (the largest entry of its elasticity matrix)."""
    return model.elastic.material_elasticity[:, 0, 0]


def _loaded(
    contacts: ContactSet, rows: np.ndarray, solved: ContactSet, start_gap: np.ndarray
) -> ContactSet:
    """``contacts`` with the rows ``rows`` carrying the forces of ``solved`` at the start
    geometry: λn = N − p g0 (so that λn + p g0 = N), λt = F."""
    out = contacts.copy()
    closed = solved.state != OPEN
    out.normal_multiplier[rows] = np.where(
        closed, solved.normal_force - solved.penalty * start_gap, 0.0
    )
    out.shear_multiplier[rows] = np.where(closed, solved.shear_force, 0.0)
    for name in ("state", "slide_direction", "normal_force", "shear_force", "intact"):
        getattr(out, name)[rows] = getattr(solved, name)
    out.fresh[rows] = False
    return out
