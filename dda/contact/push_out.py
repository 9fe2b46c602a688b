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
contact c and drives no other contact o deeper than the step left it (g_o its
penetration after the step's D; an open one may close its gap),

    min ½ Dᵀ K₀ D   subject to   G_c D = −e,   G_o D ≤ max(−g_o, 0),

where G holds the contacts' normal rows (penetration d = d0 + G D) and K₀ the step's
block-diagonal stiffness (inertia 2M/Δt², elasticity, the other block springs; fixed
blocks do not move). With W the other contacts held at their bound (an active set:
added where the push drives them deeper, dropped where they would pull),

    D_push = K₀⁻¹ Gᵀ λ,   (G K₀⁻¹ Gᵀ) λ = (−e, b_W),   λ_W ≤ 0,

G the rows of the overlapping contacts and of W: the blocks behind a contact in W are
pushed along. (Without the bound on the other contacts the push drives a fragment's
corner into a third piece, whose spring gives the overlap back as motion: 665 J, 6.4 %
of what moved, in a crushed column at Δt = 1e-5 s.) Weighing the strain by its
stiffness keeps the push's elastic energy, which the block's spring-back turns into
motion, small: a rock block pushed out of a 2e-5 m overlap keeps 0.40 of ½ m (d/Δt)²
(2.9 with the least-kinetic-energy push, which strains it freely; a rigid push keeps
none there but shoves a fragment whole into its neighbours: 12 % of what moved in a
crushed column).
"""

from __future__ import annotations

import numpy as np
import scipy

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows
from dda.result import OPEN

SLACK = 1e-6  # of the deepest overlap: a contact driven deeper by less is left out
ACTIVE_SET_PASSES = 50  # the active set's passes


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
    after: np.ndarray,
) -> np.ndarray:
    """(n, 6) D_push for the contacts with ``overlap`` > 0 (zeros when there are none):
    the least ½ Dᵀ K₀ D (``stiffness`` (n, 6, 6), D = 0 on ``fixed`` blocks) with
    G_c D = −e at those contacts and G_o D ≤ max(−g, 0) at every other one, g its
    penetration ``after`` the step's D (positive: overlap). The active set W of the other
    contacts starts empty; each pass solves D = K₀⁻¹ Gᵀ λ, (G K₀⁻¹ Gᵀ) λ = (−e, b_W) on
    the overlapping contacts and W, then drops the contact of W that pulls most (λ > 0)
    if any pulls, else adds every contact the push drives deeper than its bound (by more
    than ``SLACK`` of the deepest e), at most ``ACTIVE_SET_PASSES`` passes."""
    n = len(fixed)
    chosen = np.flatnonzero(overlap > 0.0)
    if len(chosen) == 0:
        return np.zeros((n, 6))
    inverse = np.zeros((n, 6, 6))
    inverse[~fixed] = np.linalg.inv(stiffness[~fixed])
    bound = np.where(overlap > 0.0, -overlap, np.maximum(-after, 0.0))
    slack = SLACK * float(overlap.max())
    other = overlap <= 0.0
    active = chosen
    push = np.zeros((n, 6))
    for _ in range(ACTIVE_SET_PASSES):
        multiplier, push = _equality_push(inverse, fixed, contacts, rows, active, bound[active])
        pulls = np.flatnonzero(other[active] & (multiplier > 0.0))
        if len(pulls):
            active = np.delete(active, pulls[np.argmax(multiplier[pulls])])
            continue
        deeper = _normal_motion(contacts, rows, push) - bound > slack
        deeper &= other
        deeper[active] = False
        if not deeper.any():
            break
        active = np.concatenate([active, np.flatnonzero(deeper)])
    return push


def _normal_motion(contacts: ContactSet, rows: ContactRows, d: np.ndarray) -> np.ndarray:
    """(m,) G D: each contact's change of penetration under D (n, 6)."""
    moved = np.einsum("mr,mr->m", rows.normal_i, d[contacts.block_a])
    return moved + np.einsum("mr,mr->m", rows.normal_j, d[contacts.block_b])


def _equality_push(
    inverse: np.ndarray,
    fixed: np.ndarray,
    contacts: ContactSet,
    rows: ContactRows,
    active: np.ndarray,
    target: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(λ, D) of the least ½ Dᵀ K₀ D with G D = ``target`` at the ``active`` contacts:
    D = K₀⁻¹ Gᵀ λ, (G K₀⁻¹ Gᵀ) λ = target (least squares where the rows are dependent);
    ``inverse`` holds K₀⁻¹ per block (0 on fixed blocks)."""
    n, k = len(fixed), len(active)
    blocks = np.concatenate([contacts.block_a[active], contacts.block_b[active]])
    gradient = np.concatenate([rows.normal_i[active], rows.normal_j[active]])
    which = np.tile(np.arange(k), 2)
    free = ~fixed[blocks]
    blocks, gradient, which = blocks[free], gradient[free], which[free]
    weighted = np.einsum("eij,ej->ei", inverse[blocks], gradient)  # K₀⁻¹ rows
    cols = (6 * blocks[:, None] + np.arange(6)).ravel()

    def spread(values: np.ndarray) -> scipy.sparse.csr_matrix:
        return scipy.sparse.csr_matrix(
            (values.ravel(), (np.repeat(which, 6), cols)), shape=(k, 6 * n)
        )

    g, g_weighted = spread(gradient), spread(weighted)
    coupling = (g @ g_weighted.T).toarray()  # G K₀⁻¹ Gᵀ
    multiplier = np.linalg.lstsq(coupling, target, rcond=None)[0]
    return multiplier, np.asarray(g_weighted.T @ multiplier).reshape(n, 6)
