"""Narrow phase: vertex-edge and vertex-vertex contacts between candidate pairs.

Penetration is positive: for vertex P1 and the counter-clockwise edge P2P3 of
the other block, d = ((P3 - P2) × (P1 - P2)) / l (paper eq. 9), which is > 0
when P1 lies on the inner side of the edge.

* Vertex-edge (V-E): P1 projects inside the edge (by more than
  ``EDGE_END`` of its length from either end), away from its end points
  by more than the vertex radius; −gap ≤ d ≤ max(search, 0.3 √A) (A the smaller
  block's area); P1 is not a reflex vertex and both its edges leave it away from
  the other block within ``ANGLE_TOLERANCE`` (the angle test). The tests are
  written once in :mod:`dda.contact.candidate_tests`.
* Vertex-vertex (V-V): P1 within the vertex radius of a vertex P2 of the
  other block, or, given the vertices' motion over the coming step, meeting it
  head-on within the step (``corners_meet``: corners in line, a gap wider than the
  radius closed in one step). The radius of a pair is the smaller of the two vertices'
  radii, each at most ``VERTEX_RADIUS_FRACTION`` of the shortest edge at the
  vertex (a search distance larger than a small block's edges must not pair
  vertices across the block); the V-E test excludes the same zones. One
  contact per pair (but for a nested corner, below): of the four edges
  meeting at P1 and P2, take the one that best separates the opposite
  vertex's fan of edges (largest min over the fan of u·n_out): the edge the
  vertex will enter.
  Scores within ``ANGLE_TIE`` of the best are a tie, broken by last step's
  pairing (within the contact tolerance in depth), else by position: the
  edge whose line the vertex lies furthest outside of (least penetration).
  Never taken while another candidate remains: an edge the vertex is only
  behind the line of (beyond its ends, or much deeper than behind the
  corner's other edge), and the vertex that touches when the other one is
  inside the block by more than the contact tolerance.
  A convex vertex at a reflex corner of the other block (nested in it) is
  paired with both of the corner's edges: it is inside once it is behind
  either line, and with one pairing it entered through the other within a step.
  Where the two blocks' faces overlap (the corners apart, each over the other's
  face), the pair stands for a face-to-face contact: the other corner is paired
  too, with the face that faces the chosen edge (``face_to_face``), so the faces
  are held at both ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.contact.candidate_tests import (
    beyond_ends,
    corners_meet,
    deeper_of_opposed,
    deeper_than_corner,
    deepest_candidate,
    edge_along,
    edge_depth,
    edge_parameter,
    enters_less,
    face_to_face,
    fan_clears,
    fan_separation,
    inside_corner,
    line_depth,
    meet_at_reflex,
    moving_in,
    nested_in_corner,
    off_edge,
    projects_inside,
    within_reach,
)
from dda.contact.contact_set import KEY_SCALE, contact_keys, vertex_key_parts
from dda.contact.line_continuation import (
    LastStep,
    continuing,
    keep_to_lines_kernel,
    keeping_to_one_line,
    previous_partners,
)
from dda.contact.node import separated_corners_kernel, separated_pairs
from dda.geometry import (
    expand_counts,
    reflex_vertices,
)
from dda.jit import compiled, kernel

ANGLE_TOLERANCE = 0.2  # sin of the largest angle an edge of P1 may dip into the edge
ANGLE_TIE = 0.05  # vertex-vertex: edge scores this close are a tie, decided by position
SHARED_LINE_ANGLE = 0.01  # rad: two edges this parallel, facing the same way, share a line
SHARED_LINE_COSINE = np.cos(SHARED_LINE_ANGLE)
VERTEX_RADIUS_FRACTION = 0.25  # vertex radius ≤ this x the shortest edge at either vertex
OUTSIDE_FRACTION = 0.01  # of the search distance: a vertex farther out than this penetrates nothing
# of the edge length: a vertex projecting this close to an edge's end is no V-E candidate.
# Beyond the vertex zone that is a corner facing a corner: on a grid of blocks, vertices one
# block away project exactly onto edge ends, and round-off alone put 2,500-10,000 of them in
# and out of the contact list each step (40x40 and 100x100 walls whose search distance
# exceeds a block)
EDGE_END = 1e-9


@dataclass
class Detected:
    """Contacts found this step: global vertex index and global edge start index."""

    vertex: np.ndarray
    edge: np.ndarray
    vertex_vertex: np.ndarray  # bool
    # bool: a vertex-vertex pairing whose vertex's block has an edge along the corner's
    # other edge, facing the same way (:func:`_shares_line`): the blocks share that
    # boundary line, and the vertex's depth behind this edge is the overlap of the faces
    # that meet it however near the shared edge the vertex lies (the pipeline's
    # nearer-edge test leaves such a pairing be)
    shared_line: np.ndarray


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1)
    return v / np.where(n > 0, n, 1.0)[:, None]


class VertexFans:
    """Unit vectors along the two edges leaving each vertex, and reflex flags."""

    def __init__(self, blocks: BlockSet) -> None:
        v = blocks.vertices
        self.next = blocks.next_vertex
        self.prev = blocks.previous_vertex
        if compiled(_fans_kernel):
            self.to_next, self.to_prev, self.reflex, self.shortest = _fans_kernel(
                np.ascontiguousarray(v, dtype=np.float64), self.next, self.prev
            )
            self.outward = np.column_stack([self.to_next[:, 1], -self.to_next[:, 0]])
            return
        self.to_next = _unit(v[self.next] - v)
        self.to_prev = _unit(v[self.prev] - v)
        # unit outward normal of the edge leaving each vertex (counter-clockwise polygons)
        self.outward = np.column_stack([self.to_next[:, 1], -self.to_next[:, 0]])
        self.reflex = reflex_vertices(v, blocks.offsets)
        edge_length = np.linalg.norm(v[self.next] - v, axis=1)
        self.shortest = np.minimum(edge_length, edge_length[self.prev])  # edges at the vertex

    def separation(self, vertex: np.ndarray, outward: np.ndarray) -> np.ndarray:
        """min(u_prev·n, u_next·n): ≥ 0 when the fan stays outside the edge's line."""
        to_next, to_prev = self.to_next[vertex], self.to_prev[vertex]
        return fan_separation(
            to_next[:, 0], to_next[:, 1], to_prev[:, 0], to_prev[:, 1], outward[:, 0], outward[:, 1]
        )


