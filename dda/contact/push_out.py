"""Overlap found at a new contact is removed by position, not by velocity.

A contact found for the first time already overlapping (a pairing that detection
could not make earlier: among fresh fracture fragments, where a corner slips between
pieces that part at a node, or a scene drawn overlapping) would push the blocks apart
with its penalty spring, and the spring's energy ½ p g₀² would become kinetic energy
the blocks never had (a fragment's corner found 0.36 mm deep: 1.4 kJ in one step).
Like the position correction of game-physics contact solvers, the step is solved with
such a contact starting at touch (its start penetration g₀ taken out of its gap), and
the overlap is removed by a displacement left out of the velocity: the displacement
of least step energy ½ Dᵀ K₀ D that removes the overlap e_c = g₀ at each such
contact c,

    D_push = K₀⁻¹ Gᵀ λ,   (G K₀⁻¹ Gᵀ) λ = −e,

where G holds the contacts' normal rows (penetration d = d0 + G D) and K₀ the step's
block-diagonal stiffness (inertia 2M/Δt², elasticity, the other block springs; fixed
blocks do not move). Weighing the strain by its stiffness keeps the push's elastic
energy, which the block's spring-back turns into motion, small: a rock block pushed
out of a 2e-5 m overlap keeps 0.40 of ½ m (d/Δt)² (2.9 with the least-kinetic-energy
push, which strains it freely; a rigid push keeps none there but shoves a fragment
whole into its neighbours: 12 % of what moved in a crushed column).
"""

from __future__ import annotations

import numpy as np
import scipy

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows
from dda.result import OPEN


def found_overlap(contacts: ContactSet, touch: float) -> np.ndarray:
    """(m,) the penetration each contact found this step (``fresh``) touching was found
    with (``contacts.penetration``, at detection: not the ground's prescribed motion of
    the step), where deeper than ``touch`` (the contacts' touch tolerance) and carrying
    no force yet (a contact preloaded by an in-situ field keeps its overlap); 0
    elsewhere."""
    found = contacts.fresh & (contacts.state != OPEN) & (contacts.penetration > touch)
    found &= contacts.normal_multiplier == 0.0
    return np.where(found, contacts.penetration, 0.0)


def push_out_displacement(
    stiffness: np.ndarray,
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
    weighted = np.einsum("eij,ej->ei", np.linalg.inv(stiffness[blocks]), gradient)  # K₀⁻¹ rows
    cols = (6 * blocks[:, None] + np.arange(6)).ravel()

    def spread(values: np.ndarray) -> scipy.sparse.csr_matrix:
        return scipy.sparse.csr_matrix(
            (values.ravel(), (np.repeat(which, 6), cols)), shape=(k, 6 * n)
        )

    g, g_weighted = spread(gradient), spread(weighted)
    coupling = (g @ g_weighted.T).toarray()  # G K₀⁻¹ Gᵀ
    lam = np.linalg.lstsq(coupling, -overlap[chosen], rcond=None)[0]
    return np.asarray(g_weighted.T @ lam).reshape(n, 6)
