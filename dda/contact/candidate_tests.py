"""The narrow phase's tests of a candidate contact, and the vertex-edge geometry they
and the contact rows measure, each written once.

Every function here is a :func:`dda.jit.formula`: the numpy narrow phase
(:mod:`dda.contact.narrow`) and contact rows (:mod:`dda.contact.rows`) call it on
arrays of candidates or contacts, their compiled twins on one candidate's numbers,
compiling the same function in. Only arithmetic, comparisons, ``&``, ``|``,
``np.minimum``, ``np.maximum``, ``np.sqrt`` and ``np.logical_not`` are used, which
mean the same on both.

Notation (:mod:`dda.contact.narrow`'s notes): a vertex P1 and the counter-clockwise
edge P2P3 of the other block, e = P3 − P2, w = P1 − P2, l = |e|; n the edge's unit
outward normal; u_next, u_prev the unit vectors along the two edges leaving P1 (its
fan).
"""

from __future__ import annotations

import numpy as np

from dda.jit import formula

# of the smaller block's size √A: the deepest a vertex may be behind an edge's line and
# still be a vertex-edge candidate, where that is more than the search distance
DEPTH_OF_SIZE = 0.3


@formula
def edge_parameter(wx, wy, ex, ey, length):
    """t = w·e / l²: where P1 projects along the edge (0 at P2, 1 at P3)."""
    return (wx * ex + wy * ey) / length**2


@formula
def edge_depth(wx, wy, ex, ey, length):
    """d = (e × w) / l: how far P1 is behind the edge's line (> 0: on the block's side;
    paper eq. 9)."""
    return (ex * wy - ey * wx) / length


@formula
def segment_distance(wx, wy, ex, ey, t):
    """|w − clip(t, 0, 1) e|: P1's distance from the edge segment."""
    along = np.minimum(np.maximum(t, 0.0), 1.0)
    rx, ry = wx - along * ex, wy - along * ey
    return np.sqrt(rx * rx + ry * ry)


@formula
def deepest_candidate(search, area_a, area_b):
    """max(search, 0.3 √min(A_a, A_b)): the deepest a vertex-edge candidate may be."""
    return np.maximum(search, DEPTH_OF_SIZE * np.sqrt(np.minimum(area_a, area_b)))


@formula
def projects_inside(t, edge_end):
    """P1 projects inside the edge, more than ``edge_end`` of it from either end."""
    return (t > edge_end) & (t < 1.0 - edge_end)


@formula
def within_reach(depth, gap, deepest):
    """−gap ≤ d ≤ deepest: at most ``gap`` outside the edge's line, at most ``deepest``
    behind it."""
    return (depth >= -gap) & (depth <= deepest)


@formula
def closes_on(wx, wy, mx, my, radius):
    """min over τ in [0, 1] of |w + τ m| ≤ radius: P1, moving by m against P2 over the
    coming step (m = m_P1 − m_P2, the two vertices' motions), comes within ``radius`` of
    P2 (two corners that meet head-on within the step)."""
    squared = np.maximum(mx * mx + my * my, 1e-300)
    tau = np.minimum(np.maximum(-(wx * mx + wy * my) / squared, 0.0), 1.0)
    rx, ry = wx + tau * mx, wy + tau * my
    return rx * rx + ry * ry <= radius * radius


@formula
def beside_corner(wx, wy, next_x, next_y, prev_x, prev_y, edge_end):
    """A point at w from a corner C projects inside neither of C's edges (by more than
    ``edge_end`` of it, :func:`edge_parameter`), (next) and (prev) the vectors from C to
    its two neighbours: it faces the corner, not a face."""
    along_next = edge_parameter(wx, wy, next_x, next_y, np.sqrt(next_x * next_x + next_y * next_y))
    along_prev = edge_parameter(wx, wy, prev_x, prev_y, np.sqrt(prev_x * prev_x + prev_y * prev_y))
    inside = projects_inside(along_next, edge_end) | projects_inside(along_prev, edge_end)
    return np.logical_not(inside)


@formula
def enters_corner(wx, wy, mx, my, next_x, next_y, prev_x, prev_y):
    """P1, at w from a corner P2 and moving by m against it, lies outside the line of one
    of P2's edges and moves into it ((next), (prev): the vectors from P2 to its
    neighbours; the block counter-clockwise): the sign of :func:`edge_depth` of w and of
    m behind the edge from P2 to its next corner, and behind the one from its previous
    corner, taken from P2 along −prev (the same line)."""
    outside_next = edge_depth(wx, wy, next_x, next_y, 1.0) < 0.0
    into_next = edge_depth(mx, my, next_x, next_y, 1.0) > 0.0
    outside_prev = edge_depth(wx, wy, -prev_x, -prev_y, 1.0) < 0.0
    into_prev = edge_depth(mx, my, -prev_x, -prev_y, 1.0) > 0.0
    return (outside_next & into_next) | (outside_prev & into_prev)


