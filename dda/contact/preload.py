"""Contacts that carry a stress field from t = 0 (``[in_situ]``).

The joint between two touching blocks i and j is the set of pieces of their edges that
the other block covers (:func:`dda.scene.edge_cover.covered_pieces`), each a segment AB
of an edge of one of them, j say. The field's traction on block j there is t = σ·n (n
that edge's outward normal, σ(y) the field), linear along AB, and the end forces that do
its work against Shi's linear displacement fields are f_A = L (t(A)/3 + t(B)/6) and
f_B = L (t(A)/6 + t(B)/3) (:meth:`dda.scene.in_situ.StressField.segment_forces`). A
piece's ends are vertices of i or j, where the two blocks' touching contact stands (one
a point: a vertex–vertex pair is resolved to one contact, but for a nested corner,
below): each contact takes the end
forces of the pieces of its pair that end at its point, and a vertex where the joint
bends (a polygonal opening's) takes those of the pieces on both sides. With f the sum,
the force on the contact's edge block, its normal force is N = −n_c·f (compression
positive) and its shear force F = t_c·f (n_c, t_c its edge's outward normal and
direction, :mod:`dda.contact.rows`). An end where no contact of the pair stands gives
its force to the pair's nearest contact. The contact starts with them as its
multipliers, λn = N − p g0 (so that λn + p g0 = N) and λt = F: a block whose boundary
its touching neighbours cover is in equilibrium with its contacts before anything moves,
when the field is in equilibrium with the loads.

A contact at a corner that touches an edge at a point ends no piece: it carries nothing
at first, and the equilibrium start loads it. A block's corner that sits in a concave
corner of its neighbour is two contacts at one point, one on each edge there
(:mod:`dda.contact.narrow`): each takes the end forces of the pieces along its own edge
(of the contacts at a piece's end, the one whose edge lies along the piece).
"""

from __future__ import annotations

import logging

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.rows import contact_rows
from dda.geometry import unpack_polygons
from dda.result import OPEN
from dda.scene.edge_cover import EdgePieces, covered_pieces
from dda.scene.in_situ import StressField

log = logging.getLogger(__name__)

# contacts this close to one another, relative to the coordinates' size, stand at one point
AT_ONE_POINT = 1e-9


def joint_pieces(blocks: BlockSet) -> EdgePieces:
    """Each stretch of joint once: the covered pieces of the blocks' edges whose block is
    the lower-numbered of the two."""
    pieces = covered_pieces(unpack_polygons(blocks.vertices, blocks.offsets))
    return pieces.subset(np.flatnonzero(pieces.block < pieces.other))


def pair_key(a: np.ndarray, b: np.ndarray, count: int) -> np.ndarray:
    """One integer per unordered pair of blocks."""
    return np.minimum(a, b).astype(np.int64) * count + np.maximum(a, b)


def nearest_contact(
    contacts: ContactSet,
    contact_points: np.ndarray,
    contact_normals: np.ndarray,
    usable: np.ndarray,
    points: np.ndarray,
    normals: np.ndarray,
    keys: np.ndarray,
    count: int,
) -> np.ndarray:
    """For each of ``points``, of the block pair ``keys`` (:func:`pair_key`), the
    ``usable`` contact of that pair whose point P1 (``contact_points``) is nearest; -1
    where the pair has none. Of contacts at one point (a corner nested in a reflex
    corner: one per edge there), the one whose edge (``contact_normals``) lies along
    the piece (``normals``): |n_c · n| largest."""
    best = np.full(len(keys), -1)
    own = np.flatnonzero(usable)
    if not len(own):
        return best
    own_keys = pair_key(contacts.block_a[own], contacts.block_b[own], count)
    order = np.argsort(own_keys, kind="stable")
    own, own_keys = own[order], own_keys[order]
    lo = np.searchsorted(own_keys, keys, "left")
    hi = np.searchsorted(own_keys, keys, "right")
    tie = AT_ONE_POINT * max(1.0, float(np.abs(points).max(initial=0.0)))
    best_distance = np.full(len(keys), np.inf)
    best_alignment = np.full(len(keys), -np.inf)
    for offset in range(int((hi - lo).max(initial=0))):  # a pair's few contacts, not the points
        at = lo + offset
        candidate = own[np.minimum(at, len(own) - 1)]
        distance = np.linalg.norm(contact_points[candidate] - points, axis=1)
        alignment = np.abs(np.einsum("ij,ij->i", contact_normals[candidate], normals))
        nearer = distance < best_distance - tie
        aligned = (np.abs(distance - best_distance) <= tie) & (alignment > best_alignment)
        better = (at < hi) & (nearer | aligned)
        best = np.where(better, candidate, best)
        best_distance = np.where(better, np.minimum(distance, best_distance), best_distance)
        best_alignment = np.where(better, alignment, best_alignment)
    return best


def carry_stress(blocks: BlockSet, contacts: ContactSet, field: StressField) -> ContactSet:
    """``contacts`` with every touching one carrying ``field`` as its multipliers."""
    if not len(contacts):
        return contacts
    rows = contact_rows(blocks, contacts)
    pieces = joint_pieces(blocks)
    f_start, f_end = field.segment_forces(pieces.start, pieces.end, pieces.normal)
    ends = np.concatenate([pieces.start, pieces.end])
    forces = np.concatenate([f_start, f_end])  # on the piece's block
    on = np.concatenate([pieces.block, pieces.block])
    keys = pair_key(on, np.concatenate([pieces.other, pieces.other]), blocks.count)
    touching = contacts.state != OPEN
    normals = np.concatenate([pieces.normal, pieces.normal])
    holder = nearest_contact(
        contacts, rows.points, rows.normals, touching, ends, normals, keys, blocks.count
    )
    held = holder >= 0
    if not held.all():  # a covered stretch whose blocks have no touching contact
        log.info("in-situ stress: %d joint piece end(s) without a touching contact of their "
                 "two blocks carry nothing", int((~held).sum()))  # fmt: skip
    sign = np.where(contacts.block_b[holder[held]] == on[held], 1.0, -1.0)  # on the edge block
    total = np.zeros((len(contacts), 2))
    np.add.at(total, holder[held], sign[:, None] * forces[held])
    carries = np.zeros(len(contacts), bool)
    carries[holder[held]] = True
    normal = -np.einsum("ij,ij->i", total, rows.normals)
    shear = np.einsum("ij,ij->i", total, rows.tangents)
    out = contacts.copy()
    out.normal_multiplier = np.where(
        carries, normal - contacts.penalty * rows.penetration, contacts.normal_multiplier
    )
    out.shear_multiplier = np.where(carries, shear, contacts.shear_multiplier)
    return out


def with_carried_forces(contacts: ContactSet) -> ContactSet:
    """``contacts`` with the forces their multipliers carry on the touching ones,
    N = λn + p g and F = λt (:func:`carry_stress` sets the multipliers, not the forces a
    solve records): what their springs hold at t = 0, for the energy account."""
    out = contacts.copy()
    touching = contacts.state != OPEN
    carried = contacts.normal_multiplier + contacts.penalty * contacts.penetration
    out.normal_force = np.where(touching, carried, contacts.normal_force)
    out.shear_force = np.where(touching, contacts.shear_multiplier, contacts.shear_force)
    return out
