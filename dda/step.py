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

from dataclasses import dataclass, field

import numpy as np

from dda.assembly import BlockPattern, add_forces, assemble, graph_key
from dda.blocks import BlockSet
from dda.contact import law as contact_law
from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows, contact_rows
from dda.effects.base import StepContext
from dda.linsolve import ReusingSolver, block_ordering
from dda.model import Model
from dda.result import OPEN
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


@dataclass
class LinearCache:
    """What a run keeps between steps: the current block pattern and the solver."""

    pattern: BlockPattern | None = None
    solver: ReusingSolver = field(default_factory=ReusingSolver)

    def pattern_for(self, fixed: np.ndarray, block_a: np.ndarray, block_b: np.ndarray):
        """The pattern of this contact graph (the kept one when the graph is unchanged)."""
        key = graph_key(fixed, block_a, block_b)
        if self.pattern is None or self.pattern.key != key:
            self.pattern = BlockPattern(fixed, block_a, block_b, block_ordering)
        return self.pattern


def linear_cache(model: Model) -> LinearCache:
    """The run's :class:`LinearCache`, kept on the model (one model per run)."""
    cache = model.__dict__.get("_linear_cache")
    if cache is None:
        cache = LinearCache()
        model.__dict__["_linear_cache"] = cache
    return cache


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


def _stiffness(pattern, blocks, base_diagonal, contacts, rows, law):
    p, ps, _, _ = contact_law.contact_coefficients(contacts, rows, law)
    terms = [(rows.normal_i, rows.normal_j, p)]
    if law.friction:
        terms.append((rows.shear_i, rows.shear_j, ps))
    return assemble(pattern, base_diagonal, blocks.fixed, terms)


def _forces(base_forces, contacts, rows, law):
    forces = base_forces.copy()
    _, _, normal, shear = contact_law.contact_coefficients(contacts, rows, law)
    a, b = contacts.block_a, contacts.block_b
    add_forces(forces, a, rows.normal_i, normal)
    add_forces(forces, b, rows.normal_j, normal)
    add_forces(forces, a, rows.shear_i, shear)
    add_forces(forces, b, rows.shear_j, shear)
    return forces


def _contact_motion(rows: ContactRows, contacts: ContactSet, d: np.ndarray):
    """Penetration and shear position of each contact after the step ``d``."""
    a, b = contacts.block_a, contacts.block_b
    pen = (
        rows.penetration
        + np.einsum("mr,mr->m", rows.normal_i, d[a])
        + np.einsum("mr,mr->m", rows.normal_j, d[b])
    )
    slip = (
        rows.slip
        + np.einsum("mr,mr->m", rows.shear_i, d[a])
        + np.einsum("mr,mr->m", rows.shear_j, d[b])
    )
    return pen, slip


def _solve(cache: LinearCache, pattern: BlockPattern, k, forces, blocks, timer) -> np.ndarray:
    """D (n, 6) from K (in the pattern's order) and F (n, 6) per block."""
    rhs = pattern.to_matrix_order(forces, blocks.fixed).ravel()
    x = cache.solver.solve(k, rhs, key=pattern.key, timer=timer)
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
    with timer("assembly"):
        pattern = cache.pattern_for(blocks.fixed, contacts.block_a, contacts.block_b)
    k = None
    previous_pen = None
    iterations = 0
    converged = False
    d = np.zeros((blocks.count, 6))
    for _ in range(model.scene.contact.max_iterations):
        with timer("assembly"):
            if k is None:
                k = _stiffness(pattern, blocks, base_k, contacts, rows, law)
            f = _forces(base_f, contacts, rows, law)
        d = _solve(cache, pattern, k, f, blocks, timer)
        iterations += 1
        if not np.all(np.isfinite(d)):
            cache.solver.reset()
            break
        with timer("contact_law"):
            pen, slip = _contact_motion(rows, contacts, d)
            outcome = contact_law.update(contacts, rows, pen, slip, previous_pen, joints, law)
        previous_pen = pen
        if outcome.settled:
            converged = True
            break
        if outcome.stiffness_changed:
            k = None
    closed = contacts.state != OPEN
    max_pen = float(contacts.penetration[closed].max()) if closed.any() else 0.0
    made = cache.solver.factorisations - factorisations_before
    return StepSolution(d, contacts, iterations, made, converged, max_pen)
