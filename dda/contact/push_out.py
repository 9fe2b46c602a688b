"""Overlap found at a new contact is removed by position, not by velocity.

A contact found for the first time already deeper than the contact
tolerance (a pairing that detection could not make earlier, e.g. among
fresh fracture fragments) is pushed out within one step. Shi's update
v1 = 2 D/Δt − v0 would turn that push into a velocity, and so into kinetic
energy the blocks never had (in a pile of fragments, up to 127 J in a
single step). Like the position correction of game-physics contact solvers,
the part of D that removes such an overlap is left out of the velocity.

That part is the displacement of least kinetic energy that removes the
overlap e_c pushed out at each such contact c:

    D_push = M⁻¹ Gᵀ λ,   (G M⁻¹ Gᵀ) λ = −e,

where G holds the contacts' normal rows (penetration d = d0 + G D) and M the
blocks' mass matrices (fixed blocks do not move).
"""

from __future__ import annotations

import numpy as np
import scipy

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows
from dda.result import OPEN


def pushed_overlap(
    contacts: ContactSet, rows: ContactRows, final_penetration: np.ndarray, tolerance: float
) -> np.ndarray:
    """(m,) overlap each contact had beyond ``tolerance`` when found and lost in this step.

    Zero except at fresh, closed contacts that started deeper than the tolerance.
    """
    start = rows.penetration
    pushed = start - np.maximum(final_penetration, tolerance)
    deep = contacts.fresh & (contacts.state != OPEN) & (start > tolerance)
    return np.where(deep & (pushed > 0.0), pushed, 0.0)


def push_out_displacement(
    masses: np.ndarray,
    fixed: np.ndarray,
    contacts: ContactSet,
    rows: ContactRows,
    overlap: np.ndarray,
) -> np.ndarray:
    """(n, 6) D_push for the contacts with ``overlap`` > 0 (zeros when there are none)."""
    n = len(fixed)
    chosen = np.flatnonzero(overlap > 0.0)
    k = len(chosen)
    if k == 0:
        return np.zeros((n, 6))
    blocks = np.concatenate([contacts.block_a[chosen], contacts.block_b[chosen]])
    gradient = np.concatenate([rows.normal_i[chosen], rows.normal_j[chosen]])
    which = np.tile(np.arange(k), 2)
    free = ~fixed[blocks]
    blocks, gradient, which = blocks[free], gradient[free], which[free]
    weighted = np.einsum("eij,ej->ei", np.linalg.inv(masses[blocks]), gradient)  # M⁻¹ rows
    cols = (6 * blocks[:, None] + np.arange(6)).ravel()

    def spread(values: np.ndarray) -> scipy.sparse.csr_matrix:
        return scipy.sparse.csr_matrix(
            (values.ravel(), (np.repeat(which, 6), cols)), shape=(k, 6 * n)
        )

    g, g_weighted = spread(gradient), spread(weighted)
    coupling = (g @ g_weighted.T).toarray()  # G M⁻¹ Gᵀ
    lam = np.linalg.lstsq(coupling, -overlap[chosen], rcond=None)[0]
    return np.asarray(g_weighted.T @ lam).reshape(n, 6)