def _fans(v, nxt, prv):
    """Compiled :class:`VertexFans`: unit edge vectors, reflex flags, shortest edges."""
    n = v.shape[0]
    to_next, to_prev = np.empty((n, 2)), np.empty((n, 2))
    reflex, length = np.empty(n, np.bool_), np.empty(n)
    for k in range(n):
        ax, ay = v[nxt[k], 0] - v[k, 0], v[nxt[k], 1] - v[k, 1]
        bx, by = v[prv[k], 0] - v[k, 0], v[prv[k], 1] - v[k, 1]
        la, lb = np.sqrt(ax * ax + ay * ay), np.sqrt(bx * bx + by * by)
        length[k] = la
        la, lb = (la if la > 0 else 1.0), (lb if lb > 0 else 1.0)
        to_next[k, 0], to_next[k, 1] = ax / la, ay / la
        to_prev[k, 0], to_prev[k, 1] = bx / lb, by / lb
        reflex[k] = (-bx) * ay - (-by) * ax < 0.0  # (P - P_prev) x (P_next - P) < 0
    shortest = np.empty(n)
    for k in range(n):
        shortest[k] = min(length[k], length[prv[k]])
    return to_next, to_prev, reflex, shortest


_fans_kernel = kernel(_fans)


def _vertex_edge_candidates(blocks, pairs, search):
    """All (vertex of a, edge of b) combinations with the vertex near b's box."""
    a = np.concatenate([pairs[:, 0], pairs[:, 1]])
    b = np.concatenate([pairs[:, 1], pairs[:, 0]])
    counts = np.diff(blocks.offsets)
    p, local = expand_counts(counts[a])
    vertex = blocks.offsets[a][p] + local
    lo, hi = _grown_boxes(blocks, search)
    pos = blocks.vertices[vertex]
    near = np.all((pos >= lo[b[p]]) & (pos <= hi[b[p]]), axis=1)
    p, vertex = p[near], vertex[near]
    q, local = expand_counts(counts[b[p]])
    edge = blocks.offsets[b[p]][q] + local
    return a[p][q], b[p][q], vertex[q], edge


def detect(
    blocks: BlockSet,
    pairs: np.ndarray,
    search: float,
    vertex_radius: float,
    inside_depth: float = np.inf,
    previous_keys: np.ndarray | None = None,
    gap: float | None = None,
    last: LastStep | None = None,
    motion: np.ndarray | None = None,
) -> Detected:
    """Vertex-edge and vertex-vertex contacts for candidate block pairs.

    ``gap``: the widest gap (m) a vertex may have from an edge's line to be a
    vertex-edge candidate (default ``search``): the run narrows it to what
    the blocks' motion can close in the step (:mod:`dda.contact.reach`).
    ``search`` still sets the boxes the vertices are screened in (so the
    vertex-vertex candidates, whose resolution keeps a contact's pairing
    from step to step, do not depend on ``gap``), the deepest penetration a
    candidate may have and the vertex-vertex slack.

    ``inside_depth``: a vertex deeper than this inside the other block (the
    contact tolerance) is the one a vertex-vertex pair is resolved with; corners
    of a node closer than this to each other may separate a pair
    (:mod:`dda.contact.node`).
    ``previous_keys``: contact keys of the last step; a vertex-vertex tie is
    resolved with the pairing among them, so that the contact keeps its
    identity (and its history: state, multipliers, shear reference).
    ``last``: the last step's sliding and closed contacts
    (:func:`dda.contact.line_continuation.last_step`; None: none): a corner that slid
    along a face onto the next face of its line keeps to that line.
    ``motion``: (N, 2) each vertex's motion over the coming step (None: none known):
    corners that meet head-on within it are a vertex-vertex pair, and a vertex-vertex
    tie that neither its depths nor the last step decides goes to the pairing whose
    vertex moves into its edge (:func:`_entering_less`).
    """
    empty = np.zeros(0, dtype=np.int64)
    if len(pairs) == 0:
        return Detected(empty, empty, np.zeros(0, bool), np.zeros(0, bool))
    if compiled(_detect_kernel):
        return _detect_compiled(
            blocks, pairs, search, vertex_radius, inside_depth, previous_keys, gap, last, motion
        )
    fans, (ve_vertex, ve_edge, vv_vertex, vv_edge) = _screened(
        blocks, pairs, search, vertex_radius, search if gap is None else gap, motion
    )
    apart = _at_filled_nodes(blocks, fans, vv_vertex, vv_edge, inside_depth)
    vv_vertex, vv_edge = vv_vertex[~apart], vv_edge[~apart]
    slack = OUTSIDE_FRACTION * search
    vv_vertex, vv_edge, vv_shared = _resolve_vertex_vertex(
        blocks, fans, vv_vertex, vv_edge, slack, inside_depth, previous_keys, last, motion
    )
    vertex_all = np.concatenate([ve_vertex, vv_vertex])
    edge_all = np.concatenate([ve_edge, vv_edge])
    kind = np.concatenate([np.zeros(len(ve_vertex), bool), np.ones(len(vv_vertex), bool)])
    shared = np.concatenate([np.zeros(len(ve_vertex), bool), vv_shared])
    keep = _first_of_each(vertex_all, edge_all)
    keep = keep[~_opposed_deeper(blocks, fans, vertex_all[keep], edge_all[keep])]
    return Detected(vertex_all[keep], edge_all[keep], kind[keep], shared[keep])


def _detect_compiled(
    blocks, pairs, search, vertex_radius, inside_depth, previous_keys, gap, last=None,
    motion=None,
):  # fmt: skip
    """:func:`detect` in one compiled call (:func:`_detect`): the same contacts, in the
    same order, as the numpy path's and the compiled pieces' it strings together."""
    arguments = detect_arguments(
        blocks, pairs, search, vertex_radius, inside_depth, previous_keys, gap, last, motion
    )
    return Detected(*_detect_kernel(*arguments))


def detect_arguments(
    blocks, pairs, search, vertex_radius, inside_depth, previous_keys, gap, last=None,
    motion=None,
):  # fmt: skip
    """The arguments of the compiled narrow phase (:func:`_detect`) for :func:`detect`'s."""
    known = np.zeros(0, np.int64) if previous_keys is None else np.sort(previous_keys)
    partner_ptr, partner_edges = previous_partners(blocks, last)
    held = np.zeros(0, np.int64) if last is None else last.held_keys
    return (
        np.ascontiguousarray(pairs, dtype=np.int64),
        blocks.offsets.astype(np.int64),
        np.ascontiguousarray(blocks.vertices, dtype=np.float64),
        blocks.next_vertex.astype(np.int64),
        blocks.previous_vertex.astype(np.int64),
        blocks.vertex_owner.astype(np.int64),
        np.ascontiguousarray(blocks.area, dtype=np.float64),
        vertex_key_parts(blocks),
        known.astype(np.int64),
        partner_ptr,
        partner_edges,
        held,
        np.zeros((0, 2)) if motion is None else np.ascontiguousarray(motion, np.float64),
        float(vertex_radius),
        float(search),
        float(search if gap is None else gap),
        float(inside_depth),
    )


