"""A corner sliding along a line of faces keeps to that line at a flush joint.

A block sliding across the joint of two blocks whose faces are one line (two base
blocks side by side, their tops flush) brings its corner onto the far block's corner
at the joint: a vertex-vertex pair whose four candidate pairings tie in angle. Two
of them lie along the line: the sliding corner onto the far block's face, and the far
block's corner onto the slider's face. The other two lie across the motion: the
sliding corner onto the far block's side (covered by the near block) and the far
corner onto the slider's front face. While the corner is further from the joint than
the vertex-vertex slack, the two along the line are no candidates (the corner is not
over the far block's face): one across the motion is the pair's pairing, open, and the
last step's pairing would keep it as the corner comes up, a wall at the joint (a
frictionless block at 0.5 m/s would come back at 0.15 m/s;
tests/standing/test_flush_joint.py).

The geometry of the node alone cannot tell the two pairs apart: mirrored in the line
through the node and the near block's corner, the slider becomes the far block and
the far block a slider moving along the joint. What does tell them apart is the last
step: the sliding corner slid on the near block's face, whose line the far block's
face continues. So a tied candidate that continues the line of another edge its
vertex slid along last step (a sliding contact;
:func:`dda.contact.candidate_tests.continues_line`) wins the tie. The pair's own
pairing of the last step, where it was a closed contact, joins those candidates: along
their line, it keeps the tie by the usual rules; across it (two corners meeting at a
node, each from its own face, as around a fresh opening, or a wall already closed),
the rule stands aside and the usual rules decide.

A corner at rest near the joint has slid along no face when its block starts to move;
within the vertex-vertex slack of the joint, its face's contact with the near block's
corner at the joint is that corner's, onto the face (the corner slides under it). So a
vertex also moved along its own two edges where a corner of another block slid under
one of them last step and lies within the slack of the vertex: the vertex is passing
over that corner, and a tied candidate onto a third block's edge that continues the
edge's line (facing it) wins the tie as well. A corner elsewhere on the face (a rock
mass's faces carry many) or the corner's own block does not count: the line carries
the vertex past that corner, onto the face beyond it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dda.blocks import BlockSet
from dda.contact.candidate_tests import along_one_line, continues_line, passing_corner
from dda.contact.contact_set import ContactSet, same_block
from dda.geometry import expand_counts
from dda.jit import formula, kernel, select
from dda.result import OPEN, SLIDING


class LastStep(NamedTuple):
    """What the line rule needs of the last step's contacts (:func:`last_step`)."""

    sliding_vertex: np.ndarray  # the vertices of its sliding contacts (present numbering)
    sliding_edge: np.ndarray  # ... and their edges (start vertices)
    held_keys: np.ndarray  # the sorted keys of its closed contacts (sliding or locked)


def last_step(contacts: ContactSet) -> LastStep:
    """The line rule's view of ``contacts``, the last step's contact set (its vertex and
    edge numbers are the present blocks': stages and fracture renumber them)."""
    sliding = contacts.state == SLIDING
    held = np.sort(np.asarray(contacts.key, np.int64)[contacts.state != OPEN])
    return LastStep(
        contacts.vertex[sliding].astype(np.int64), contacts.edge[sliding].astype(np.int64), held
    )


def previous_partners(blocks: BlockSet, last: LastStep | None) -> tuple[np.ndarray, np.ndarray]:
    """(indptr, lines): for each vertex of ``blocks``, as CSR lists, the lines it moved
    along last step, each a row (line, via) of ``lines``:

    * (e, −1) for the edge e (its start vertex) of each of its sliding contacts;
    * (−(e + 1), w) for each of its own two edges e along which a vertex w of another
      block slid: a corner slid under that edge, whose line carried the vertex past it
      (a base block's corner under a sliding block's face). It counts towards the faces
      of blocks other than w's (:func:`continuing`)."""
    n = len(blocks.vertices)
    if last is None:
        return np.zeros(n + 1, np.int64), np.zeros((0, 2), np.int64)
    slid, slider = last.sliding_edge, last.sliding_vertex
    vertex = np.concatenate([slider, slid, blocks.next_vertex[slid]])
    own = -(slid + 1)
    lines = np.column_stack(
        [np.concatenate([slid, own, own]),
         np.concatenate([np.full(len(slid), -1), slider, slider])]
    ).astype(np.int64)  # fmt: skip
    order = np.argsort(vertex, kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(vertex, minlength=n), out=indptr[1:])
    return indptr, np.ascontiguousarray(lines[order])


