"""The contacts a block that breaks hands to its pieces.

A block breaks between two steps and its pieces keep its outer boundary: each vertex of
the parent is a vertex of a piece, each edge of the parent is covered by edges of the
pieces. A contact of the parent with another block (a vertex of one on an edge of the
other) is at the same place on the pieces, so it goes on there with all it carries: its
state, its multipliers λn and λt (the force it holds: an augmented-Lagrangian multiplier,
an equilibrium start's preload, an in-situ field), its penalty, its bond (a joint that
failed stays failed) and its shear reference point. Without it the pieces' contacts with
the parent's neighbours would start as new ones: unloaded (the force held by λ lost in
one step, a jolt to the neighbours) and bonded (a joint that had slipped healed).

The place of a contact on a piece:

* the parent's vertex P is the piece's vertex at the same point (within
  ``SAME_POINT`` of the parent's size; where a crack ends at P, the piece whose edge at
  P lies most nearly along the contact's edge);
* the parent's edge P2P3 is the piece's edge along the same line, in the same direction,
  whose span holds the projection of the touching vertex V (the nearest span where
  none does), and the shear reference point P0 = P2 + r (P3 − P2) keeps its place:
  r' = (P0 − Q2)·(Q3 − Q2) / |Q3 − Q2|².

A contact that finds no place (a crack runs through its vertex and moved it, or both
its blocks broke and one side finds none) is left to the next step's search, which
finds it anew.
"""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet, carried_over, contact_keys, joined

# the distance, over the parent's size √A, within which a piece's vertex or edge is the
# parent's: the pieces are cut with shapely, which keeps the parent's vertices to
# round-off
SAME_POINT = 1e-9


def after_breaking(
    contacts: ContactSet, old: BlockSet, new: BlockSet, parent_of: np.ndarray
) -> ContactSet:
    """The contacts of ``new``, the blocks after some of ``old`` broke (``parent_of``: each
    new block's old row): those of the blocks that stay as they were (renumbered), and
    those of the broken ones on their pieces (:func:`inherited_contacts`)."""
    whole = np.flatnonzero(np.isin(new.ids, old.ids))  # the pieces have fresh ids
    row_of = np.full(old.count, -1)
    row_of[parent_of[whole]] = whole
    kept = carried_over(contacts, old, new, row_of)
    return joined(kept, inherited_contacts(contacts, old, new, row_of, parent_of))


def inherited_contacts(
    contacts: ContactSet, old: BlockSet, new: BlockSet, row_of: np.ndarray, parent_of: np.ndarray
) -> ContactSet:
    """The contacts of ``contacts`` that have a block that broke between ``old`` and
    ``new``, placed on its pieces (module docstring). ``row_of``: each old block's row in
    ``new`` (−1 for one that broke); ``parent_of``: each new block's old row."""
    broken = row_of < 0
    rows = np.flatnonzero(broken[contacts.block_a] | broken[contacts.block_b])
    if not len(rows):
        return contacts.subset(rows)
    handed = contacts.subset(rows)
    pieces = np.flatnonzero(broken[parent_of])  # the new rows of the pieces
    vertex = _renumbered(old, new, row_of, handed.vertex)
    edge = _renumbered(old, new, row_of, handed.edge)
    reference = handed.reference.copy()
    for parent in np.flatnonzero(broken):
        own = pieces[parent_of[pieces] == parent]
        size = float(np.sqrt(old.area[parent]))
        at_vertex = np.flatnonzero(handed.block_a == parent)
        vertex[at_vertex] = _same_vertex(
            old, new, handed.vertex[at_vertex], handed.edge[at_vertex], own, size
        )
        at_edge = np.flatnonzero(handed.block_b == parent)
        edge[at_edge], reference[at_edge] = _same_edge(
            old, new, handed.vertex[at_edge], handed.edge[at_edge],
            handed.reference[at_edge], own, size,
        )  # fmt: skip
    placed = np.flatnonzero((vertex >= 0) & (edge >= 0))
    out = handed.subset(placed)
    out.vertex, out.edge, out.reference = vertex[placed], edge[placed], reference[placed]
    owner = new.vertex_owner
    out.block_a, out.block_b = owner[out.vertex], owner[out.edge]
    out.key = contact_keys(new, out.vertex, out.edge)
    _, first = np.unique(out.key, return_index=True)  # one contact a vertex-edge pair
    return out.subset(np.sort(first))