def _detect(
    pairs, offsets, v, nxt, prv, owner, area, parts, known, partner_ptr, partner_edges, held,
    motion, vertex_radius, search, gap, inside,
):  # fmt: skip
    """Compiled :func:`detect`: fans, screen, corners separated at filled nodes,
    vertex-vertex resolution and one row per pairing, the kernels of each stage."""
    to_next, to_prev, reflex, shortest = _fans_kernel(v, nxt, prv)
    outward = np.empty_like(to_next)
    for k in range(to_next.shape[0]):  # loops, not slices (dda.jit's docstring)
        outward[k, 0], outward[k, 1] = to_next[k, 1], -to_next[k, 0]
    radius = np.minimum(vertex_radius, VERTEX_RADIUS_FRACTION * shortest)
    margin = max(gap, radius.max()) if radius.shape[0] else gap
    blocks_count = offsets.shape[0] - 1
    lo, hi = np.empty((blocks_count, 2)), np.empty((blocks_count, 2))
    for b in range(blocks_count):
        for axis in range(2):
            low, high = np.inf, -np.inf
            for k in range(offsets[b], offsets[b + 1]):
                low, high = min(low, v[k, axis]), max(high, v[k, axis])
            lo[b, axis], hi[b, axis] = low - margin, high + margin
    count = pairs.shape[0]
    directed = np.empty((2 * count, 2), np.int64)
    for k in range(count):
        directed[k, 0], directed[k, 1] = pairs[k, 0], pairs[k, 1]
        directed[count + k, 0], directed[count + k, 1] = pairs[k, 1], pairs[k, 0]
    ve_v, ve_e, vv_v, vv_e = _screen_kernel(
        directed, offsets, v, nxt, prv, reflex, to_next, to_prev, radius, area, lo, hi,
        search, gap, motion, ANGLE_TOLERANCE, EDGE_END,
    )  # fmt: skip
    vv_s = np.zeros(0, np.bool_)
    if vv_v.shape[0]:
        close = ~separated_corners_kernel(v, owner, to_next, to_prev, vv_v, vv_e, inside)
        vv_v, vv_e, vv_s = _resolve_kernel(
            vv_v[close], vv_e[close], v, nxt, prv, to_next, to_prev, outward, reflex, parts,
            known, (partner_ptr, partner_edges, held), OUTSIDE_FRACTION * search, inside, ANGLE_TIE,
            KEY_SCALE, motion,
        )  # fmt: skip
    vertex = np.concatenate((ve_v, vv_v))
    edge = np.concatenate((ve_e, vv_e))
    kind = np.zeros(vertex.shape[0], np.bool_)
    kind[ve_v.shape[0] :] = True
    shared = np.zeros(vertex.shape[0], np.bool_)
    for k in range(vv_s.shape[0]):
        shared[ve_v.shape[0] + k] = vv_s[k]
    keep = _pairings_kernel(vertex, edge, v, nxt, reflex, owner, outward, blocks_count)
    return vertex[keep], edge[keep], kind[keep], shared[keep]


def _screened(
    blocks: BlockSet, pairs: np.ndarray, search: float, vertex_radius: float, gap: float,
    motion: np.ndarray | None = None,
):  # fmt: skip
    """(fans, (V-E vertex, edge, V-V vertex, edge)): the candidates that pass the tests
    (V-E: a vertex at most ``gap`` outside the edge's line; V-V: within the vertex radius,
    or, with the vertices' ``motion`` over the coming step, meeting head-on in it)."""
    fans = VertexFans(blocks)
    radius = np.minimum(vertex_radius, VERTEX_RADIUS_FRACTION * fans.shortest)
    screen = _screen_compiled if compiled(_screen_kernel) else _screen_numpy
    motion = np.zeros((0, 2)) if motion is None else np.ascontiguousarray(motion, np.float64)
    return fans, screen(blocks, fans, pairs, search, radius, gap, motion)


def _at_filled_nodes(blocks: BlockSet, fans: VertexFans, p1, p2, tight: float) -> np.ndarray:
    """Mask of the corner pairs that other blocks separate (:mod:`dda.contact.node`)."""
    corners = (fans.to_next, fans.to_prev, p1, p2)
    return separated_pairs(blocks.vertices, blocks.vertex_owner, *corners, tight)


def separated_blocks(
    blocks: BlockSet, pairs: np.ndarray, search: float, vertex_radius: float, tight: float
) -> np.ndarray:
    """(k, 2) block pairs (lower row first) among ``pairs`` with corners that meet at a
    node other blocks fill: no contact between them while the node stays so."""
    if len(pairs) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    fans, (_, _, p1, p2) = _screened(blocks, pairs, search, vertex_radius, search)
    apart = _at_filled_nodes(blocks, fans, p1, p2, tight)
    owner = blocks.vertex_owner
    found = np.column_stack([owner[p1[apart]], owner[p2[apart]]]).astype(np.int64)
    return np.unique(np.sort(found, axis=1), axis=0)


def _box_margin(radius: np.ndarray, gap: float) -> float:
    """How far outside another block's box a vertex can be a candidate: a V-E
    candidate projects inside its edge within ``gap`` of it, a V-V one lies within
    its vertex radius of the edge's first vertex; boxes grown by this much lose
    neither."""
    return max(float(gap), float(radius.max(initial=0.0)))


def _grown_boxes(blocks: BlockSet, search: float) -> tuple[np.ndarray, np.ndarray]:
    lo = np.minimum.reduceat(blocks.vertices, blocks.offsets[:-1], axis=0) - search
    hi = np.maximum.reduceat(blocks.vertices, blocks.offsets[:-1], axis=0) + search
    return lo, hi


def _screen_numpy(blocks, fans, pairs, search, radius, gap, motion):
    """(V-E vertex, edge, V-V vertex, edge) candidates that pass the tests (numpy)."""
    a, b, vertex, edge = _vertex_edge_candidates(blocks, pairs, _box_margin(radius, gap))
    v = blocks.vertices
    p1, p2, p3 = v[vertex], v[edge], v[fans.next[edge]]
    e, w = p3 - p2, p1 - p2
    length = np.linalg.norm(e, axis=1)
    t = edge_parameter(w[:, 0], w[:, 1], e[:, 0], e[:, 1], length)
    d = edge_depth(w[:, 0], w[:, 1], e[:, 0], e[:, 1], length)
    outward = np.column_stack([e[:, 1], -e[:, 0]]) / length[:, None]
    r2 = np.linalg.norm(w, axis=1)
    r3 = np.linalg.norm(p1 - p3, axis=1)
    deepest = deepest_candidate(search, blocks.area[a], blocks.area[b])
    radius2 = np.minimum(radius[vertex], radius[edge])  # the zone around P2 ...
    radius3 = np.minimum(radius[vertex], radius[fans.next[edge]])  # ... and around P3

    ve = (
        ~fans.reflex[vertex]
        & projects_inside(t, EDGE_END)
        & (r2 > radius2)
        & (r3 > radius3)
        & within_reach(d, gap, deepest)
        & fan_clears(fans.separation(vertex, outward), ANGLE_TOLERANCE)
    )
    vv = (a < b) & (r2 <= radius2)
    if len(motion):
        m = motion[vertex] - motion[edge]
        corner_a, corner_b = v[vertex], v[edge]
        b_next, b_prev = (v[fans.next[edge]] - corner_b).T, (v[fans.prev[edge]] - corner_b).T
        a_next, a_prev = (v[fans.next[vertex]] - corner_a).T, (v[fans.prev[vertex]] - corner_a).T
        meet = corners_meet(
            w[:, 0], w[:, 1], m[:, 0], m[:, 1], radius2, b_next, b_prev, a_next, a_prev, EDGE_END
        )
        vv |= (a < b) & meet
    return vertex[ve], edge[ve], vertex[vv], edge[vv]