def continuing(
    vertices: np.ndarray,
    outward: np.ndarray,
    parts: np.ndarray,
    vertex: np.ndarray,
    edge: np.ndarray,
    depth: np.ndarray,
    slack: float,
    inside_depth: float,
    partners: tuple[np.ndarray, np.ndarray],
    cosine: float,
) -> np.ndarray:
    """Mask of the candidates (``vertex`` onto ``edge``, arrays of one shape, ``depth``
    the vertex's behind the edge's line) that continue a line their vertex moved along
    last step (``partners``: :func:`previous_partners`; ``parts``: the vertices' key
    parts, :func:`dda.contact.contact_set.vertex_key_parts`). An edge the vertex slid along
    does not count for the same pairing again; an own edge counts for any candidate (a
    vertex sliding on an edge and passing over a corner under its own edge keeps to both
    lines, which the usual rules then decide between)."""
    indptr, lines = partners
    flat_vertex, flat_edge = vertex.ravel(), edge.ravel()
    row, position = expand_counts(indptr[flat_vertex + 1] - indptr[flat_vertex])
    coded, via = lines[indptr[flat_vertex][row] + position].T
    mine = flat_edge[row]
    own = coded < 0
    other = np.where(own, -coded - 1, coded)
    via = np.maximum(via, 0)
    gap = vertices[mine] - vertices[other]
    corner = vertices[via] - vertices[flat_vertex[row]]
    hit = continues_moved_line(
        outward[mine, 0], outward[mine, 1], outward[other, 0], outward[other, 1], gap[:, 0],
        gap[:, 1], depth.ravel()[row], own, corner[:, 0], corner[:, 1],
        same_block(parts[via], parts[mine]), slack, inside_depth, cosine,
    )  # fmt: skip
    hit &= coded != mine  # the same pairing as last step's: not a line continued
    out = np.zeros(flat_vertex.shape, bool)
    out[row[hit]] = True
    return out.reshape(vertex.shape)


@formula
def continues_moved_line(nx, ny, other_nx, other_ny, dx, dy, depth, own, corner_dx, corner_dy,
                         corners_block, slack, inside_depth, cosine):  # fmt: skip
    """A candidate (a vertex onto an edge of outward normal (nx, ny), ``depth`` behind its
    line) that continues a line its vertex moved along last step, the line of an edge of
    normal (other_nx, other_ny) whose start is (dx, dy) from the candidate edge's
    (:func:`dda.contact.candidate_tests.continues_line`):

    * an edge the vertex slid along (``own`` False);
    * or one of its own edges (``own``; its normal reversed: the candidate's edge faces
      it) under which a corner slid, where that corner, (corner_dx, corner_dy) from the
      vertex, is within ``slack`` of it (the vertex is passing over it,
      :func:`dda.contact.candidate_tests.passing_corner`) and the candidate's edge is not
      of the corner's block (``corners_block``)."""
    sign = select(own, -1.0, 1.0)
    on_line = continues_line(
        nx, ny, sign * other_nx, sign * other_ny, dx, dy, depth, slack, inside_depth, cosine
    )
    passing = passing_corner(corner_dx, corner_dy, slack) & np.logical_not(corners_block)
    return on_line & (np.logical_not(own) | passing)


def _keep_to_lines(tied, line, verts, edges, depth, v, outward, partners, parts, scale, slack,
                   inside, cosine):  # fmt: skip
    """Compiled :func:`continuing` and :func:`keeping_to_one_line` of one vertex-vertex
    pair's four candidates (``verts`` onto ``edges``; ``partners``: the CSR lists of the
    lines the vertices moved along last step (:func:`previous_partners`), then the sorted
    keys, ``parts`` × ``scale`` + ``parts``, of the contacts that were closed): ``line``
    set where a ``tied`` candidate continues a line its vertex moved along; where some
    do, also where one was a closed contact (it keeps to its own line), and where all
    those lie along one line, ``tied`` narrowed to them. In place."""
    partner_ptr, partner_edges, held = partners
    continued = False
    for c in range(4):
        if not tied[c]:
            continue
        mine = edges[c]
        for j in range(partner_ptr[verts[c]], partner_ptr[verts[c] + 1]):
            coded = partner_edges[j, 0]
            if coded == mine:
                continue  # the same pairing as last step's: not a line continued
            own = coded < 0
            other = -coded - 1 if own else coded
            via = max(partner_edges[j, 1], 0)
            line[c] |= continues_moved_line(
                outward[mine, 0], outward[mine, 1], outward[other, 0], outward[other, 1],
                v[mine, 0] - v[other, 0], v[mine, 1] - v[other, 1], depth[c], own,
                v[via, 0] - v[verts[c], 0], v[via, 1] - v[verts[c], 1],
                same_block(parts[via], parts[mine]), slack, inside, cosine,
            )  # fmt: skip
        continued |= line[c]
    if not continued:
        return
    for c in range(4):
        key = parts[verts[c]] * scale + parts[edges[c]]
        at = np.searchsorted(held, key)
        line[c] |= tied[c] and at < held.shape[0] and held[at] == key  # a closed contact
    first = -1
    for c in range(4):
        if line[c]:
            if first < 0:
                first = c
                continue
            a, b = edges[first], edges[c]
            dot = outward[a, 0] * outward[b, 0] + outward[a, 1] * outward[b, 1]
            if not along_one_line(dot, cosine):
                return  # two lines that cross: no rule
    if first >= 0:
        for c in range(4):
            tied[c] &= line[c]


keep_to_lines_kernel = kernel(_keep_to_lines) or _keep_to_lines


def keeping_to_one_line(
    tied: np.ndarray, line: np.ndarray, normals: np.ndarray, cosine: float
) -> np.ndarray:
    """``tied`` (k, 4) narrowed to ``line`` (the tied candidates that continue a line, of
    outward normals ``normals`` (k, 4, 2)) where those lie along one line
    (:func:`dda.contact.candidate_tests.along_one_line`); where they cross, or none does,
    ``tied`` as it is."""
    rows = np.arange(len(tied))
    reference = normals[rows, np.argmax(line, axis=1)]
    dots = np.einsum("kcj,kj->kc", normals, reference)
    one = line.any(axis=1) & ~(line & ~along_one_line(dots, cosine)).any(axis=1)
    return np.where(one[:, None], line, tied)