@formula
def corners_meet(wx, wy, mx, my, radius, b_next, b_prev, a_next, a_prev, edge_end):
    """Corner P1, at w from corner P2 of the other block and moving by m against it over
    the coming step, meets it head-on within the step: each from outside an edge line at
    the other moves into it (:func:`enters_corner`: not a corner beyond a block) and comes
    within ``radius`` of P2 (:func:`closes_on`), while neither corner faces an edge of the
    other (:func:`beside_corner`: that is a vertex-edge candidate). ``b_next``, ``b_prev``:
    the vectors (x, y) from P2 to its neighbours; ``a_next``, ``a_prev``: from P1 to its."""
    meet = closes_on(wx, wy, mx, my, radius)
    meet = meet & enters_corner(wx, wy, mx, my, b_next[0], b_next[1], b_prev[0], b_prev[1])
    meet = meet & enters_corner(-wx, -wy, -mx, -my, a_next[0], a_next[1], a_prev[0], a_prev[1])
    faces_b = beside_corner(wx, wy, b_next[0], b_next[1], b_prev[0], b_prev[1], edge_end)
    faces_a = beside_corner(-wx, -wy, a_next[0], a_next[1], a_prev[0], a_prev[1], edge_end)
    return meet & faces_b & faces_a


@formula
def fan_separation(next_x, next_y, prev_x, prev_y, nx, ny):
    """min(u_next·n, u_prev·n): ≥ 0 when P1's fan stays outside the edge's line."""
    return np.minimum(next_x * nx + next_y * ny, prev_x * nx + prev_y * ny)


@formula
def fan_clears(separation, angle_tolerance):
    """The angle test: neither edge of P1 dips into the edge by more than the angle whose
    sine is ``angle_tolerance``."""
    return separation >= -angle_tolerance


@formula
def line_depth(wx, wy, nx, ny):
    """(P2 − P1)·n with (wx, wy) = P2 − P1: P1's depth behind the edge's line (> 0:
    inside), by the edge's outward normal (the vertex-vertex resolution's measure)."""
    return wx * nx + wy * ny


@formula
def beyond_ends(depth, along, slack):
    """Behind the edge's line by more than ``slack`` while projecting beyond its ends
    (``along`` < 0 or > 1): only the line makes up the penetration."""
    return (depth > slack) & ((along < 0.0) | (along > 1.0))


@formula
def deeper_than_corner(depth, other_depth, slack, reflex_corner, shares_line):
    """At a convex corner, behind this edge's line by more than ``slack`` beyond the depth
    behind the corner's other edge (P1 lies outside or on that other edge), unless P1's
    block has an edge along the other one, facing the same way (``shares_line``)."""
    convex = np.logical_not(reflex_corner)
    return convex & (depth - other_depth > slack) & np.logical_not(shares_line)


@formula
def inside_corner(depth, other_depth, inside_depth):
    """Behind both edge lines at the other vertex by more than ``inside_depth``: inside
    that block."""
    return np.minimum(depth, other_depth) > inside_depth


@formula
def nested_in_corner(corner_reflex, vertex_reflex, depth, other_depth, inside_depth):
    """A convex vertex nested at a reflex corner of the other block: it is held by both
    of the corner's edges (it is inside once it is behind either line), so it is paired
    with both. Paired with one, it entered the block through the other within a step
    (a wedge nested in a horseshoe's floor corner: 7.8 mm at every other step).

    Nested: in front of both lines (``depth``, ``other_depth`` within ``inside_depth``),
    or behind both (in the block, past the corner). Not a vertex behind one line only:
    across a floor or wall thinner than the vertex radius, outside the block, where the
    other edge's line is a phantom wall (a block sliding under a 1 cm floor hit it)."""
    in_front = (depth <= inside_depth) & (other_depth <= inside_depth)
    behind = (depth > inside_depth) & (other_depth > inside_depth)
    return corner_reflex & np.logical_not(vertex_reflex) & (in_front | behind)


@formula
def face_to_face(separation, normal_dot, depth, off, apart, slack, angle_tolerance):
    """The other end of a face-to-face contact that a vertex-vertex pair stands for: the
    corner vertex (its fan clears the edge, ``separation`` ≥ −``angle_tolerance``) onto
    the entering vertex's edge that faces the chosen pairing's edge (``normal_dot``, of
    their unit outward normals, within that angle of −1), where the corner lies over
    that edge (not ``off`` it), at most ``slack`` in front of its line (``depth``), and
    more than ``slack`` from the entering vertex (``apart``: corners that meet need one
    contact). Two blocks whose faces overlap by less than the vertex radius are such a
    pair; held at one end only, the face turned about it and the other corner entered
    the block (the tunnel's falling debris: 1.5e-4 m² over 45 steps, no contact)."""
    facing = normal_dot <= -np.sqrt(1.0 - angle_tolerance * angle_tolerance)
    near = (depth >= -slack) & np.logical_not(off) & (apart > slack)
    return facing & fan_clears(separation, angle_tolerance) & near


