"""One time step: assemble, factorise, solve, apply the contact law, repeat.

K changes only when contact states or penalties change; between such
changes every augmentation (AL) or friction update re-uses K and only
rebuilds F. Across steps, while the contact graph is the same, the block
pattern of K (its fill-reducing order, CSR structure and scatter indices)
and the last factorisation are kept: a new K is solved by conjugate
gradients preconditioned with that factorisation (:mod:`dda.linsolve`),
and re-factorised only when that stops paying.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from dda.assembly import (
    BlockPattern,
    add_force_terms,
    assemble,
    contacts_key,
    free_pairs,
    free_rows,
    reassemble,
)
from dda.blocks import BlockSet
from dda.contact import law as contact_law
from dda.contact.broad import candidate_pairs
from dda.contact.contact_set import ContactSet
from dda.contact.narrow import separated_blocks
from dda.contact.push_out import push_out_displacement, pushed_overlap
from dda.contact.rows import contact_rows, gaps_after
from dda.effects.base import StepContext
from dda.linsolve import ReusingSolver, block_ordering
from dda.low_rank import StepUpdates
from dda.model import Model
from dda.result import OPEN, SLIDING
from dda.timing import StageTimer


@dataclass
class StepSolution:
    """Outcome of one step attempt."""

    d: np.ndarray  # (n, 6) unknowns of every block (zeros for fixed blocks)
    contacts: ContactSet
    iterations: int  # linear solves
    factorisations: int
    converged: bool
    max_penetration: float
    held: int = 0  # contacts that reached StateFlips.LIMIT (held where within tolerance)
    pushed: np.ndarray | None = None  # (n, 6) part of d that removed overlap found this step
    friction_work: tuple[float, float] = (0.0, 0.0)  # (dissipated, put in by holds)


MAX_CHANGED_FOR_PCG = 6  # contact springs changed since the factorisation: PCG still pays


SPARE_PAIRS = 1.25  # a new pattern keeps the old one's pairs up to this many per needed pair
NEIGHBOUR_MARGIN = 0.1  # a new pattern holds the pairs of boxes this close (x search distance)


@dataclass
class LinearCache:
    """What a run keeps between steps: the current block pattern and the solver.

    ``coefficients`` are the contact spring constants (normal and shear) of
    the factorised K: a new K whose springs differ in more than
    ``MAX_CHANGED_FOR_PCG`` contacts is a high-rank change, re-factorised
    at once instead of trying PCG first.
    """

    pattern: BlockPattern | None = None
    solver: ReusingSolver = field(default_factory=ReusingSolver)
    coefficients: tuple[np.ndarray, np.ndarray] | None = None  # sorted contact keys, springs

    def pattern_for(
        self,
        fixed: np.ndarray,
        block_a: np.ndarray,
        block_b: np.ndarray,
        neighbours: Callable[[], np.ndarray] | None = None,
        active: np.ndarray | None = None,
    ):
        """The pattern of this contact list (of its ``active``, closed, contacts).

        The kept one when the list is the same; its structure (ordering, CSR,
        and so the factorisation's analysis) with new slots while every contact
        still lands on one of its blocks; else a new one. A new pattern also
        holds the pairs of blocks ``neighbours()`` returns (pairs of blocks
        close enough to come into contact soon) and the old pattern's pairs
        (up to ``SPARE_PAIRS`` per needed pair): contacts come and go at the
        search distance, and each new pattern costs an ordering and an analysis.
        """
        kept = self.pattern
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
        if kept is not None and np.array_equal(kept._fixed, fixed):
            needed = len(free_pairs(rows, block_a, block_b))
            if len(kept.pairs) <= SPARE_PAIRS * max(needed, 1):
                extra.append(kept.pairs)
        spare = np.concatenate(extra) if extra else None
        self.pattern = BlockPattern(fixed, block_a, block_b, block_ordering, spare, active)
        self.coefficients = None
        return self.pattern


def pattern_neighbours(blocks: BlockSet, contacts: ContactSet, settings) -> np.ndarray:
    """Block pairs a new pattern holds beside those of the closed contacts.

    The pairs of boxes within ``NEIGHBOUR_MARGIN`` of the search distance
    (blocks that may come into contact soon), less the pairs with no contact
    whose corners meet at a node that other blocks fill
    (:func:`dda.contact.narrow.separated_blocks`): those get no contact while
    the node stays filled, so K does not need their fill-in. On the standard
    walls these are the diagonal neighbours, half the block pairs; without
    them a factorisation of the 30x30 wall costs a third less.
    """
    near = candidate_pairs(blocks, NEIGHBOUR_MARGIN * settings.search_distance)  # i < j
    search, radius, tight = settings.search_distance, settings.vertex_radius, settings.law.tolerance
    apart = separated_blocks(blocks, near, search, radius, tight)  # i < j

    def key(a, b):  # one integer per unordered pair
        return np.minimum(a, b) * blocks.count + np.maximum(a, b)

    no_contact = np.setdiff1d(key(*apart.T), key(contacts.block_a, contacts.block_b))
    return near[~np.isin(key(*near.T), no_contact)]


def linear_cache(model: Model) -> LinearCache:
    """The run's :class:`LinearCache`, kept on the model (one model per run)."""
    cache = model.__dict__.get("_linear_cache")
    if cache is None:
        cache = LinearCache()
        model.__dict__["_linear_cache"] = cache
    return cache


class StateFlips:
    """How often each contact changed state within one step.

    A contact that flipped open/closed (or sliding/locked) ``LIMIT`` times
    is caught in a cycle: the states of a few contacts feed back on each
    other and the open–close iteration never settles (seen in jointed rock
    masses: period 4 to 12 among a handful of contacts, one step after
    another, and cutting Δt does not help). Such a contact is held closed
    (sliding, at the Coulomb force) for the rest of the step, as long as
    what holding it costs stays within the contact tolerance: its
    penetration or gap (its shear motion this step) is at most ``tolerance``.

    ``LIMIT`` = 4: the contact has come back to its first state twice. One
    round trip happens as neighbours settle; a second one is the cycle
    coming round again. Holding then instead of after 6 flips cut the
    solves per step by 15 % (rock slope), 6 % (tunnel), 19 % (10x10 wall)
    and 10 % (30x30), with fewer or as many cut steps. Against holding
    after 12 flips, the walls' results differ as much with 4 as with 6
    (centroids 2-5e-5 m, 1-2 % of the largest displacement; stresses 2-3 %;
    docs/benchmarks.md). After 3 flips (one and a half round trips)
    contacts that were settling get held too: the tunnel then needs 32.7
    solves a step and 51 cut steps instead of 28.1 and 19.
    """

    LIMIT = 4

    def __init__(self, count: int) -> None:
        self.normal = np.zeros(count, np.int64)
        self.shear = np.zeros(count, np.int64)

    def held(self, penetration, moved, tolerance: float):
        """(keep closed, keep sliding) masks for the next law update."""
        keep_closed = (self.normal >= self.LIMIT) & (np.abs(penetration) <= tolerance)
        keep_sliding = (self.shear >= self.LIMIT) & (np.abs(moved) <= tolerance)
        return keep_closed, keep_sliding

    def count(self, before: np.ndarray, after: np.ndarray) -> None:
        self.normal += (before == OPEN) != (after == OPEN)
        self.shear += (before != OPEN) & (after != OPEN) & (before != after)

    def held_count(self) -> int:
        return int(np.count_nonzero((self.normal >= self.LIMIT) | (self.shear >= self.LIMIT)))


def friction_work(
    contacts: ContactSet, keep_sliding: np.ndarray, moved: np.ndarray
) -> tuple[float, float]:
    """(dissipated, put in by holds): the work of the sliding contacts' friction in one solve.

    With λt the friction force of the solve (``shear_multiplier``), σ the
    slide direction and Δs the shear motion since the step start (``moved``):

        dissipated = Σ |λt| max(0, σ Δs)    over the sliding contacts,
        put in     = Σ |λt| max(0, -σ Δs)   over those held sliding (``keep_sliding``).

    Friction opposes sliding in direction σ. A held contact may move the other
    way (held, it does not stick), and then its friction pushes the blocks:
    energy the hold put in, which Coulomb's law cannot. Call before the law's
    update (which may turn the direction).
    """
    sliding = np.flatnonzero(contacts.state == SLIDING)
    if len(sliding) == 0:
        return 0.0, 0.0
    force = np.abs(contacts.shear_multiplier[sliding])
    along = contacts.slide_direction[sliding] * moved[sliding]
    dissipated = float(np.sum(force * np.maximum(0.0, along)))
    held = keep_sliding[sliding]
    return dissipated, float(np.sum((force * np.maximum(0.0, -along))[held]))


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


def _stiffness(pattern, blocks, base_diagonal, coefficients, rows, law, earlier=None):
    """K (in the pattern's order) and the contact springs (2, m) it holds.

    ``coefficients``: the contacts' :func:`dda.contact.law.contact_coefficients`.
    ``earlier``: (pattern, K, springs) assembled before in this step (the same
    rows and effects); on the same pattern, only the contacts whose springs
    changed are added to it (:func:`dda.assembly.reassemble`).
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
    return assemble(pattern, base_diagonal, blocks.fixed, terms), springs


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
    return changed <= MAX_CHANGED_FOR_PCG and changed + 2 <= cache.solver.pcg_budget


def _forces(base_forces, contacts, rows, coefficients):
    """F: the effects' forces and the contact forces (``coefficients`` as for K)."""
    forces = base_forces.copy()
    _, _, normal, shear = coefficients
    a, b = contacts.block_a, contacts.block_b
    terms = [(a, rows.normal_i, normal), (b, rows.normal_j, normal)]
    terms += [(a, rows.shear_i, shear), (b, rows.shear_j, shear)]
    add_force_terms(forces, terms)
    return forces


def _solve(
    cache: LinearCache, pattern, k, forces, blocks, timer, springs=None, updates=None, raw=None
) -> np.ndarray:
    """D (n, 6) from K (in the pattern's order) and F (n, 6) per block.

    ``springs``: (contact keys, springs) of K, sorted by key (None without
    contacts), to decide whether PCG on the kept factorisation is worth trying.
    ``updates``: the :class:`StepUpdates` of this step's factorised K, and ``raw`` K's
    springs per contact: a few changed springs are solved for through that factorisation.
    """
    rhs = pattern.to_matrix_order(forces, blocks.fixed).ravel()
    x = None
    if updates is not None and updates.applies(cache.solver.factored, pattern):
        with timer("solve"):
            x = updates.solve(k, rhs, raw)
    if x is None:
        similar = springs is None or _similar(cache, *springs)
        x = cache.solver.solve(k, rhs, key=pattern.key, timer=timer, similar=similar)
    if springs is not None and cache.solver.factored is k:
        cache.coefficients = springs
    return pattern.from_matrix_order(x, blocks.count)


def solve_step(
    model: Model,
    blocks: BlockSet,
    contacts: ContactSet,
    ctx: StepContext,
    timer: StageTimer,
) -> StepSolution:
    """Iterate solves and contact-law updates until the contacts settle."""
    cache = linear_cache(model)
    factorisations_before = cache.solver.factorisations
    with timer("assembly"):
        base_k, base_f = _effect_terms(model, blocks, ctx)
    cm = model.contact
    if cm is None or len(contacts) == 0:
        with timer("assembly"):
            none = np.zeros(0, np.int64)
            pattern = cache.pattern_for(blocks.fixed, none, none)
            k = assemble(pattern, base_k, blocks.fixed)
        d = _solve(cache, pattern, k, base_f, blocks, timer)
        made = cache.solver.factorisations - factorisations_before
        return StepSolution(d, contacts, 1, made, bool(np.all(np.isfinite(d))), 0.0)

    law = cm.law
    with timer("contact_law"):
        rows = contact_rows(blocks, contacts)
        joints = cm.joints.properties(cm.joints.rows_for(blocks, contacts), rows.length)

    def neighbours():
        return pattern_neighbours(blocks, contacts, cm)

    pattern = None
    k = springs = assembled = updates = None
    previous_pen = None
    work = (0.0, 0.0)
    iterations = 0
    converged = False
    d = np.zeros((blocks.count, 6))
    flips = StateFlips(len(contacts))
    for _ in range(model.scene.contact.max_iterations):
        with timer("assembly"):
            coefficients = contact_law.contact_coefficients(contacts, rows, law)  # K and F
            if k is None:
                closed_now = contacts.state != OPEN  # open contacts add nothing to K
                pattern = cache.pattern_for(
                    blocks.fixed, contacts.block_a, contacts.block_b, neighbours, closed_now
                )
                k, springs = _stiffness(pattern, blocks, base_k, coefficients, rows, law, assembled)
                assembled = (pattern, k, springs)
                springs = _keyed_springs(contacts, springs)
            f = _forces(base_f, contacts, rows, coefficients)
        d = _solve(cache, pattern, k, f, blocks, timer, springs, updates, assembled[2])
        iterations += 1
        if cache.solver.factored is k and (updates is None or updates.factored is not k):
            updates = StepUpdates(
                k,
                assembled[2],
                pattern,
                rows,
                contacts.block_a,
                contacts.block_b,
                cache.solver.solve_many,
            )
        if not np.all(np.isfinite(d)):
            cache.solver.reset()
            break
        with timer("contact_law"):
            pen, slip = gaps_after(rows, contacts.block_a, contacts.block_b, d)
            before = contacts.state.copy()
            moved = slip - rows.slip  # shear motion this step
            held = flips.held(pen, moved, law.tolerance)
            work = friction_work(contacts, held[1], moved)
            outcome = contact_law.update(contacts, rows, pen, slip, previous_pen, joints, law, held)
            flips.count(before, contacts.state)
        previous_pen = pen
        if outcome.settled:
            converged = True
            break
        if outcome.stiffness_changed:
            k = None
    closed = contacts.state != OPEN
    max_pen = float(contacts.penetration[closed].max()) if closed.any() else 0.0
    made = cache.solver.factorisations - factorisations_before
    pushed = None
    if converged and not ctx.static:
        overlap = pushed_overlap(contacts, rows, contacts.penetration, law.tolerance)
        if overlap.any():
            masses = model.inertia.masses(blocks)
            pushed = push_out_displacement(masses, blocks.fixed, contacts, rows, overlap)
    return StepSolution(
        d, contacts, iterations, made, converged, max_pen, flips.held_count(), pushed, work
    )
