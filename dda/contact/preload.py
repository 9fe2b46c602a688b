"""Contacts that carry a stress field from t = 0 (``[in_situ]``).

A touching contact P1 (block i) on the edge P2P3 (block j) stands at one end of the
stretch of joint its vertex's own edge shares with P2P3: from P1 along that edge to
the nearer of its far end and the edge's end, length L, other end Q. The joint's
traction on block j there is t = σ·n (n the edge's outward normal, σ(y) the field),
and of the forces at the stretch's two ends that do its work against Shi's linear
displacement fields the contact takes f = L (t(P1)/3 + t(Q)/6) (the contact at Q takes
the rest): N = −n·f (compression positive), F = t_e·f along the edge direction t_e
(the shear force the contact carries, :mod:`dda.contact.rows`). The contact starts with
them as its multipliers, λn = N − p g0 (so that λn + p g0 = N) and λt = F: a block
whose stress is σ is then in equilibrium with its contacts before anything moves.

A vertex whose edges meet P2P3 at an angle (a corner on an edge) shares no stretch and
carries nothing at first; the equilibrium start loads it.
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.narrow import SHARED_LINE_COSINE
from dda.contact.rows import contact_rows
from dda.result import OPEN
from dda.scene.in_situ import StressField


def shared_stretches(blocks: BlockSet, contacts: ContactSet, tangent: np.ndarray):
    """(L, Q): per contact the length of the stretch of the contact edge that its vertex's
    own edges lie along, from P1, and its other end Q (L = 0: none)."""
    v = blocks.vertices
    p1, p2, p3 = v[contacts.vertex], v[contacts.edge], v[blocks.next_vertex[contacts.edge]]
    edge_length = np.einsum("ij,ij->i", p3 - p2, tangent)
    at = np.einsum("ij,ij->i", p1 - p2, tangent)  # P1's place along P2P3
    best, end = np.zeros(len(p1)), p1.copy()
    for neighbour in (blocks.next_vertex, blocks.previous_vertex):
        far = v[neighbour[contacts.vertex]]
        u = far - p1
        size = np.linalg.norm(u, axis=1)
        along = np.einsum("ij,ij->i", u, tangent)
        parallel = np.abs(along) >= SHARED_LINE_COSINE * size
        reach = np.clip(at + along, 0.0, edge_length)  # the far end, clipped to the edge
        length = np.where(parallel, np.abs(reach - at), 0.0)
        better = length > best
        best = np.where(better, length, best)
        end = np.where(better[:, None], p2 + reach[:, None] * tangent, end)
    return best, end


def carry_stress(blocks: BlockSet, contacts: ContactSet, field: StressField) -> ContactSet:
    """``contacts`` with every touching one carrying ``field`` as its multipliers."""
    if not len(contacts):
        return contacts
    rows = contact_rows(blocks, contacts)
    length, far = shared_stretches(blocks, contacts, rows.tangents)
    n = rows.normals
    f, _ = field.segment_forces(rows.points, far, n)
    normal = -np.einsum("ij,ij->i", f, n)
    shear = np.einsum("ij,ij->i", f, rows.tangents)
    carries = (contacts.state != OPEN) & (length > 0.0)
    out = contacts.copy()
    out.normal_multiplier = np.where(
        carries, normal - contacts.penalty * rows.penetration, contacts.normal_multiplier
    )
    out.shear_multiplier = np.where(carries, shear, contacts.shear_multiplier)
    return out
