"""One time step: assemble, factorise, solve, apply the contact law, repeat.

K changes only when contact states or penalties change; between such
changes every augmentation (AL) or friction update re-uses the same
factorisation and only rebuilds F.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.assembly import add_forces, add_pair_terms, assemble, free_rows
from dda.blocks import BlockSet
from dda.contact import law as contact_law
from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows, contact_rows
from dda.effects.base import StepContext
from dda.linsolve import Factorisation
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


def _stiffness(blocks, base_diagonal, contacts, rows, law):
    diagonal = base_diagonal.copy()
    p, ps, _, _ = contact_law.contact_coefficients(contacts, rows, law)
    a, b = contacts.block_a, contacts.block_b
    parts = [add_pair_terms(diagonal, a, b, rows.normal_i, rows.normal_j, p)]
    if law.friction:
        parts.append(add_pair_terms(diagonal, a, b, rows.shear_i, rows.shear_j, ps))
    pi = np.concatenate([x[0] for x in parts])
    pj = np.concatenate([x[1] for x in parts])
    blocks_ij = np.concatenate([x[2] for x in parts])
    return assemble(diagonal, pi, pj, blocks_ij, blocks.fixed)


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
    pen = rows.penetration + np.einsum("mr,mr->m", rows.normal_i, d[a]) + np.einsum(
        "mr,mr->m", rows.normal_j, d[b])
    slip = rows.slip + np.einsum("mr,mr->m", rows.shear_i, d[a]) + np.einsum(
        "mr,mr->m", rows.shear_j, d[b])
    return pen, slip


def solve_step(
    model: Model,
    blocks: BlockSet,
    contacts: ContactSet,
    ctx: StepContext,
    timer: StageTimer,
) -> StepSolution:
    """Iterate solves and contact-law updates until the contacts settle."""
    with timer("assembly"):
        base_k, base_f = _effect_terms(model, blocks, ctx)
        free = ~blocks.fixed
        order = free_rows(blocks.fixed)
    cm = model.contact
    if cm is None or len(contacts) == 0:
        with timer("assembly"):
            k = assemble(base_k, np.zeros(0, np.int64), np.zeros(0, np.int64),
                         np.zeros((0, 6, 6)), blocks.fixed)
        with timer("factorisation"):
            fac = Factorisation(k)
        with timer("solve"):
            d = _expand(fac.solve(base_f[free].ravel()), order, blocks.count)
        return StepSolution(d, contacts, 1, 1, bool(np.all(np.isfinite(d))), 0.0)

    law = cm.law
    with timer("contact_law"):
        rows = contact_rows(blocks, contacts)
        joints = cm.joints.properties(cm.joints.rows_for(blocks, contacts), rows.length)
    fac = None
    previous_pen = None
    iterations = factorisations = 0
    converged = False
    d = np.zeros((blocks.count, 6))
    for _ in range(model.scene.contact.max_iterations):
        if fac is None:
            with timer("assembly"):
                k = _stiffness(blocks, base_k, contacts, rows, law)
            with timer("factorisation"):
                fac = Factorisation(k)
            factorisations += 1
        with timer("assembly"):
            f = _forces(base_f, contacts, rows, law)
        with timer("solve"):
            d = _expand(fac.solve(f[free].ravel()), order, blocks.count)
        iterations += 1
        if not np.all(np.isfinite(d)):
            break
        with timer("contact_law"):
            pen, slip = _contact_motion(rows, contacts, d)
            outcome = contact_law.update(contacts, rows, pen, slip, previous_pen, joints, law)
        previous_pen = pen
        if outcome.settled:
            converged = True
            break
        if outcome.stiffness_changed:
            fac = None
    closed = contacts.state != OPEN
    max_pen = float(contacts.penetration[closed].max()) if closed.any() else 0.0
    return StepSolution(d, contacts, iterations, factorisations, converged, max_pen)


def _expand(solution: np.ndarray, order: np.ndarray, n: int) -> np.ndarray:
    d = np.zeros((n, 6))
    free = order >= 0
    d[free] = solution.reshape(-1, 6)
    return d
