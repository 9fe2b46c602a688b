"""Corner pairs at a node that other blocks separate: no contact between them.

Where blocks tessellate the plane around a node (four blocks of a wall, the
wedges where joints cross), every two of their corners there lie within the
vertex radius of each other, and each such pair used to become a
vertex-vertex contact. Two blocks that meet only at the node, with other
blocks' corners filling the angle between them on both sides (the diagonal
neighbours of a wall), cannot reach each other without pushing those blocks
aside: the contacts with the blocks in between carry every force. The
contact between them is a spurious load path: its penetration is measured
against the line of an edge the corner never touches, so it pushes or pulls
as the node deforms and cycles open and closed against the contacts that do
carry the load. Measured before it was dropped:

- cases/verify/node.toml (two columns of two blocks, the upper row pushed
  sideways, frictionless): 46 % of the load went down through the node into
  a lower block that equilibrium (and the FEM) leaves unloaded;
- the rock masses of cases/: such contacts carried up to 1.0 MN (tunnel,
  134 of them closed at the end) and 1.9 MN (slope), against median contact
  forces of 0.16 and 0.60 MN;
- the walls of ``dda bench``: 2 of the 6 contacts at every inner node; the
  solves per step fell from 8.2 to 4.7 (10x10) and from 10.4 to 6.6 (30x30)
  without them.

Angles at a vertex of a counter-clockwise polygon: its wedge runs
counter-clockwise from the direction of the edge leaving it (``to_next``) to
the direction back along the edge reaching it (``to_prev``). For the corners
x and y of a pair, the two angular gaps between their wedges are
g1 = ccw(end x, start y) and g2 = ccw(end y, start x) (one of them is 0 for
neighbours sharing an edge; where their wedges overlap a little, as when one
of them turned, it comes out near 2π, which no other wedges can fill). The
pair is separated when both gaps are wider than ``ANGLE_FILL`` and each is
filled, to within ``ANGLE_FILL``, by the wedges of the other corners paired
with x or y (those whose bisector lies in the gap, of blocks other than x's
and y's). A node with a void in either gap keeps the pair: a corner may move
into the void and reach the other block. So does a loose node: every corner
counted (x, y and the mates filling the gaps) must lie within ``tight`` (the
contact tolerance) of x and of y. Among fragments that have moved apart by
a millimetre, corners paired within the vertex radius do not fill each
other's gaps, and dropping such pairs let fragments of the pile in
tests/standing run into each other (steps gaining up to 5e4 J).
"""

from __future__ import annotations

import numpy as np

from dda.geometry import expand_counts
from dda.jit import compiled, kernel

ANGLE_FILL = 0.05  # rad: a gap left uncovered by less than this counts as filled
TWO_PI = 2.0 * np.pi