def _screen_compiled(blocks, fans, pairs, search, radius, gap, motion):
    """The same candidates as :func:`_screen_numpy`, in the same order (numba)."""
    lo, hi = _grown_boxes(blocks, _box_margin(radius, gap))
    directed = np.concatenate([pairs, pairs[:, ::-1]]).astype(np.int64)
    out = _screen_kernel(
        np.ascontiguousarray(directed),
        blocks.offsets.astype(np.int64),
        np.ascontiguousarray(blocks.vertices, dtype=np.float64),
        fans.next.astype(np.int64),
        fans.prev.astype(np.int64),
        fans.reflex,
        np.ascontiguousarray(fans.to_next),
        np.ascontiguousarray(fans.to_prev),
        radius,
        np.ascontiguousarray(blocks.area, dtype=np.float64),
        np.ascontiguousarray(lo),
        np.ascontiguousarray(hi),
        float(search),
        float(gap),
        motion,
        ANGLE_TOLERANCE,
        EDGE_END,
    )
    return out


def _screen(
    directed,
    offsets,
    v,
    nxt,
    prv,
    reflex,
    to_next,
    to_prev,
    radius,
    area,
    lo,
    hi,
    search,
    gap,
    motion,
    angle_tolerance,
    edge_end,
):
    """Compiled screen: loop over directed pairs, vertices near the box, edges."""
    capacity = 0
    for k in range(directed.shape[0]):
        a, b = directed[k, 0], directed[k, 1]
        capacity += (offsets[a + 1] - offsets[a]) * (offsets[b + 1] - offsets[b])
    ve_v = np.empty(capacity, np.int64)
    ve_e = np.empty(capacity, np.int64)
    vv_v = np.empty(capacity, np.int64)
    vv_e = np.empty(capacity, np.int64)
    nve = 0
    nvv = 0
    for k in range(directed.shape[0]):
        a, b = directed[k, 0], directed[k, 1]
        deepest = deepest_candidate(search, area[a], area[b])
        for vertex in range(offsets[a], offsets[a + 1]):
            x1, y1 = v[vertex, 0], v[vertex, 1]
            if not (lo[b, 0] <= x1 <= hi[b, 0] and lo[b, 1] <= y1 <= hi[b, 1]):
                continue
            for edge in range(offsets[b], offsets[b + 1]):
                end = nxt[edge]
                x2, y2 = v[edge, 0], v[edge, 1]
                ex, ey = v[end, 0] - x2, v[end, 1] - y2
                wx, wy = x1 - x2, y1 - y2
                length = np.sqrt(ex * ex + ey * ey)
                r2 = np.sqrt(wx * wx + wy * wy)
                radius2 = min(radius[vertex], radius[edge])
                if a < b and (
                    r2 <= radius2
                    or _meet_kernel(v, nxt, prv, motion, vertex, edge, r2, radius2, edge_end)
                ):
                    vv_v[nvv] = vertex
                    vv_e[nvv] = edge
                    nvv += 1
                if reflex[vertex] or r2 <= radius2:
                    continue
                if not projects_inside(edge_parameter(wx, wy, ex, ey, length), edge_end):
                    continue
                ux, uy = x1 - v[end, 0], y1 - v[end, 1]
                if not np.sqrt(ux * ux + uy * uy) > min(radius[vertex], radius[end]):
                    continue
                if not within_reach(edge_depth(wx, wy, ex, ey, length), gap, deepest):
                    continue
                sep = fan_separation(
                    to_next[vertex, 0], to_next[vertex, 1], to_prev[vertex, 0],
                    to_prev[vertex, 1], ey / length, -ex / length,
                )  # fmt: skip
                if fan_clears(sep, angle_tolerance):
                    ve_v[nve] = vertex
                    ve_e[nve] = edge
                    nve += 1
    return ve_v[:nve].copy(), ve_e[:nve].copy(), vv_v[:nvv].copy(), vv_e[:nvv].copy()


def _meet(v, nxt, prv, motion, vertex, corner, apart, radius, edge_end):
    """:func:`corners_meet` of ``vertex`` and the other block's ``corner``, ``apart`` from
    each other (False without ``motion``, and at once where their relative motion is
    shorter than ``apart`` less ``radius``)."""
    if motion.shape[0] == 0:
        return False
    mx, my = motion[vertex, 0] - motion[corner, 0], motion[vertex, 1] - motion[corner, 1]
    if mx * mx + my * my < (apart - radius) * (apart - radius):
        return False
    x, y = v[vertex], v[corner]
    return corners_meet(
        x[0] - y[0], x[1] - y[1], mx, my, radius,
        (v[nxt[corner], 0] - y[0], v[nxt[corner], 1] - y[1]),
        (v[prv[corner], 0] - y[0], v[prv[corner], 1] - y[1]),
        (v[nxt[vertex], 0] - x[0], v[nxt[vertex], 1] - x[1]),
        (v[prv[vertex], 0] - x[0], v[prv[vertex], 1] - x[1]),
        edge_end,
    )  # fmt: skip


_meet_kernel = kernel(_meet)
_screen_kernel = kernel(_screen)


def _outward_normal(blocks: BlockSet, fans: VertexFans, edge: np.ndarray) -> np.ndarray:
    """Unit outward normal of each edge (kept per vertex in ``fans``)."""
    return fans.outward[edge]