def _renumbered(old: BlockSet, new: BlockSet, row_of: np.ndarray, vertex: np.ndarray):
    """The new packed number of each old packed vertex of a block that stays (−1 else)."""
    owner = old.vertex_owner[vertex]
    row = row_of[owner]
    local = vertex - old.offsets[owner]
    return np.where(row >= 0, new.offsets[np.maximum(row, 0)] + local, -1)


def _piece_vertices(new: BlockSet, pieces: np.ndarray) -> np.ndarray:
    """The packed numbers of the vertices of the blocks ``pieces``."""
    return np.concatenate([np.arange(new.offsets[p], new.offsets[p + 1]) for p in pieces])


def _same_vertex(old, new, vertex, edge, pieces, size):
    """The pieces' vertex at each old ``vertex``'s point (−1 where none is); where a crack
    ends there and two pieces share the point, the one with an edge at it most nearly
    along the contact's ``edge`` (the other block's): the piece that carries the parent's
    edge there, as the contact's length does."""
    if not len(vertex):
        return np.zeros(0, np.int64)
    candidates = _piece_vertices(new, pieces)
    apart = np.linalg.norm(
        old.vertices[vertex][:, None, :] - new.vertices[candidates][None, :, :], axis=2
    )
    near = apart <= SAME_POINT * size  # (m, k)
    along = old.vertices[old.next_vertex[edge]] - old.vertices[edge]  # (m, 2)
    along /= np.linalg.norm(along, axis=1)[:, None]
    sides = [new.vertices[new.next_vertex[candidates]] - new.vertices[candidates],
             new.vertices[new.previous_vertex[candidates]] - new.vertices[candidates]]  # fmt: skip
    turned = np.full(near.shape, np.inf)  # |sin| of the angle to the contact's edge
    for side in sides:
        unit = side / np.linalg.norm(side, axis=1)[:, None]
        sine = np.abs(along[:, None, 0] * unit[None, :, 1] - along[:, None, 1] * unit[None, :, 0])
        turned = np.minimum(turned, sine)
    best = np.argmin(np.where(near, turned, np.inf), axis=1)
    found = near[np.arange(len(vertex)), best]
    return np.where(found, candidates[best], -1)


def _same_edge(old, new, vertex, edge, reference, pieces, size):
    """(the pieces' edge along each old ``edge`` that holds the projection of the touching
    ``vertex``, −1 where none lies along it; the shear reference on it)."""
    if not len(edge):
        return np.zeros(0, np.int64), np.zeros(0)
    p2, p3 = old.vertices[edge], old.vertices[old.next_vertex[edge]]
    starts = _piece_vertices(new, pieces)
    q2, q3 = new.vertices[starts], new.vertices[new.next_vertex[starts]]
    along = p3 - p2  # (m, 2)
    length = np.linalg.norm(along, axis=1)[:, None]
    unit = along / length

    def off_line(q):  # (m, k) distance of the points q from each edge's line
        rel = q[None, :, :] - p2[:, None, :]
        return np.abs(rel[..., 0] * unit[:, None, 1] - rel[..., 1] * unit[:, None, 0])

    span = q3 - q2
    same_way = (span[None, :, :] * unit[:, None, :]).sum(axis=2) > 0.0
    on_line = (off_line(q2) <= SAME_POINT * size) & (off_line(q3) <= SAME_POINT * size)
    # the touching vertex's place along each candidate span, 0 to 1 inside it
    span_length2 = (span**2).sum(axis=1)
    t = ((old.vertices[vertex][:, None, :] - q2[None, :, :]) * span[None, :, :]).sum(axis=2)
    t = t / np.maximum(span_length2, np.finfo(float).tiny)[None, :]
    outside = np.maximum(0.0, np.maximum(-t, t - 1.0))
    outside = np.where(same_way & on_line, outside, np.inf)
    best = np.argmin(outside, axis=1)
    found = np.isfinite(outside[np.arange(len(edge)), best])
    chosen = np.where(found, starts[best], -1)
    p0 = p2 + reference[:, None] * along  # the shear reference point keeps its place
    b2, b_span = q2[best], span[best]
    moved = ((p0 - b2) * b_span).sum(axis=1) / np.maximum(span_length2[best], 1e-300)
    return chosen, np.where(found, moved, reference)