@formula
def along_one_line(normal_dot, cosine):
    """Two edges through one point lie along one line: their unit outward normals
    parallel or opposed (|``normal_dot``| at least ``cosine``)."""
    return np.abs(normal_dot) >= cosine


@formula
def continues_line(nx, ny, other_nx, other_ny, dx, dy, depth, slack, inside_depth, cosine):
    """A vertex-vertex candidate (a vertex onto an edge of unit outward normal (nx, ny))
    that continues the line of an edge the vertex was paired with last step (normal
    (other_nx, other_ny)): the two face the same way (their normals' dot product at least
    ``cosine``), this edge's start, (dx, dy) from the other's, lies within ``slack`` of
    the other's line, and the vertex is on it (``depth`` behind it between −``slack`` and
    ``inside_depth``). A corner sliding along a face onto the next block's face of the
    same line (a block crossing the flush joint of two base blocks) stays on that line
    (:mod:`dda.contact.line_continuation`)."""
    same_way = nx * other_nx + ny * other_ny >= cosine
    offset = dx * other_nx + dy * other_ny
    on_line = same_way & (np.abs(offset) <= slack)
    return on_line & (depth >= -slack) & (depth <= inside_depth)


@formula
def passing_corner(dx, dy, slack):
    """The corner (dx, dy) from a vertex that slid under the vertex's own edge last step
    lies within ``slack`` of it: the vertex is passing over that corner, and its edge's
    line goes on past it (:mod:`dda.contact.line_continuation`)."""
    return dx * dx + dy * dy <= slack * slack


@formula
def off_edge(along, length, slack):
    """P1 projects beyond the edge's ends by more than ``slack`` (m)."""
    return np.maximum(-along, along - 1.0) * length > slack


@formula
def deeper_of_opposed(depth, other_depth, normal_dot, nested):
    """Of one vertex's two contacts with edges of one block facing opposite ways
    (``normal_dot`` < 0), both behind their lines: True for the deeper one (it entered
    a thin part of the block through the other edge). Not where the two edges meet at a
    reflex corner of the block (``nested``, :func:`meet_at_reflex`): the vertex is
    nested in a notch narrower than 90° and is held by both."""
    opposed = (normal_dot < 0.0) & (depth > 0.0) & (other_depth > 0.0)
    return opposed & (depth > other_depth) & np.logical_not(nested)


@formula
def meet_at_reflex(first, next_of_first, second, next_of_second, reflex_first, reflex_second):
    """Edges ``first`` and ``second`` of one block (numbered by their start vertices) are
    consecutive and the vertex they share is reflex."""
    return ((next_of_first == second) & reflex_second) | ((next_of_second == first) & reflex_first)


@formula
def edge_along(wx, wy, ex, ey):
    """w·e / e·e with (wx, wy) = P1 − P2: where P1 projects along the edge (the
    vertex-vertex resolution's measure; :func:`edge_parameter` divides by l² of the
    computed length, the screen's)."""
    return (wx * ex + wy * ey) / (ex * ex + ey * ey)


@formula
def geometrically_sound(far, penetration, boundary, to_block, tolerance, slack):
    """False for a pairing that only the edge's extended line makes look like a contact.

    * A vertex behind the edge's line must be about as near the edge (``far``) as it is
      to the edge block's whole boundary (``boundary``, within ``slack``): a vertex lying
      on one edge of a block (a T-junction, a corner) is not also "behind" another edge
      of that block. In front of the line (``penetration`` ≤ 0) it is a gap the vertex
      may close, however near another edge is: a corner sliding along a floor into a
      reflex corner faces the wall there (with the test, its contact with the wall was
      dropped while it was more than ``slack`` away, and at 6 mm a step it crossed the
      wall by 2.9 mm).
    * A vertex that penetrates more than ``tolerance`` must lie inside the block
      (``to_block`` within ``slack``).
    """
    near_enough = (far <= boundary + slack) | (penetration <= 0.0)
    inside = (penetration <= tolerance) | (to_block <= slack)
    return near_enough & inside


@formula
def moving_in(motion_x, motion_y, edge_motion_x, edge_motion_y, nx, ny):
    """(m_P1 − m_edge)·n: how far the vertex moves into the edge's line over the coming
    step, against the edge's own block (< 0: it enters), m the motions of the two."""
    return (motion_x - edge_motion_x) * nx + (motion_y - edge_motion_y) * ny


@formula
def enters_less(approach, deepest):
    """A tied pairing left out for another that enters: it enters by less than half of
    the deepest entry ``deepest`` (< 0) among the tied, or not at all."""
    return (deepest < 0.0) & (approach > 0.5 * deepest)