def _resolve_vertex_vertex(
    blocks, fans, p1, p2, slack: float, inside_depth: float, previous_keys, last=None,
    motion=None,
):  # fmt: skip
    """Pick, for each coincident vertex pair (p1, p2), the edge to be entered.

    Candidates: the two edges at p2 (vertex p1 enters them) and the two edges
    at p1 (vertex p2 enters them). A reflex vertex never is the entering one,
    nor is a pairing whose penetration only the edge's line makes up
    (:func:`_fake_pairings`, beyond ``slack``), nor the vertex that is outside
    while the other is inside by more than ``inside_depth``
    (:func:`_hidden_penetration`), while another candidate remains.

    Among candidates tied in angle, one whose vertex projects onto its edge
    beats one whose vertex is beyond the edge's ends (by more than ``slack``):
    when one corner has slid past the other, the contact passes to the corner
    still over the other block's face. Among those within ``inside_depth`` of the
    least penetration, a pairing of the last step (its key in ``previous_keys``)
    wins; otherwise the least penetration does. Without this the
    corners of a regular wall, where every candidate ties, swapped pairings
    with round-off from step to step (more than half of the contacts of a
    10 x 10 wall got new keys every step) and lost their history.
    Where no pairing of the last step decides either, the one whose vertex moves into
    its edge over the coming step (``motion``: each vertex's, None: unknown) wins over
    those that enter by less than half as much: two corners that meet exactly, at rest,
    tie in every pairing (a beam laid corner to corner on two pillars rested on the
    top face of one and met the side face of the other, and tipped).

    Returns (vertex, edge, shared line) of each pairing: the last whether the
    vertex's block has an edge along the corner's other edge, facing the same way
    (:attr:`Detected.shared_line`).
    """
    if len(p1) == 0:
        return p1, p2, np.zeros(0, bool)
    candidates = [
        (p1, p2),  # p1 onto edge starting at p2
        (p1, fans.prev[p2]),  # p1 onto edge ending at p2
        (p2, p1),
        (p2, fans.prev[p1]),
    ]
    verts = np.column_stack([c[0] for c in candidates])
    edges = np.column_stack([c[1] for c in candidates])
    scores = np.column_stack(
        [
            np.where(
                fans.reflex[vert], -np.inf, fans.separation(vert, _outward_normal(blocks, fans, ed))
            )
            for vert, ed in candidates
        ]
    )
    depth = np.column_stack([_depth(blocks, fans, vert, ed) for vert, ed in candidates])
    along = np.column_stack([_along(blocks, fans, vert, ed) for vert, ed in candidates])
    off = _off_their_edges(blocks, fans, candidates, along, slack)
    shared = _shared_lines(fans, candidates)
    fake = _fake_pairings(depth, along, slack, fans.reflex[p2], fans.reflex[p1], shared)
    fake |= _hidden_penetration(depth, inside_depth)
    separation = scores
    scores = np.where(fake & ~fake.all(axis=1, keepdims=True), -np.inf, scores)
    # near-ties in angle (symmetric corners, a slight rotation) are decided by position:
    # the edge whose line the vertex is furthest outside of (least penetration)
    tied = scores >= scores.max(axis=1, keepdims=True) - ANGLE_TIE
    tied = _keeping_to_a_line(blocks, fans, verts, edges, depth, tied, slack, inside_depth, last)
    tied &= _on_their_edges(off, tied)
    least = np.where(tied, depth, np.inf).min(axis=1, keepdims=True)
    near = tied & (depth <= least + inside_depth)
    keep, decided = _persisting(blocks, candidates, near, previous_keys)
    tied &= keep
    if motion is not None and len(motion):
        tied &= ~_entering_less(verts, edges, motion, fans.outward, near, decided)
    best = np.argmin(np.where(tied, depth, np.inf), axis=1)
    # at a reflex corner a vertex is inside the block once it is behind either edge
    # line: it then belongs to the edge it is behind (the other one's line is no guide)
    for first, corner in ((0, p2), (2, p1)):
        pair = depth[:, first : first + 2]
        inside = fans.reflex[corner] & (pair.max(axis=1) > 0)
        best = np.where(inside, first + np.argmax(pair, axis=1), best)
    rows = np.arange(len(p1))
    # a convex vertex nested in a reflex corner is paired with the corner's other edge too
    group = best - best % 2
    corner, entering = np.where(group == 0, p2, p1), np.where(group == 0, p1, p2)
    nested = nested_in_corner(
        fans.reflex[corner], fans.reflex[entering], depth[rows, group], depth[rows, group + 1],
        inside_depth,
    )  # fmt: skip
    facing = _face_to_face(blocks, fans, verts, edges, best, separation, depth, off, fake, slack)
    second = nested | (facing >= 0)
    other = np.where(nested, group + 1 - best % 2, facing)[second]
    return (
        np.concatenate([verts[rows, best], verts[rows[second], other]]),
        np.concatenate([edges[rows, best], edges[rows[second], other]]),
        np.concatenate([shared[rows, best], shared[rows[second], other]]),
    )


def _face_to_face(blocks, fans, verts, edges, best, separation, depth, off, fake, slack):
    """(k,) the candidate (column) that is the other end of the face-to-face contact each
    pair's pairing ``best`` stands for (:func:`face_to_face`: the corner vertex onto the
    entering vertex's edge that faces the chosen edge), −1 where none is."""
    rows = np.arange(len(best))
    normals = fans.outward[edges[rows, best]]
    counter = 2 - (best - best % 2)  # the corner vertex's candidates: columns 2, 3 or 0, 1
    vertex_a, vertex_b = verts[:, 0], verts[:, 2]
    apart = np.linalg.norm(blocks.vertices[vertex_a] - blocks.vertices[vertex_b], axis=1)
    found = np.full(len(best), -1)
    for shift in (1, 0):  # the first of the two columns wins
        column = counter + shift
        dot = np.einsum("ij,ij->i", normals, fans.outward[edges[rows, column]])
        face = face_to_face(
            separation[rows, column], dot, depth[rows, column], off[rows, column], apart,
            slack, ANGLE_TOLERANCE,
        ) & ~fake[rows, column]  # fmt: skip
        found = np.where(face, column, found)
    return found


def _shares_line(outward, prv, vertex, other_edge):
    """True when one of ``vertex``'s two edges is parallel to ``other_edge`` with the same
    outward normal (within 0.01 rad; 0.05 let toppling stacks' corners, turned a few
    degrees, pair with the wrong edge and gain 4 % of their energy): the two blocks share
    that boundary line on the same side, so a vertex behind the corner's other edge is
    inside."""
    nx, ny = outward[other_edge, 0], outward[other_edge, 1]
    own = max(
        outward[vertex, 0] * nx + outward[vertex, 1] * ny,
        outward[prv[vertex], 0] * nx + outward[prv[vertex], 1] * ny,
    )
    return own >= SHARED_LINE_COSINE


_shares_line = kernel(_shares_line) or _shares_line  # the compiled resolver calls the twin


