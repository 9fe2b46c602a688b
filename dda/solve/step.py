"""One time step: the minimiser of the step's incremental potential (:mod:`dda.solve.newton`).

A step's linear systems take one of three forms: in band storage where the kernels
are used and the band is narrow enough (:mod:`dda.solve.band_system`; a Newton pass
is one compiled call), else, for the numpy Newton, dense up to the policy's
``dense_system_rows`` unknowns (:mod:`dda.solve.dense_system`,
:class:`dda.solve.policy.StepPolicy`), else on a sparse block pattern (every step,
with ``DDA_SYSTEMS=sparse``), as follows.
K changes only when contact pieces or penalties change; between such
changes every Newton iteration, augmentation (AL) or friction update re-uses
K and only rebuilds F. Across steps, while the contact graph is the same, the block
pattern of K (its fill-reducing order, CSR structure and scatter indices)
and the last factorisation are kept: a new K is solved by conjugate
gradients preconditioned with that factorisation (:mod:`dda.solve.linsolve`),
and re-factorised only when that stops paying.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from dda.blocks import BlockSet
from dda.contact import law as contact_law
from dda.contact.broad import candidate_pairs
from dda.contact.contact_set import ContactSet
from dda.contact.formulas import first_bound, remembered_pieces
from dda.contact.law import BoundIteration, ContactLaw, JointProperties
from dda.contact.narrow import separated_blocks
from dda.contact.potential import ContactTerms
from dda.contact.push_out import found_overlap, push_metric, push_out_displacement
from dda.contact.rows import ContactRows, contact_rows, gaps_after
from dda.effects.base import StepContext
from dda.effects.pair_springs import PairSprings
from dda.model import Model
from dda.result import OPEN
from dda.solve.assembly import (
    BLOCK,
    BlockPattern,
    assemble,
    contacts_key,
    free_pairs,
    free_rows,
    reassemble,
    subtract_contact_forces,
)
from dda.solve.band_system import BandOrder, BandSystem, band_kernels
from dda.solve.contact_dashpots import contact_dashpots
from dda.solve.dense_system import DenseSystem
from dda.solve.interior_point import StaticContactProblem
from dda.solve.linsolve import ReusingSolver, block_ordering
from dda.solve.low_rank import StepUpdates
from dda.solve.newton import BlockQuadratic, ContactGeometry, better_start, minimise
from dda.solve.policy import SizeRules, StepPolicy, current_policy
from dda.solve.systems import NumpyPasses, StepSystems
from dda.solve.timing import StageTimer


@dataclass
class StepSolution:
    """Outcome of one step attempt."""

    d: np.ndarray  # (n, 6) unknowns of every block (zeros for fixed blocks)
    contacts: ContactSet
    iterations: int  # linear solves (Newton iterations and chord steps)
    factorisations: int
    converged: bool
    max_penetration: float
    pushed: np.ndarray | None = None  # (n, 6) part of d that removed overlap found this step
    friction_dissipation: float = 0.0  # work of the friction forces against the slips
    moved: float = 0.0  # largest vertex displacement (m), once the step is accepted
    moves: np.ndarray | None = None  # (NV, 2) each vertex's displacement, likewise
    # Newton iterations: assembled systems solved (the rest of ``iterations`` are chord
    # steps, back-substitutions with a kept factorisation)
    newton_iterations: int = 0
    loads: np.ndarray | None = None  # (n, 6) F₀: the effects' forces of the step


@dataclass
class LinearCache:
    """What a run keeps between steps: its :class:`~dda.solve.policy.StepPolicy`, the
    current block pattern, the solver and the band numbering.

    ``coefficients`` are the contact spring constants (normal and shear) of
    the factorised K: a new K whose springs differ in more than the policy's
    ``max_changed_for_pcg`` contacts is a high-rank change, re-factorised
    at once instead of trying PCG first.
    """

    policy: StepPolicy = field(default_factory=current_policy)
    pattern: BlockPattern | None = None
    solver: ReusingSolver = None  # type: ignore[assignment]  # made from the policy
    coefficients: tuple[np.ndarray, np.ndarray] | None = None  # sorted contact keys, springs
    band: BandOrder = None  # type: ignore[assignment]  # the band systems' block numbering

    def __post_init__(self) -> None:
        if self.solver is None:
            self.solver = ReusingSolver(policy=self.policy)
        if self.band is None:
            self.band = BandOrder(self.policy.reorder_growth)

    def pattern_for(
        self,
        fixed: np.ndarray,
        block_a: np.ndarray,
        block_b: np.ndarray,
        neighbours: Callable[[], np.ndarray] | None = None,
        active: np.ndarray | None = None,
        coupled: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        """The pattern of this contact list (of its ``active``, closed, contacts).

        The kept one when the list is the same; its structure (ordering, CSR,
        and so the factorisation's analysis) with new slots while every contact
        still lands on one of its blocks; else a new one. A new pattern also
        holds the pairs of blocks ``neighbours()`` returns (pairs of blocks
        close enough to come into contact soon) and the old pattern's pairs
        (up to the policy's ``spare_pairs`` per needed pair): contacts come and go at the
        search distance, and each new pattern costs an ordering and an analysis.
        ``coupled``: pairs of blocks (block_i, block_j) that springs join (rock
        bolts): the pattern holds them always.
        """
        kept = self.pattern
        if coupled is not None and kept is not None and not kept.covers(fixed, *coupled):
            kept = None  # a spring between blocks that K has no block for: a new pattern
        if kept is not None and kept.contacts_key == contacts_key(fixed, block_a, block_b):
            if kept.lands(active):
                return kept
        elif kept is not None and kept.covers(fixed, block_a, block_b, active):
            self.pattern = kept.with_contacts(block_a, block_b)
            return self.pattern
        rows = free_rows(fixed)
        extra = []
        if neighbours is not None:
            near = neighbours()
            extra.append(free_pairs(rows, near[:, 0], near[:, 1]))
        if coupled is not None:
            extra.append(free_pairs(rows, *coupled))
        if kept is not None and np.array_equal(kept._fixed, fixed):
            needed = len(free_pairs(rows, block_a, block_b))
            if len(kept.pairs) <= self.policy.spare_pairs * max(needed, 1):
                extra.append(kept.pairs)
        spare = np.concatenate(extra) if extra else None
        self.pattern = BlockPattern(fixed, block_a, block_b, block_ordering, spare, active)
        self.coefficients = None
        return self.pattern


def pattern_neighbours(
    blocks: BlockSet, contacts: ContactSet, settings, margin: float
) -> np.ndarray:
    """Block pairs a new pattern holds beside those of the closed contacts.

    The pairs of boxes within ``margin`` (the policy's ``neighbour_margin``) of the
    search distance
    (blocks that may come into contact soon), less the pairs with no contact
    whose corners meet at a node that other blocks fill
    (:func:`dda.contact.narrow.separated_blocks`): those get no contact while
    the node stays filled, so K does not need their fill-in. On the standard
    walls these are the diagonal neighbours, half the block pairs; without
    them a factorisation of the 30x30 wall costs a third less.
    """
    near = candidate_pairs(blocks, margin * settings.search_distance)  # i < j
    search, radius, tight = settings.search_distance, settings.vertex_radius, settings.law.tolerance
    apart = separated_blocks(blocks, near, search, radius, tight)  # i < j

    def key(a, b):  # one integer per unordered pair
        return np.minimum(a, b) * blocks.count + np.maximum(a, b)

    no_contact = np.setdiff1d(key(*apart.T), key(contacts.block_a, contacts.block_b))
    return near[~np.isin(key(*near.T), no_contact)]


def _couplings(model: Model, blocks: BlockSet, ctx: StepContext) -> PairSprings | None:
    """The springs between blocks that the effects add this step (rock bolts), or None."""
    return PairSprings.join([effect.couplings(blocks, ctx) for effect in model.effects])


def _effect_terms(model: Model, blocks: BlockSet, ctx: StepContext):
    diagonal = np.zeros((blocks.count, 6, 6))
    forces = np.zeros((blocks.count, 6))
    for effect in model.effects:
        k = effect.stiffness(blocks, ctx)
        if k is not None:
            diagonal += k
        f = effect.forces(blocks, ctx)
        if f is not None:
            forces += f
    return diagonal, forces


def _push_metric(
    model: Model, blocks: BlockSet, ctx: StepContext, base_k: np.ndarray
) -> np.ndarray:
    """The push-out's metric (:func:`dda.contact.push_out.push_metric`): the step's block
    springs ``base_k`` less the inertia's, and a little of the blocks' rigid mass."""
    springs = base_k - model.inertia.stiffness(blocks, ctx)
    masses = model.inertia.masses(blocks)
    young = model.elastic.material_elasticity[:, 0, 0][blocks.material]
    return push_metric(springs, masses, young / masses[:, 0, 0])


def _stiffness(
    pattern, blocks, base_diagonal, coefficients, rows, law, earlier=None, couplings=None
):
    """K (in the pattern's order) and the contact springs (2, m) it holds.

    ``coefficients``: the contacts' :func:`dda.contact.law.contact_coefficients`.
    ``earlier``: (pattern, K, springs) assembled before in this step (the same
    rows and effects); on the same pattern, only the contacts whose springs
    changed are added to it (:func:`dda.solve.assembly.reassemble`). ``couplings``:
    the springs between blocks (rock bolts, :mod:`dda.effects.pair_springs`).
    """
    p, ps, _, _ = coefficients
    springs = np.stack([p, ps if law.friction else np.zeros_like(ps)])  # the ones K holds
    if earlier is not None and earlier[0] is pattern:
        change = springs - earlier[2]
        changed = np.flatnonzero(change.any(axis=0))
        if len(changed) == 0:
            return earlier[1], springs
        terms = [(rows.normal_i[changed], rows.normal_j[changed], change[0, changed])]
        if law.friction:
            terms.append((rows.shear_i[changed], rows.shear_j[changed], change[1, changed]))
        return reassemble(pattern, earlier[1], terms, changed), springs
    terms = [(rows.normal_i, rows.normal_j, springs[0])]  # rows of one array: no copy
    if law.friction:
        terms.append((rows.shear_i, rows.shear_j, springs[1]))
    return assemble(pattern, base_diagonal, blocks.fixed, terms, couplings), springs


def _keyed_springs(contacts: ContactSet, springs: np.ndarray):
    """The springs K holds, by contact key (sorted); open contacts hold none and are left
    out, so that one coming or going within the search distance is no change of K."""
    live = np.flatnonzero(springs.any(axis=0))
    order = live[np.argsort(contacts.key[live], kind="stable")]
    return contacts.key[order], springs[:, order]


def _similar(cache: LinearCache, keys: np.ndarray, springs: np.ndarray) -> bool:
    """True when few contact springs differ from those of the factorised K.

    Contacts are matched by their persistent keys (sorted); one that is new,
    gone or has other springs counts as changed.
    """
    if cache.coefficients is None or cache.solver.pcg_budget < 2:
        return False
    old_keys, old_springs = cache.coefficients
    if len(old_keys) == 0:
        changed = len(keys)
    else:
        at = np.clip(np.searchsorted(old_keys, keys), 0, len(old_keys) - 1)
        found = old_keys[at] == keys
        same = found & np.all(old_springs[:, at] == springs, axis=0)
        changed = (len(keys) - int(same.sum())) + (len(old_keys) - int(found.sum()))
    limit = cache.policy.max_changed_for_pcg
    return changed <= limit and changed + 2 <= cache.solver.pcg_budget


def _forces(base_forces, contacts, rows, coefficients):
    """F: the effects' forces and the contact forces (``coefficients`` as for K)."""
    forces = base_forces.copy()
    _, _, normal, shear = coefficients
    _subtract_forces(forces, contacts, rows, normal, shear)
    return forces


def _subtract_forces(forces, contacts, rows, normal, shear) -> None:
    """F −= Σ N ∇g + Σ F ∇s over the contacts (in place; ``normal``, ``shear``: N, F)."""
    gradients = (rows.normal_i, rows.normal_j, rows.shear_i, rows.shear_j)
    subtract_contact_forces(forces, contacts.block_a, contacts.block_b, gradients, normal, shear)


def _solve(
    cache: LinearCache, pattern, k, forces, blocks, timer, springs=None, updates=None, raw=None
) -> np.ndarray:
    """D (n, 6) from K (in the pattern's order) and F (n, 6) per block.

    ``springs``: (contact keys, springs) of K, sorted by key (None without
    contacts), to decide whether PCG on the kept factorisation is worth trying.
    ``updates``: the :class:`StepUpdates` of this step's factorised K, and ``raw`` K's
    springs per contact: a few changed springs are solved for through that factorisation.
    """
    rhs = pattern.to_matrix_order(forces).ravel()
    x = None
    if updates is not None and updates.applies(cache.solver.factored, pattern):
        with timer("solve"):
            x = updates.solve(k, rhs, raw)
    if x is None:
        similar = springs is None or _similar(cache, *springs)
        x = cache.solver.solve(k, rhs, key=pattern.key, timer=timer, similar=similar)
    if springs is not None and cache.solver.factored is k:
        cache.coefficients = springs
    return pattern.from_matrix_order(x)


class _PieceSystem(NumpyPasses):
    """The linear system of one Newton iteration, K(springs) D = F(offsets), with reuse.

    K is re-assembled only when some contact spring changed (only those contacts
    are added again, on the same pattern); the solve re-uses the kept
    factorisation through PCG or low-rank updates (:class:`dda.solve.low_rank.StepUpdates`)
    when few springs changed since it was made.
    """

    def __init__(
        self, cache, blocks, contacts, rows, base_k, base_f, law, neighbours, timer, couplings=None
    ):
        self.cache, self.blocks, self.contacts, self.rows = cache, blocks, contacts, rows
        self.base_k, self.base_f, self.law = base_k, base_f, law
        self.neighbours, self.timer = neighbours, timer
        self.couplings = couplings  # springs between blocks (rock bolts), constant in the step
        self.coupled = None if couplings is None else (couplings.block_i, couplings.block_j)
        self.pattern = self.k = self.keyed = self.assembled = self.updates = None
        self.factorisations = 0  # its factorisations are counted by the cache's solver

    def __call__(self, kn, ks, offset_n, offset_t) -> np.ndarray:
        blocks, contacts, cache = self.blocks, self.contacts, self.cache
        coefficients = (kn, ks, offset_n, offset_t)
        with self.timer("assembly"):
            if self.assembled is None or not np.array_equal(np.stack([kn, ks]), self.assembled[2]):
                active = (kn > 0.0) | (ks > 0.0)  # contacts that add to K
                self.pattern = cache.pattern_for(
                    blocks.fixed,
                    contacts.block_a,
                    contacts.block_b,
                    self.neighbours,
                    active,
                    self.coupled,
                )
                self.k, springs = _stiffness(
                    self.pattern,
                    blocks,
                    self.base_k,
                    coefficients,
                    self.rows,
                    self.law,
                    self.assembled,
                    self.couplings,
                )
                self.assembled = (self.pattern, self.k, springs)
                self.keyed = _keyed_springs(contacts, springs)
            f = _forces(self.base_f, contacts, self.rows, coefficients)
        d = _solve(
            cache,
            self.pattern,
            self.k,
            f,
            blocks,
            self.timer,
            self.keyed,
            self.updates,
            self.assembled[2],
        )
        k = self.k
        if cache.solver.factored is k and (self.updates is None or self.updates.factored is not k):
            self.updates = StepUpdates(
                k,
                self.assembled[2],
                self.pattern,
                self.rows,
                contacts.block_a,
                contacts.block_b,
                cache.solver.solve_many,
                cache.policy,
            )
        return d

    def chord(self, residual: np.ndarray) -> np.ndarray | None:
        """K_f⁻¹ r (n, 6) with the solver's kept factorisation K_f, when it is one of
        this pattern (:func:`dda.solve.newton.minimise`'s chord steps), else None."""
        if self.pattern is None:
            return None
        rhs = self.pattern.to_matrix_order(residual).ravel()
        with self.timer("solve"):
            x = self.cache.solver.solve_kept(rhs, self.pattern.key)
        return None if x is None else self.pattern.from_matrix_order(x)

    def contact_vector(self, normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
        """Σ N ∇g + Σ F ∇s over the contacts, (n, 6)."""
        out = np.zeros_like(self.base_f)
        _subtract_forces(out, self.contacts, self.rows, -normal, -shear)
        return out


def _band_system(cache, blocks, contacts, rows, base_k, base_f, law, couplings, timer, fallback):
    """The step's :class:`BandSystem` where it pays (the kernels used, the band narrow
    enough: :mod:`dda.solve.band_system`), else None."""
    free_rows_count = BLOCK * int(np.count_nonzero(~blocks.fixed))
    narrowest = cache.band.made_width(blocks.fixed)
    pays = cache.policy.band_pays
    if not (cache.solver.automatic and pays(free_rows_count, narrowest) and band_kernels()):
        return None
    none = np.zeros(0, np.int64)
    bolts = (none, none) if couplings is None else (couplings.block_i, couplings.block_j)
    with timer("assembly"):
        numbering = cache.band.numbering(blocks.fixed, contacts.block_a, contacts.block_b, *bolts)
        if not pays(free_rows_count, numbering.width):
            return None
        return BandSystem(
            blocks.fixed, contacts.block_a, contacts.block_b, rows, base_k, base_f,
            law.friction, couplings, numbering, timer, fallback,
        )  # fmt: skip


def _start_at_touch(contacts: ContactSet, rows: ContactRows, touch: float) -> np.ndarray | None:
    """The overlap of the contacts found this step already overlapping
    (:func:`dda.contact.push_out.found_overlap`), taken out of their start penetration:
    the step solves them from touch, and the caller removes the overlap by position
    (:func:`dda.contact.push_out.push_out_displacement`); None where there is none."""
    overlap = found_overlap(contacts, touch)
    if not overlap.any():
        return None
    rows.penetration = rows.penetration - overlap
    contacts.penetration = contacts.penetration - overlap
    return overlap


def _rows_at(blocks: BlockSet, contacts: ContactSet, ctx: StepContext) -> ContactRows:
    """The contacts' rows, their gaps at ``ctx.prescribed`` where it is given (fixed
    blocks moved by the ground, or the equilibrium start's accumulated D: the known part
    of g and s)."""
    rows = contact_rows(blocks, contacts)
    if ctx.prescribed is not None:
        rows.penetration, rows.slip = gaps_after(
            rows, contacts.block_a, contacts.block_b, ctx.prescribed
        )
    return rows


def _first_bounds(contacts, rows, joints, law) -> np.ndarray:
    """Friction bounds of the step's first solve, from the larger of each contact's
    normal force at the end of the last step and at this step's start geometry
    (a contact of blocks that turn together may open by the second-order rotation
    of one step and close again in the next: its last force is the better guess);
    a contact found this step touching (no force known yet) starts stuck
    (``UNBOUNDED``); one found open starts with the bound of its start geometry (0: no
    normal force, and no bond across a gap): a stuck shear spring on an open contact
    would join two blocks a search distance apart in K and its block pattern."""
    if not law.friction:
        return np.zeros(len(contacts))
    found_touching = contacts.fresh & (contacts.state != OPEN)
    return first_bound(
        joints, contacts.intact, contacts.state == OPEN, contacts.normal_multiplier,
        contacts.penalty, law.allowance, rows.penetration, contacts.normal_force, found_touching,
    )  # fmt: skip


def _remembered_pieces(contacts: ContactSet, terms, g: np.ndarray, s: np.ndarray):
    """Pieces for the step's first Newton iteration: the states the contacts ended the
    last step in (a contact closed then is taken closed, one sliding then is taken
    sliding the same way), else the pieces at the start point."""
    normal, shear = remembered_pieces(*terms.pieces(g, s), contacts.state, contacts.slide_direction)
    return normal.astype(np.int8), shear.astype(np.int8)


def _constant_velocity(blocks: BlockSet, ctx: StepContext) -> np.ndarray:
    """D = v0 Δt: the step if nothing changed the blocks' motion (fixed blocks: 0)."""
    return np.where(blocks.fixed[:, None], 0.0, blocks.velocity * ctx.dt)


@dataclass
class _StepLoop:
    """What the step's outer loop works on; :meth:`solve` is the loop in Python (numpy
    Newton or one compiled pass at a time), :func:`dda.solve.band_step.solve_on_band`
    the whole loop compiled on band systems."""

    blocks: BlockSet
    contacts: ContactSet
    rows: ContactRows
    joints: JointProperties
    law: ContactLaw
    system: StepSystems
    budget: int
    rules: SizeRules
    ctx: StepContext
    timer: StageTimer
    quadratic: BlockQuadratic
    policy: StepPolicy

    @property
    def guessed_bound_solves(self) -> int:
        """Newton iterations and chord steps on a step's first bounds while some are a guess."""
        return self.policy.guessed_bound_solves

    @property
    def between_bounds(self) -> int:
        """Newton iterations and chord steps on one set of bounds."""
        return 1 if self.rules.bounds_every_solve else self.policy.inner_solves

    def solve(self) -> tuple[np.ndarray, int, int, bool, float]:
        """(D, Newton iterations, chord steps, converged, friction's dissipation); the
        contacts' law data and states written (:func:`dda.contact.law.update`,
        :func:`dda.contact.law.record`)."""
        blocks, contacts, rows, joints, law = (
            self.blocks, self.contacts, self.rows, self.joints, self.law
        )  # fmt: skip
        system, budget, rules, ctx, timer = (
            self.system, self.budget, self.rules, self.ctx, self.timer
        )  # fmt: skip
        with timer("contact_law"):
            first = _first_bounds(contacts, rows, joints, law)
            bounds = BoundIteration(first, system.sums_by_rows)  # as the compiled loop sums
        quadratic = self.quadratic
        geometry = ContactGeometry(rows, contacts.block_a, contacts.block_b)
        d = np.zeros((blocks.count, 6))
        solves, chords, converged, previous_g = 0, 0, False, None
        # this pass goes on, on new friction bounds, from an unfinished one whose next
        # direction was a chord direction, or from a converged one whose solution the law
        # then moved (new bounds or multipliers: the pieces, and so the kept
        # factorisation, still fit nearly everywhere); in large systems
        # (SizeRules.chord_first) it starts with a chord step, only while the chord steps
        # are fewer than the Newton iterations' budget: a Newton iteration in every pass
        # bounds the step's work
        goes_on = False
        gaps = None  # (g, s) at d, when known
        while solves < budget:
            terms = contact_law.contact_terms(contacts, joints, law, bounds.bound)
            guess = None
            if solves == 0:
                if not ctx.static:
                    candidates = [d, _constant_velocity(blocks, ctx)]
                    start = system.better_start(terms, candidates)  # compiled, or None
                    if start is None:
                        start = better_start(quadratic, geometry, terms, candidates)
                    d = start
                gaps = system.gaps(d)
                if gaps is None:
                    gaps = geometry.at(d)
                guess = _remembered_pieces(contacts, terms, *gaps)
            inner = None
            if law.friction:
                inner = self.guessed_bound_solves if bounds.guessing else self.between_bounds
            rule = {
                "max_steps": inner,
                "rate": rules.rate,
                "chord_first": rules.chord_first and goes_on and chords < budget,
                "start_gaps": gaps,
                "conjugate": rules.conjugate,
                "tolerance": self.policy.newton_tolerance,
            }
            newton = system.minimise(terms, d, budget - solves, guess, **rule)  # or None
            if newton is None:
                newton = minimise(
                    quadratic, geometry, terms, system, system.contact_vector, d,
                    budget - solves, guess, chord=system.chord, forces_from_rows=True, **rule,
                )  # fmt: skip
            gaps = newton.gaps
            goes_on = newton.converged or newton.chord_next
            solves += newton.solves
            chords += newton.chords
            d = newton.d
            if not np.all(np.isfinite(d)):
                break
            if not newton.converged:
                if solves >= budget:
                    break
                with timer("contact_law"):  # the bounds follow the normal forces as they come
                    normal = terms.normal_force(gaps[0])
                    bounds.advance(contact_law.friction_bound(contacts, joints, normal))
                continue
            with timer("contact_law"):
                g, s = gaps
                outcome = contact_law.update(contacts, terms, g, s, previous_g, joints, law)
            if outcome.settled:
                converged = True
                break
            bounds.advance(outcome.bound)
            previous_g = g
        with timer("contact_law"):
            g, s = geometry.at(d) if gaps is None else gaps
            dissipated = contact_law.friction_dissipation(terms, s)
            contact_law.record(contacts, terms, g, s, law.friction_tolerance, law.persistent)
        return d, solves, chords, converged, dissipated


def solve_step(
    model: Model,
    blocks: BlockSet,
    contacts: ContactSet,
    ctx: StepContext,
    timer: StageTimer,
    cache: LinearCache | None = None,
) -> StepSolution:
    """Minimise the step's incremental potential (:mod:`dda.solve.newton`).

    Outer loop: Newton on the potential with the contact data frozen, then the
    law's update (:func:`dda.contact.law.update`: AL multipliers and variable
    penalty, friction bounds from the new normal forces, broken bonds), until
    that changes nothing beyond its tolerances. Every Newton iteration (an
    assembled and solved quadratic; not the chord steps between them) counts
    against ``[contact] max_iterations``; a step that does not settle within
    them is not converged (the caller cuts Δt).

    ``cache``: the run's :class:`LinearCache` (its policy, and the pattern,
    factorisation and band numbering kept from the last step); None for a step on its
    own (a new one, of the environment's policy).
    """
    cache = LinearCache() if cache is None else cache
    policy = cache.policy
    factorisations_before = cache.solver.factorisations
    with timer("assembly"):
        base_k, base_f = _effect_terms(model, blocks, ctx)
        couplings = _couplings(model, blocks, ctx)
        coupled = None if couplings is None else (couplings.block_i, couplings.block_j)
    cm = model.contact
    if cm is None or len(contacts) == 0:
        with timer("assembly"):
            none = np.zeros(0, np.int64)
            pattern = cache.pattern_for(blocks.fixed, none, none, coupled=coupled)
            k = assemble(pattern, base_k, blocks.fixed, couplings=couplings)
        d = _solve(cache, pattern, k, base_f, blocks, timer)
        made = cache.solver.factorisations - factorisations_before
        finite = bool(np.all(np.isfinite(d)))
        return StepSolution(d, contacts, 1, made, finite, 0.0, newton_iterations=1, loads=base_f)

    law = cm.law.for_step(ctx.static)
    with timer("contact_law"):
        rows = _rows_at(blocks, contacts, ctx)
        overlap = None if ctx.static else _start_at_touch(contacts, rows, cm.touch_tolerance)
        joint_rows = cm.joints.rows_for(blocks, contacts)
        joints = cm.joints.properties(joint_rows, rows.length)
        if cm.joints.has_restitution and not ctx.static:  # dashpots beside the springs
            dashpots = contact_dashpots(
                contacts, rows, cm.joints.restitution[joint_rows],
                model.inertia.masses(blocks)[:, 0, 0], blocks.fixed, ctx.dt, law.shear_ratio,
            )  # fmt: skip
            couplings = PairSprings.join([couplings, dashpots])

    def neighbours():
        return pattern_neighbours(blocks, contacts, cm, policy.neighbour_margin)

    free_rows_count = BLOCK * int(np.count_nonzero(~blocks.fixed))

    def sparse_system():
        return _PieceSystem(
            cache, blocks, contacts, rows, base_k, base_f, law, neighbours, timer, couplings
        )

    def numpy_system():  # the systems of the numpy Newton: dense when small, else sparse
        if not (cache.solver.automatic and free_rows_count <= policy.dense_system_rows):
            return sparse_system()
        with timer("assembly"):
            return DenseSystem(
                blocks.fixed, contacts.block_a, contacts.block_b, rows, base_k, base_f,
                law.friction, couplings, timer, policy.numpy_solve_rows,
            )  # fmt: skip

    system: StepSystems
    if policy.systems == "sparse":  # DDA_SYSTEMS: the large models' path at every size
        system = sparse_system()
    else:
        system = _band_system(
            cache, blocks, contacts, rows, base_k, base_f, law, couplings, timer, numpy_system
        )
        system = system or numpy_system()
    budget = model.scene.contact.max_iterations
    rules = policy.size_rules(free_rows_count, not ctx.static, system.compiled_passes)
    loop = _StepLoop(
        blocks, contacts, rows, joints, law, system, budget, rules, ctx, timer,
        BlockQuadratic(base_k, base_f, ~blocks.fixed, couplings), policy,
    )  # fmt: skip
    solved = system.solve_loop(loop)  # compiled; None: in Python (or LAPACK failed: redone)
    if solved is None:
        solved = loop.solve()
    d, solves, chords, converged, dissipated = solved
    if not np.all(np.isfinite(d)):
        cache.solver.reset()
    closed = contacts.state != OPEN
    max_pen = float(contacts.penetration[closed].max()) if closed.any() else 0.0
    made = cache.solver.factorisations - factorisations_before + system.factorisations
    pushed = None
    if converged and overlap is not None:
        with timer("push_out"):  # rare, but a dense solve: its time is said apart
            after = gaps_after(rows, contacts.block_a, contacts.block_b, d)[0]
            metric = _push_metric(model, blocks, ctx, base_k)
            pushed = push_out_displacement(
                metric, blocks.fixed, contacts, rows, overlap, after, base_k
            )
        d = d + pushed
    return StepSolution(
        d, contacts, solves + chords, made, converged, max_pen, pushed, dissipated,
        newton_iterations=solves, loads=base_f,
    )  # fmt: skip


def static_contact_problem(
    model: Model, blocks: BlockSet, contacts: ContactSet, ctx: StepContext
) -> StaticContactProblem:
    """The data of a static step (``ctx.static``) for :func:`dda.solve.interior_point.
    solve_interior`: the effects' quadratic and couplings, the contacts' rows (gaps from
    ``ctx.prescribed``), their springs and tension as the step's first Newton solve has
    them, and the friction bound b(N) of the joint law (none without a contact model)."""
    cm = model.contact
    base_k, base_f = _effect_terms(model, blocks, ctx)
    couplings = _couplings(model, blocks, ctx)
    quadratic = BlockQuadratic(base_k, base_f, ~blocks.fixed, couplings)
    if cm is None:
        contacts = ContactSet.empty()
        geometry = ContactGeometry(
            contact_rows(blocks, contacts), contacts.block_a, contacts.block_b
        )
        terms = ContactTerms(*(np.zeros(0) for _ in range(6)))
        return StaticContactProblem(quadratic, geometry, terms, np.zeros_like, False)
    rows = _rows_at(blocks, contacts, ctx)
    joints = cm.joints.properties(cm.joints.rows_for(blocks, contacts), rows.length)
    law = cm.law
    terms = contact_law.contact_terms(
        contacts, joints, law, _first_bounds(contacts, rows, joints, law)
    )

    def bound(normal: np.ndarray) -> np.ndarray:
        return contact_law.friction_bound(contacts, joints, normal)

    return StaticContactProblem(
        quadratic,
        ContactGeometry(rows, contacts.block_a, contacts.block_b),
        terms,
        bound,
        law.friction,
        joints,
    )