def _ccw(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Counter-clockwise angle from direction a to direction b, in [0, 2π)."""
    return np.mod(b - a, TWO_PI)


def wedges(to_next: np.ndarray, to_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start angle, angular span) of every vertex's wedge."""
    start = np.arctan2(to_next[:, 1], to_next[:, 0])
    end = np.arctan2(to_prev[:, 1], to_prev[:, 0])
    return start, _ccw(start, end)


def separated_pairs(
    vertices: np.ndarray,
    owner: np.ndarray,
    to_next: np.ndarray,
    to_prev: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    tight: float,
) -> np.ndarray:
    """Mask of the corner pairs (p1[k], p2[k]) that other blocks separate at their node.

    ``owner``: block of each vertex; ``to_next``, ``to_prev``: unit vectors along
    the edges at each vertex; ``tight``: how close the corners of a node must be.
    Compiled when numba is there, numpy otherwise.
    """
    if len(p1) == 0:
        return np.zeros(0, dtype=bool)
    p1, p2 = p1.astype(np.int64), p2.astype(np.int64)
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    if compiled(separated_corners_kernel):
        own = owner.astype(np.int64)
        return separated_corners_kernel(v, own, to_next, to_prev, p1, p2, tight)
    start, span = wedges(to_next, to_prev)
    indptr, mates = _mates(p1, p2, len(owner))
    return _separated_numpy(v, owner, start, span, p1, p2, indptr, mates, tight)


def _mates(p1, p2, n_vertices):
    """CSR lists of the corners paired with each vertex (both directions)."""
    here = np.concatenate([p1, p2])
    there = np.concatenate([p2, p1])
    order = np.argsort(here, kind="stable")
    indptr = np.zeros(n_vertices + 1, dtype=np.int64)
    np.cumsum(np.bincount(here, minlength=n_vertices), out=indptr[1:])
    return indptr, there[order]


def _near(v, a, b, tight):
    """|v[a] - v[b]| <= tight (arrays of vertex indices, or one index each)."""
    return np.hypot(v[a, 0] - v[b, 0], v[a, 1] - v[b, 1]) <= tight


def _separated_numpy(v, owner, start, span, p1, p2, indptr, mates, tight):
    """:func:`separated_pairs` with numpy: every (pair, mate) combination at once."""
    end_x = start[p1] + span[p1]
    end_y = start[p2] + span[p2]
    g1, g2 = _ccw(end_x, start[p2]), _ccw(end_y, start[p1])
    pair, mate = _pair_mates(p1, p2, indptr, mates)
    x, y = p1[pair], p2[pair]
    other = (owner[mate] != owner[x]) & (owner[mate] != owner[y])
    other &= _near(v, mate, x, tight) & _near(v, mate, y, tight)
    pair, mate = pair[other], mate[other]
    bisector = start[mate] + 0.5 * span[mate]
    in_first = _ccw(end_x[pair], bisector) < g1[pair]
    in_second = _ccw(end_y[pair], bisector) < g2[pair]
    n = len(p1)
    cover1 = np.bincount(pair, weights=np.where(in_first, span[mate], 0.0), minlength=n)
    cover2 = np.bincount(pair, weights=np.where(in_second, span[mate], 0.0), minlength=n)
    return (
        _near(v, p1, p2, tight)
        & (g1 > ANGLE_FILL)
        & (g2 > ANGLE_FILL)
        & (cover1 >= g1 - ANGLE_FILL)
        & (cover2 >= g2 - ANGLE_FILL)
    )


def _pair_mates(p1, p2, indptr, mates):
    """(pair index, mate) for every mate of either corner of each pair, each mate once."""
    pairs, found = [], []
    for corner in (p1, p2):
        pair, position = expand_counts(indptr[corner + 1] - indptr[corner])
        pairs.append(pair)
        found.append(mates[indptr[corner][pair] + position])
    pair, mate = np.concatenate(pairs), np.concatenate(found)
    _, once = np.unique(pair * len(indptr) + mate, return_index=True)
    return pair[once], mate[once]


def _separated(v, owner, start, span, p1, p2, indptr, mates, tight, fill):
    """Compiled :func:`separated_pairs`: pair by pair, the same arithmetic."""
    n = p1.shape[0]
    out = np.zeros(n, np.bool_)
    two_pi = 2.0 * np.pi
    for k in range(n):
        x, y = p1[k], p2[k]
        if not _near_each(v, x, y, tight):
            continue
        end_x, end_y = start[x] + span[x], start[y] + span[y]
        g1 = (start[y] - end_x) % two_pi
        g2 = (start[x] - end_y) % two_pi
        if g1 <= fill or g2 <= fill:
            continue
        cover1, cover2 = 0.0, 0.0
        for corner in (x, y):
            for j in range(indptr[corner], indptr[corner + 1]):
                q = mates[j]
                if owner[q] == owner[x] or owner[q] == owner[y]:
                    continue
                if not (_near_each(v, q, x, tight) and _near_each(v, q, y, tight)):
                    continue
                if corner == y and _listed(mates, indptr[x], indptr[x + 1], q):
                    continue  # a mate of both corners counts once
                bisector = start[q] + 0.5 * span[q]
                if (bisector - end_x) % two_pi < g1:
                    cover1 += span[q]
                if (bisector - end_y) % two_pi < g2:
                    cover2 += span[q]
        out[k] = cover1 >= g1 - fill and cover2 >= g2 - fill
    return out


def _listed(values, begin, stop, q):
    """True when q is among values[begin:stop]."""
    for j in range(begin, stop):
        if values[j] == q:
            return True
    return False


_listed = kernel(_listed) or _listed
_near_each = kernel(_near) or _near
_separated_kernel = kernel(_separated)


def _separated_corners(v, owner, to_next, to_prev, p1, p2, tight):
    """Compiled :func:`separated_pairs` from the fans: the wedges, the mates' lists
    (a counting sort, stable as :func:`_mates`'s) and :func:`_separated`, one call."""
    n = v.shape[0]
    start, span = np.empty(n), np.empty(n)
    for k in range(n):
        start[k] = np.arctan2(to_next[k, 1], to_next[k, 0])
        span[k] = (np.arctan2(to_prev[k, 1], to_prev[k, 0]) - start[k]) % TWO_PI
    indptr = np.zeros(n + 1, np.int64)
    for k in range(p1.shape[0]):
        indptr[p1[k] + 1] += 1
        indptr[p2[k] + 1] += 1
    for k in range(n):
        indptr[k + 1] += indptr[k]
    mates = np.empty(2 * p1.shape[0], np.int64)
    filled = indptr[:-1].copy()
    for here, there in ((p1, p2), (p2, p1)):
        for k in range(here.shape[0]):
            mates[filled[here[k]]] = there[k]
            filled[here[k]] += 1
    return _separated_kernel(v, owner, start, span, p1, p2, indptr, mates, tight, ANGLE_FILL)


separated_corners_kernel = kernel(_separated_corners)