def _resolve(
    p1, p2, v, nxt, prv, to_next, to_prev, outward, reflex, parts, known, partners, slack,
    inside, tie, scale, motion,
):  # fmt: skip
    """Compiled :func:`_resolve_vertex_vertex` (the same rules, candidate by candidate)."""
    k = p1.shape[0]
    out_v = np.empty(2 * k, np.int64)  # one pairing each, then the nested corners' second
    out_e = np.empty(2 * k, np.int64)
    out_s = np.empty(2 * k, np.bool_)  # the pairing's vertex shares a line (Detected)
    seconds = 0
    verts = np.empty(4, np.int64)
    edges = np.empty(4, np.int64)
    score = np.empty(4)
    depth = np.empty(4)
    fake = np.empty(4, np.bool_)
    off = np.empty(4, np.bool_)
    tied = np.empty(4, np.bool_)
    line = np.empty(4, np.bool_)
    for i in range(k):
        a, b = p1[i], p2[i]
        verts[0], edges[0] = a, b
        verts[1], edges[1] = a, prv[b]
        verts[2], edges[2] = b, a
        verts[3], edges[3] = b, prv[a]
        for c in range(4):
            vert, ed = verts[c], edges[c]
            nx, ny = outward[ed, 0], outward[ed, 1]
            if reflex[vert]:
                score[c] = -np.inf
            else:
                score[c] = fan_separation(
                    to_next[vert, 0], to_next[vert, 1], to_prev[vert, 0], to_prev[vert, 1], nx, ny
                )
            wx, wy = v[ed, 0] - v[vert, 0], v[ed, 1] - v[vert, 1]
            depth[c] = line_depth(wx, wy, nx, ny)
            ex, ey = v[nxt[ed], 0] - v[ed, 0], v[nxt[ed], 1] - v[ed, 1]
            along = edge_along(-wx, -wy, ex, ey)
            fake[c] = beyond_ends(depth[c], along, slack)
            off[c] = off_edge(along, np.sqrt(ex * ex + ey * ey), slack)
        for first, corner in ((0, b), (2, a)):
            for this, other in ((first, first + 1), (first + 1, first)):
                # the shared line is asked only where it can decide (it costs two dot
                # products; at most corners of a wall the depths are equal)
                deeper = depth[this] - depth[other] > slack
                shared = deeper and _shares_line(outward, prv, verts[this], edges[other])
                fake[this] |= deeper_than_corner(
                    depth[this], depth[other], slack, reflex[corner], shared
                )
        a_inside = inside_corner(depth[0], depth[1], inside)
        b_inside = inside_corner(depth[2], depth[3], inside)
        fake[2] |= a_inside and not b_inside
        fake[3] |= a_inside and not b_inside
        fake[0] |= b_inside and not a_inside
        fake[1] |= b_inside and not a_inside
        if not (fake[0] and fake[1] and fake[2] and fake[3]):
            for c in range(4):
                if fake[c]:
                    score[c] = -np.inf
        top = max(max(score[0], score[1]), max(score[2], score[3]))
        for c in range(4):
            tied[c] = score[c] >= top - tie
            line[c] = False
        if known.shape[0] > 0:
            keep_to_lines_kernel(
                tied, line, verts, edges, depth, v, outward, partners, parts, scale, slack,
                inside, SHARED_LINE_COSINE,
            )  # fmt: skip
        on_edge = False
        for c in range(4):
            on_edge |= tied[c] and not off[c]
        least = np.inf
        for c in range(4):
            tied[c] &= not (on_edge and off[c])
            if tied[c] and depth[c] < least:
                least = depth[c]
        near = 0
        for c in range(4):
            near += tied[c] and depth[c] <= least + inside
        decided = False
        if near > 1 and known.shape[0] > 0:
            was_any = False
            was = np.zeros(4, np.bool_)
            for c in range(4):
                if tied[c] and depth[c] <= least + inside:
                    key = parts[verts[c]] * scale + parts[edges[c]]
                    at = np.searchsorted(known, key)
                    was[c] = at < known.shape[0] and known[at] == key
                    was_any |= was[c]
            if was_any:
                decided = True
                for c in range(4):
                    tied[c] &= was[c]
        if near > 1 and not decided and motion.shape[0] > 0:
            approach = np.zeros(4)
            deepest = 0.0
            for c in range(4):
                if tied[c] and depth[c] <= least + inside:
                    vert, ed = verts[c], edges[c]
                    approach[c] = moving_in(
                        motion[vert, 0], motion[vert, 1], motion[ed, 0], motion[ed, 1],
                        outward[ed, 0], outward[ed, 1],
                    )  # fmt: skip
                    deepest = min(deepest, approach[c])
            for c in range(4):
                if tied[c] and depth[c] <= least + inside:
                    tied[c] &= not enters_less(approach[c], deepest)
        best = 0
        lowest = np.inf
        for c in range(4):
            if tied[c] and depth[c] < lowest:
                lowest = depth[c]
                best = c
        for first, corner in ((0, b), (2, a)):
            if reflex[corner] and max(depth[first], depth[first + 1]) > 0.0:
                best = first if depth[first] >= depth[first + 1] else first + 1
        out_v[i], out_e[i] = verts[best], edges[best]
        out_s[i] = _shares_line(outward, prv, verts[best], edges[best + 1 - 2 * (best % 2)])
        group = best - best % 2
        corner, entering = (b, a) if group == 0 else (a, b)
        other = -1
        if nested_in_corner(
            reflex[corner], reflex[entering], depth[group], depth[group + 1], inside
        ):
            other = group + 1 - best % 2
        elif (v[a, 0] - v[b, 0]) ** 2 + (v[a, 1] - v[b, 1]) ** 2 > slack * slack:
            # corners apart (at most of a wall's they meet: no call made for them)
            other = _face_to_face_kernel(
                best, edges, outward, score, depth, off, fake, slack, v, a, b
            )
        if other >= 0:
            out_v[k + seconds], out_e[k + seconds] = verts[other], edges[other]
            partner = other + 1 - 2 * (other % 2)
            out_s[k + seconds] = _shares_line(outward, prv, verts[other], edges[partner])
            seconds += 1
    return out_v[: k + seconds], out_e[: k + seconds], out_s[: k + seconds]


def _face_to_face_one(best, edges, outward, score, depth, off, fake, slack, v, a, b):
    """Compiled :func:`_face_to_face` of one pair (corners ``a`` and ``b``), from its four
    candidates' ``score`` (the fan separation; −∞ where the vertex is reflex or the
    pairing fake), ``depth``, ``off`` and ``fake``."""
    apart = np.sqrt((v[a, 0] - v[b, 0]) ** 2 + (v[a, 1] - v[b, 1]) ** 2)
    counter = 2 - (best - best % 2)
    chosen = edges[best]
    for column in (counter, counter + 1):
        ed = edges[column]
        dot = outward[chosen, 0] * outward[ed, 0] + outward[chosen, 1] * outward[ed, 1]
        face = face_to_face(
            score[column], dot, depth[column], off[column], apart, slack, ANGLE_TOLERANCE
        )
        if face and not fake[column]:
            return column
    return -1


_face_to_face_kernel = kernel(_face_to_face_one) or _face_to_face_one
_resolve_kernel = kernel(_resolve)


def _off_their_edges(blocks: BlockSet, fans: VertexFans, candidates, along, slack):
    """(k, 4): whether each candidate's vertex projects beyond its edge's ends by more
    than ``slack`` (:func:`off_edge`)."""
    length = np.column_stack(
        [np.linalg.norm(blocks.vertices[fans.next[ed]] - blocks.vertices[ed], axis=1)
         for _, ed in candidates]
    )  # fmt: skip
    return off_edge(along, length, slack)


def _keeping_to_a_line(blocks, fans, verts, edges, depth, tied, slack, inside_depth, last):
    """``tied`` (k, 4), narrowed, where some continue a line their vertex moved along last
    step (an edge it slid along, or an own edge it is passing along over a corner), to
    those and to the tied candidates (``verts`` onto ``edges``) that were closed contacts
    then (each keeps to its own line), where all of them lie along one line
    (:mod:`dda.contact.line_continuation`; ``last``: the last step's)."""
    if last is None or len(last.sliding_vertex) == 0:
        return tied
    partners = previous_partners(blocks, last)
    parts = vertex_key_parts(blocks)
    line = tied & continuing(blocks.vertices, fans.outward, parts, verts, edges, depth, slack,
                             inside_depth, partners, SHARED_LINE_COSINE)  # fmt: skip
    own = tied & np.isin(contact_keys(blocks, verts, edges), last.held_keys)  # closed ones
    line |= own & line.any(axis=1, keepdims=True)
    return keeping_to_one_line(tied, line, fans.outward[edges], SHARED_LINE_COSINE)


def _on_their_edges(off: np.ndarray, tied: np.ndarray) -> np.ndarray:
    """(k, 4) mask: the tied candidates whose vertex projects within the slack of its
    edge (not ``off`` it), where there is one among the tied (else every candidate).
    Without it the last step's pairing won a tie after its vertex had slid past the
    edge's end (a toppling stack: the corner 17 mm beyond it, on the edge's line); the
    pipeline's soundness test then refused it, the corner had no contact for a step and
    entered the other block by 0.4 mm."""
    on_edge = ~off
    usable = (on_edge & tied).any(axis=1, keepdims=True)
    return np.where(usable, on_edge, True)


def _persisting(
    blocks: BlockSet, candidates, tied: np.ndarray, previous_keys
) -> tuple[np.ndarray, np.ndarray]:
    """((k, 4) mask: the tied candidates that were pairings last step, where there is
    one among the tied (else every candidate); (k,): where one was)."""
    keep = np.ones_like(tied)
    decided = np.zeros(len(tied), bool)
    rows = np.flatnonzero(tied.sum(axis=1) > 1)
    if previous_keys is None or len(previous_keys) == 0 or len(rows) == 0:
        return keep, decided
    vert = np.concatenate([c[0][rows] for c in candidates])
    edge = np.concatenate([c[1][rows] for c in candidates])
    was = np.isin(contact_keys(blocks, vert, edge), previous_keys).reshape(4, -1).T
    was &= tied[rows]
    decided[rows] = was.any(axis=1)
    keep[rows] = np.where(decided[rows, None], was, True)
    return keep, decided


def _entering_less(verts, edges, motion, outward, near, decided) -> np.ndarray:
    """(k, 4): the near-tied pairings of the rows that no earlier pairing decided, with
    more than one, that enter their edge by less than half of the deepest entry among
    them (:func:`enters_less`; ``motion``: each vertex's over the coming step)."""
    normal = outward[edges]
    approach = moving_in(
        motion[verts, 0], motion[verts, 1], motion[edges, 0], motion[edges, 1],
        normal[..., 0], normal[..., 1],
    )  # fmt: skip
    open_rows = (near.sum(axis=1) > 1) & ~decided
    considered = near & open_rows[:, None]
    deepest = np.minimum(np.where(considered, approach, 0.0).min(axis=1, keepdims=True), 0.0)
    return considered & enters_less(approach, deepest)


def _depth(blocks: BlockSet, fans: VertexFans, vertex: np.ndarray, edge: np.ndarray):
    """Signed depth of each vertex behind the line of each edge (> 0: inside)."""
    w = blocks.vertices[edge] - blocks.vertices[vertex]
    normal = _outward_normal(blocks, fans, edge)
    return line_depth(w[:, 0], w[:, 1], normal[:, 0], normal[:, 1])


def _shared_lines(fans: VertexFans, candidates) -> np.ndarray:
    """(k, 4): whether the entering vertex of each candidate has an edge along the corner's
    other edge, facing the same way (:func:`_shares_line`): the blocks then lie on the
    same side of that shared boundary line."""
    out = []
    for c, (vert, _) in enumerate(candidates):
        other = candidates[c + 1 if c % 2 == 0 else c - 1][1]
        normal = fans.outward[other]
        own = np.maximum(
            np.einsum("ij,ij->i", fans.outward[vert], normal),
            np.einsum("ij,ij->i", fans.outward[fans.prev[vert]], normal),
        )
        out.append(own >= SHARED_LINE_COSINE)
    return np.column_stack(out)


def _fake_pairings(depth, along, slack: float, reflex_p2, reflex_p1, shared=None) -> np.ndarray:
    """Vertex-vertex candidates whose penetration only an edge's line makes up.

    Columns as in :func:`_resolve_vertex_vertex` (0, 1: the edges at p2; 2, 3: at p1).
    A vertex behind an edge's line but beyond the edge's ends is not in that edge;
    nor is it, at a convex corner, when it is behind that edge's line by more than
    ``slack`` beyond its depth behind the corner's other edge: it lies outside or on
    the other edge (the pipeline's soundness test would refuse the pairing). Two
    fragments meeting along a crack line are the case: each corner lies on the
    other's edge, and behind the line of the edge across the corner by about the
    length they share; choosing that pairing left them with no contact at all.

    Not so when the vertex's own block has an edge along the corner's other edge,
    facing the same way (``shared``, parallel within 0.01 rad): then the two blocks
    lie on the same side of a common boundary line (two fragments' outer faces,
    split from one face of the parent), the vertex slid along it into the other
    block, and its depth behind the corner's edge is a real overlap (the
    fragments' crack faces cross).
    """
    fake = beyond_ends(depth, along, slack)
    if shared is None:
        shared = np.zeros_like(fake)
    for first, reflex in ((0, reflex_p2), (2, reflex_p1)):
        a, b = depth[:, first], depth[:, first + 1]
        fake[:, first] |= deeper_than_corner(a, b, slack, reflex, shared[:, first])
        fake[:, first + 1] |= deeper_than_corner(b, a, slack, reflex, shared[:, first + 1])
    return fake


def _hidden_penetration(depth: np.ndarray, inside_depth: float) -> np.ndarray:
    """Candidates of the vertex that is not inside when the other one is.

    A vertex behind both edge lines at the other vertex by more than
    ``inside_depth`` is inside that block. Pairing the other vertex instead
    (it lies on an edge, d ≈ 0) leaves the overlap with nothing to resist it:
    in a pile of fragments it grew to 0.5 mm over tens of steps, until the
    pairing turned and the augmented Lagrangian pushed it out in one step.
    """
    p1_inside = inside_corner(depth[:, 0], depth[:, 1], inside_depth)
    p2_inside = inside_corner(depth[:, 2], depth[:, 3], inside_depth)
    hidden = np.zeros_like(depth, dtype=bool)
    hidden[:, 2:] = (p1_inside & ~p2_inside)[:, None]
    hidden[:, :2] = (p2_inside & ~p1_inside)[:, None]
    return hidden


def _along(blocks: BlockSet, fans: VertexFans, vertex: np.ndarray, edge: np.ndarray):
    """Position of each vertex's projection along each edge (0 at its start, 1 at its end)."""
    v = blocks.vertices
    e, w = v[fans.next[edge]] - v[edge], v[vertex] - v[edge]
    return edge_along(w[:, 0], w[:, 1], e[:, 0], e[:, 1])


def _opposed_deeper(blocks: BlockSet, fans: VertexFans, vertex: np.ndarray, edge: np.ndarray):
    """Mask of the contacts whose vertex has a contact with another edge of the same
    block that faces the other way (normals at more than 90°) and lies less deep,
    the vertex being behind both edges' lines: it is inside a thin part of that
    block, a wedge near its tip or a sliver, and entered it through the shallower
    edge. (In a notch, where two edges also face each other, a vertex touching one
    wall is in front of the other's line: both contacts stay; and a vertex nested in a
    notch narrower than 90°, behind both walls' lines where they meet at the notch's
    reflex corner, is held by both: they stay.)

    Both contacts would push the vertex across the block, each towards the other
    edge: their forces cancel, the penetration does not shrink however large they
    grow, and the augmented Lagrangian raised them without bound. In the tunnel
    case a vertex touching one edge of a sliver (d ≈ 3e-7 m) got a fresh contact
    2.3 mm deep on the sliver's other edge, whose normal is at 169° to the first;
    within one step the pair's forces reached 1e11 N at penalties of 5e13 N/m, and
    the step they settled in released 8e7 J.
    """
    drop = np.zeros(len(vertex), bool)
    if len(vertex) < 2:
        return drop
    group = vertex.astype(np.int64) * blocks.count + blocks.vertex_owner[edge]
    _, inverse, counts = np.unique(group, return_inverse=True, return_counts=True)
    shared = np.flatnonzero(counts[inverse] > 1)
    if len(shared) == 0:
        return drop
    shared = shared[np.argsort(group[shared], kind="stable")]
    first, second = _pairs_within_groups(group[shared])
    normal = _outward_normal(blocks, fans, edge[shared])
    depth = _depth(blocks, fans, vertex[shared], edge[shared])
    facing = np.einsum("ij,ij->i", normal[first], normal[second])
    a, b = edge[shared][first], edge[shared][second]
    nested = meet_at_reflex(a, fans.next[a], b, fans.next[b], fans.reflex[a], fans.reflex[b])
    drop[shared[first[deeper_of_opposed(depth[first], depth[second], facing, nested)]]] = True
    drop[shared[second[deeper_of_opposed(depth[second], depth[first], facing, nested)]]] = True
    return drop


def _pairs_within_groups(sorted_group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first, second) positions of every pair of rows with the same group (sorted)."""
    starts = np.flatnonzero(np.r_[True, sorted_group[1:] != sorted_group[:-1]])
    sizes = np.diff(np.r_[starts, len(sorted_group)])
    owner, local = expand_counts(sizes * sizes)
    first = starts[owner] + local // sizes[owner]
    second = starts[owner] + local % sizes[owner]
    later = first < second
    return first[later], second[later]


def _pairings(vertex, edge, v, nxt, reflex, owner, outward, count):
    """Compiled :func:`_first_of_each`, then the rows :func:`_opposed_deeper` keeps: the
    same rows, in the same (ascending) order."""
    if vertex.shape[0] == 0:
        return np.zeros(0, np.int64)
    rows = _first_rows(vertex * (edge.max() + 1) + edge)
    group = vertex[rows] * count + owner[edge[rows]]
    by_group = np.argsort(group, kind="mergesort")
    drop = np.zeros(rows.shape[0], np.bool_)
    start = 0
    while start < by_group.shape[0]:
        end = start + 1
        while end < by_group.shape[0] and group[by_group[end]] == group[by_group[start]]:
            end += 1
        for a in range(start, end):
            for b in range(a + 1, end):
                i, j = by_group[a], by_group[b]
                _drop_deeper_if_opposed(
                    rows[i], rows[j], i, j, vertex, edge, v, nxt, reflex, outward, drop
                )
        start = end
    return rows[~drop]


def _first_rows(key):
    """Ascending rows of each key's first occurrence (``np.unique``'s return_index)."""
    order = np.argsort(key, kind="mergesort")
    first = np.zeros(key.shape[0], np.bool_)
    for p in range(key.shape[0]):
        first[order[p]] = p == 0 or key[order[p]] != key[order[p - 1]]
    return np.flatnonzero(first)


def _drop_deeper_if_opposed(row_i, row_j, i, j, vertex, edge, v, nxt, reflex, outward, drop):
    """Of one vertex's two pairings with edges of one block facing opposite ways, both
    behind their lines, mark the deeper one (:func:`_opposed_deeper`)."""
    ei, ej, p = edge[row_i], edge[row_j], vertex[row_i]
    facing = outward[ei, 0] * outward[ej, 0] + outward[ei, 1] * outward[ej, 1]
    di = line_depth(v[ei, 0] - v[p, 0], v[ei, 1] - v[p, 1], outward[ei, 0], outward[ei, 1])
    dj = line_depth(v[ej, 0] - v[p, 0], v[ej, 1] - v[p, 1], outward[ej, 0], outward[ej, 1])
    nested = meet_at_reflex(ei, nxt[ei], ej, nxt[ej], reflex[ei], reflex[ej])
    if deeper_of_opposed(di, dj, facing, nested):
        drop[i] = True
    elif deeper_of_opposed(dj, di, facing, nested):
        drop[j] = True


_first_rows = kernel(_first_rows) or _first_rows
_drop_deeper_if_opposed = kernel(_drop_deeper_if_opposed) or _drop_deeper_if_opposed
_pairings_kernel = kernel(_pairings)


def _first_of_each(vertex: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """Indices keeping one row per (vertex, edge) pair."""
    if len(vertex) == 0:
        return np.zeros(0, dtype=np.int64)
    key = vertex.astype(np.int64) * (int(edge.max()) + 1) + edge  # one integer per pair
    _, first = np.unique(key, return_index=True)  # first occurrence of each
    return np.sort(first)


_detect_kernel = kernel(_detect)
