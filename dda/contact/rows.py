"""Linearised contact distances (paper eqs. 9-13) for all contacts at once.

Normal: d = S0/l + E D_i + G D_j, penetration positive, with
e_r = [(y2-y3) t1r(P1) + (x3-x2) t2r(P1)] / l and
g_r = [(y3-y1) t1r(P2) + (x1-x3) t2r(P2) + (y1-y2) t1r(P3) + (x2-x1) t2r(P3)] / l.

Shear: s = s0 + Es D_i + Gs D_j, the position of P1 along the edge
direction t = (P3-P2)/l relative to the reference point P0 = P2 + r (P3-P2)
of the edge: s0 = (P1-P0)·t, Es = tᵀ T_i(P1), Gs = -tᵀ T_j(P0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.contact.candidate_tests import edge_depth, edge_parameter, segment_distance
from dda.contact.contact_set import ContactSet
from dda.jit import compiled, kernel
from dda.kinematics import displacement_matrices


@dataclass
class ContactRows:
    """Gap values at the step start and their gradients with respect to D."""

    penetration: np.ndarray  # S0 / l at the step start, > 0 is overlap (m,)
    normal_i: np.ndarray  # E (m, 6)
    normal_j: np.ndarray  # G (m, 6)
    slip: np.ndarray  # s0, position of P1 from the reference point (m,)
    shear_i: np.ndarray  # Es (m, 6)
    shear_j: np.ndarray  # Gs (m, 6)
    parameter: np.ndarray  # projection of P1 on the edge, in [0, 1] along P2->P3
    normals: np.ndarray  # (m, 2) unit normal out of the edge's block
    tangents: np.ndarray  # (m, 2) unit edge direction
    length: np.ndarray  # contact length carried by the vertex (for c and T)
    points: np.ndarray  # (m, 2) P1


def edge_geometry(blocks: BlockSet, vertex: np.ndarray, edge: np.ndarray):
    """(d, t, r) of each vertex P1 and edge P2P3: penetration d = (P3-P2)×(P1-P2)/l,
    parameter t = (P1-P2)·(P3-P2)/l² and distance r = |P1 - P2 - clip(t, 0, 1)(P3-P2)|
    from the edge segment."""
    nxt = blocks.next_vertex
    if compiled(_edge_geometry_kernel):
        return _edge_geometry_kernel(
            np.ascontiguousarray(blocks.vertices, dtype=np.float64),
            np.asarray(vertex, dtype=np.int64),
            np.asarray(edge, dtype=np.int64),
            nxt.astype(np.int64),
        )
    p1, p2, p3 = blocks.vertices[vertex], blocks.vertices[edge], blocks.vertices[nxt[edge]]
    e = p3 - p2
    length = np.linalg.norm(e, axis=1)
    w = p1 - p2
    d = edge_depth(w[:, 0], w[:, 1], e[:, 0], e[:, 1], length)
    t = edge_parameter(w[:, 0], w[:, 1], e[:, 0], e[:, 1], length)
    return d, t, segment_distance(w[:, 0], w[:, 1], e[:, 0], e[:, 1], t)


def _edge_geometry(v, vertex, edge, nxt):
    """Compiled :func:`edge_geometry`."""
    m = vertex.shape[0]
    d, t, r = np.empty(m), np.empty(m), np.empty(m)
    for c in range(m):
        p, q = vertex[c], edge[c]
        ex, ey = v[nxt[q], 0] - v[q, 0], v[nxt[q], 1] - v[q, 1]
        wx, wy = v[p, 0] - v[q, 0], v[p, 1] - v[q, 1]
        length = np.sqrt(ex * ex + ey * ey)
        d[c] = edge_depth(wx, wy, ex, ey, length)
        t[c] = edge_parameter(wx, wy, ex, ey, length)
        r[c] = segment_distance(wx, wy, ex, ey, t[c])
    return d, t, r


_edge_geometry_kernel = kernel(_edge_geometry)


def gaps_after(
    rows: ContactRows, block_a: np.ndarray, block_b: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Penetration d = S0/l + E D_a + G D_b and shear position s = s0 + Es D_a + Gs D_b
    of every contact after the step D (n, 6) (eqs. 9-13, linearised)."""
    if compiled(_gaps_kernel):
        return _gaps_kernel(
            rows.penetration,
            rows.slip,
            rows.normal_i,
            rows.normal_j,
            rows.shear_i,
            rows.shear_j,
            np.asarray(block_a, dtype=np.int64),
            np.asarray(block_b, dtype=np.int64),
            np.ascontiguousarray(d, dtype=np.float64),
        )
    da, db = d[block_a], d[block_b]
    pen = (
        rows.penetration
        + np.einsum("mr,mr->m", rows.normal_i, da)
        + np.einsum("mr,mr->m", rows.normal_j, db)
    )
    slip = (
        rows.slip
        + np.einsum("mr,mr->m", rows.shear_i, da)
        + np.einsum("mr,mr->m", rows.shear_j, db)
    )
    return pen, slip


def _gaps(pen0, slip0, normal_i, normal_j, shear_i, shear_j, block_a, block_b, d):
    """Compiled :func:`gaps_after`: one pass over the contacts."""
    m = pen0.shape[0]
    pen = np.empty(m)
    slip = np.empty(m)
    for c in range(m):
        a, b = block_a[c], block_b[c]
        p, s = pen0[c], slip0[c]
        for r in range(6):
            p += normal_i[c, r] * d[a, r] + normal_j[c, r] * d[b, r]
            s += shear_i[c, r] * d[a, r] + shear_j[c, r] * d[b, r]
        pen[c], slip[c] = p, s
    return pen, slip


_gaps_kernel = kernel(_gaps)


def contact_rows(blocks: BlockSet, contacts: ContactSet) -> ContactRows:
    """E, G, Es, Gs and the gaps of every contact at the current positions."""
    v = blocks.vertices
    nxt, prv = blocks.next_vertex, blocks.previous_vertex
    if compiled(_rows_kernel):
        rows = _contact_rows_compiled(blocks, contacts, nxt, prv)
        rows.length = carried_once(
            v, contacts.vertex, contacts.block_b, nxt, prv, rows.tangents, rows.length
        )
        return rows
    i, j = contacts.block_a, contacts.block_b
    p1, p2, p3 = v[contacts.vertex], v[contacts.edge], v[nxt[contacts.edge]]
    ci, cj = blocks.centroid[i], blocks.centroid[j]
    e = p3 - p2
    length = np.linalg.norm(e, axis=1)
    tangent = e / length[:, None]
    inward = np.column_stack([-tangent[:, 1], tangent[:, 0]])

    t1 = displacement_matrices(p1, ci)
    t2 = displacement_matrices(p2, cj)
    t3 = displacement_matrices(p3, cj)
    normal_i = np.einsum("mk,mkr->mr", inward, t1)
    a2 = np.column_stack([p3[:, 1] - p1[:, 1], p1[:, 0] - p3[:, 0]])
    a3 = np.column_stack([p1[:, 1] - p2[:, 1], p2[:, 0] - p1[:, 0]])
    normal_j = (np.einsum("mk,mkr->mr", a2, t2) + np.einsum("mk,mkr->mr", a3, t3)) / length[:, None]
    w = p1 - p2
    penetration = (e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0]) / length

    p0 = p2 + contacts.reference[:, None] * e
    shear_i = np.einsum("mk,mkr->mr", tangent, t1)
    shear_j = -np.einsum("mk,mkr->mr", tangent, displacement_matrices(p0, cj))
    slip = np.einsum("mk,mk->m", p1 - p0, tangent)

    return ContactRows(
        penetration=penetration,
        normal_i=normal_i,
        normal_j=normal_j,
        slip=slip,
        shear_i=shear_i,
        shear_j=shear_j,
        parameter=np.einsum("ij,ij->i", w, e) / length**2,
        normals=-inward,
        tangents=tangent,
        length=carried_once(
            v,
            contacts.vertex,
            contacts.block_b,
            nxt,
            prv,
            tangent,
            _carried_length(v, contacts.vertex, nxt, prv, tangent),
        ),  # fmt: skip
        points=p1,
    )


def _contact_rows_compiled(blocks, contacts, nxt, prv) -> ContactRows:
    """:func:`contact_rows` in one compiled pass over the contacts."""
    out = _empty_rows(len(contacts.vertex))
    _rows_kernel(
        np.ascontiguousarray(blocks.vertices, dtype=np.float64),
        np.ascontiguousarray(blocks.centroid, dtype=np.float64),
        nxt.astype(np.int64),
        prv.astype(np.int64),
        np.asarray(contacts.vertex, dtype=np.int64),
        np.asarray(contacts.edge, dtype=np.int64),
        np.asarray(contacts.block_a, dtype=np.int64),
        np.asarray(contacts.block_b, dtype=np.int64),
        np.asarray(contacts.reference, dtype=np.float64),
        out.penetration,
        out.normal_i,
        out.normal_j,
        out.slip,
        out.shear_i,
        out.shear_j,
        out.parameter,
        out.normals,
        out.tangents,
        out.length,
        out.points,
    )
    return out


def _empty_rows(m: int) -> ContactRows:
    """:class:`ContactRows` arrays for m contacts (zeros: the kernel adds into the rows).

    The normal and shear gradients of each side are the two halves of one
    (2, m, 6) array, which the assembly then takes as it is, without a copy
    (:func:`dda.solve.assembly.stacked`).
    """
    gradient_i, gradient_j = np.zeros((2, m, 6)), np.zeros((2, m, 6))
    arrays = {name: np.zeros(m) for name in ContactRows.__dataclass_fields__}
    arrays |= {name: np.zeros((m, 2)) for name in ("normals", "tangents", "points")}
    arrays |= {"normal_i": gradient_i[0], "shear_i": gradient_i[1]}
    arrays |= {"normal_j": gradient_j[0], "shear_j": gradient_j[1]}
    return ContactRows(**arrays)


def _project(row, k, nx, ny, px, py, cx, cy, scale):
    """row[k] += scale · (nx, ny)ᵀ T(p, c) (paper eq. 2), T of point p, centroid c."""
    dx, dy = px - cx, py - cy
    row[k, 0] += scale * nx
    row[k, 1] += scale * ny
    row[k, 2] += scale * (ny * dx - nx * dy)
    row[k, 3] += scale * nx * dx
    row[k, 4] += scale * ny * dy
    row[k, 5] += scale * 0.5 * (nx * dy + ny * dx)


_project = kernel(_project) or _project  # the compiled rows kernel calls the compiled twin


def _rows(
    v,
    centroid,
    nxt,
    prv,
    vertex,
    edge,
    block_a,
    block_b,
    reference,
    penetration,
    normal_i,
    normal_j,
    slip,
    shear_i,
    shear_j,
    parameter,
    normals,
    tangents,
    carried,
    points,
):
    """Compiled :func:`contact_rows`: the same formulas, one contact at a time
    (the four row arrays come zeroed)."""
    for c in range(vertex.shape[0]):
        p, q = vertex[c], edge[c]
        x1, y1 = v[p, 0], v[p, 1]
        x2, y2 = v[q, 0], v[q, 1]
        x3, y3 = v[nxt[q], 0], v[nxt[q], 1]
        cix, ciy = centroid[block_a[c], 0], centroid[block_a[c], 1]
        cjx, cjy = centroid[block_b[c], 0], centroid[block_b[c], 1]
        ex, ey = x3 - x2, y3 - y2
        length = np.sqrt(ex * ex + ey * ey)
        tx, ty = ex / length, ey / length
        wx, wy = x1 - x2, y1 - y2
        _project(normal_i, c, -ty, tx, x1, y1, cix, ciy, 1.0)
        _project(normal_j, c, y3 - y1, x1 - x3, x2, y2, cjx, cjy, 1.0)
        _project(normal_j, c, y1 - y2, x2 - x1, x3, y3, cjx, cjy, 1.0)
        for r in range(6):  # (a2 T2 + a3 T3) / l, in numpy's order
            normal_j[c, r] /= length
        penetration[c] = (ex * wy - ey * wx) / length
        x0, y0 = x2 + reference[c] * ex, y2 + reference[c] * ey
        _project(shear_i, c, tx, ty, x1, y1, cix, ciy, 1.0)
        _project(shear_j, c, tx, ty, x0, y0, cjx, cjy, -1.0)
        slip[c] = (x1 - x0) * tx + (y1 - y0) * ty
        parameter[c] = (wx * ex + wy * ey) / (length * length)
        normals[c, 0], normals[c, 1] = ty, -tx
        tangents[c, 0], tangents[c, 1] = tx, ty
        points[c, 0], points[c, 1] = x1, y1
        ax, ay = v[nxt[p], 0] - x1, v[nxt[p], 1] - y1
        bx, by = v[prv[p], 0] - x1, v[prv[p], 1] - y1
        la, lb = np.sqrt(ax * ax + ay * ay), np.sqrt(bx * bx + by * by)
        ca = abs(ax * tx + ay * ty) / (la if la > 0 else 1.0)
        cb = abs(bx * tx + by * ty) / (lb if lb > 0 else 1.0)
        carried[c] = 0.5 * (la if ca >= cb else lb)


_rows_kernel = kernel(_rows)


# the cosine of the largest angle between a vertex's own edge and a contact edge along
# which that own edge still counts as lying (for the second of two contacts that would
# carry the same own edge: :func:`carried_once`)
ALONG = math.cos(math.radians(10.0))


def carried_once(
    v: np.ndarray,
    vertex: np.ndarray,
    block_b: np.ndarray,
    nxt: np.ndarray,
    prv: np.ndarray,
    tangents: np.ndarray,
    carried: np.ndarray,
) -> np.ndarray:
    """``carried`` where a vertex has two contacts with one block (a corner nested in a
    reflex corner: one contact on each edge there): each carries half of the own edge
    that lies along its edge (within 10°), each own edge once, else nothing.

    A single contact carries half the vertex's own edge best aligned with its edge
    (:func:`_carried_length`), however far from it. Two would count one own edge twice,
    or count an edge that touches nothing: a square on a base with a 2° kink under its
    corner had 1.5 m of bonded length for 1 m, and held 1.7 times its cohesion's load;
    with a 60° kink, 1.5 m too. Where both contacts' own edge is the same, the better
    aligned contact carries it (the earlier row on a tie).

    A declared pair: :func:`_carried_once` (one pass linking each vertex's contacts,
    compiled; 2.7 µs on the 5 × 5 wall's 90 contacts, 88 µs on the 100 × 100 wall's
    40,000, AMD EPYC) and :func:`_carried_once_numpy` (a sort; 8.3 and 531 µs), checked
    against each other by ``tests/contact/test_rows.py``.
    """
    if compiled(_carried_once_kernel):
        return _carried_once_kernel(
            np.ascontiguousarray(v, dtype=np.float64),
            np.asarray(vertex, dtype=np.int64),
            np.asarray(block_b, dtype=np.int64),
            np.asarray(nxt, dtype=np.int64),
            np.asarray(prv, dtype=np.int64),
            np.ascontiguousarray(tangents, dtype=np.float64),
            np.asarray(carried, dtype=np.float64),
            ALONG,
        )
    return _carried_once_numpy(v, vertex, block_b, nxt, prv, tangents, carried)


def _carried_once_numpy(v, vertex, block_b, nxt, prv, tangents, carried):
    """:func:`carried_once` on arrays: the pairs found by a sort on (vertex, block)."""
    order = np.lexsort((block_b, vertex))
    same = (np.diff(vertex[order]) == 0) & (np.diff(block_b[order]) == 0)
    if not same.any():
        return carried
    first, second = order[:-1][same], order[1:][same]
    k = len(first)
    pair = np.concatenate([first, second])
    own = np.stack([v[nxt[vertex[pair]]], v[prv[vertex[pair]]]]) - v[vertex[pair]]
    lengths = np.linalg.norm(own, axis=2)
    cosine = np.abs(np.einsum("kij,ij->ki", own, tangents[pair])) / np.where(
        lengths > 0, lengths, 1.0
    )
    along = cosine >= ALONG  # (2, 2k): own edge (next, previous) along the contact's edge
    choice = np.where(cosine[0] >= cosine[1], 0, 1)
    rows = np.arange(2 * k)
    partner = np.concatenate([rows[k:], rows[:k]])
    better = cosine[choice, rows] > cosine[choice[partner], partner]
    better |= (cosine[choice, rows] == cosine[choice[partner], partner]) & (rows < k)
    # an own edge the partner also chose and carries better goes to the partner
    ceded = (choice == choice[partner]) & along[choice, partner] & ~better
    choice = np.where(ceded, 1 - choice, choice)
    out = carried.copy()
    out[pair] = np.where(along[choice, rows], 0.5 * lengths[choice, rows], 0.0)
    return out


def _carried_once(v, vertex, block_b, nxt, prv, tangents, carried, along):
    """:func:`carried_once`: each vertex's contacts linked in one pass, then each pair of
    them with one block shares the vertex's two own edges."""
    out = carried.copy()
    head = np.full(v.shape[0], -1, np.int64)
    link = np.full(vertex.shape[0], -1, np.int64)  # the vertex's previous contact
    for c in range(vertex.shape[0]):
        link[c] = head[vertex[c]]
        head[vertex[c]] = c
    for c in range(vertex.shape[0]):
        d = link[c]
        while d >= 0:
            if block_b[d] == block_b[c]:
                _share_own_edges(v, vertex[c], d, c, nxt, prv, tangents, out, along)
            d = link[d]
    return out


def _share_own_edges(v, p, first, second, nxt, prv, tangents, out, along):
    """The lengths ``first`` and ``second``, two contacts of vertex ``p`` with one block,
    carry (:func:`carried_once`)."""
    ax, ay = v[nxt[p], 0] - v[p, 0], v[nxt[p], 1] - v[p, 1]
    bx, by = v[prv[p], 0] - v[p, 0], v[prv[p], 1] - v[p, 1]
    la, lb = np.sqrt(ax * ax + ay * ay), np.sqrt(bx * bx + by * by)
    ca1 = abs(ax * tangents[first, 0] + ay * tangents[first, 1]) / (la if la > 0 else 1.0)
    cb1 = abs(bx * tangents[first, 0] + by * tangents[first, 1]) / (lb if lb > 0 else 1.0)
    ca2 = abs(ax * tangents[second, 0] + ay * tangents[second, 1]) / (la if la > 0 else 1.0)
    cb2 = abs(bx * tangents[second, 0] + by * tangents[second, 1]) / (lb if lb > 0 else 1.0)
    next1, next2 = ca1 >= cb1, ca2 >= cb2  # each contact's best aligned own edge
    if next1 == next2:  # the same one: the better aligned keeps it, the other cedes it
        if max(ca1, cb1) >= max(ca2, cb2):
            next2 = not next2 if (ca1 if next1 else cb1) >= along else next2
        else:
            next1 = not next1 if (ca2 if next2 else cb2) >= along else next1
    c1, c2 = (ca1 if next1 else cb1), (ca2 if next2 else cb2)
    out[first] = 0.5 * (la if next1 else lb) if c1 >= along else 0.0
    out[second] = 0.5 * (la if next2 else lb) if c2 >= along else 0.0


_share_own_edges = kernel(_share_own_edges) or _share_own_edges  # compiled into the next
_carried_once_kernel = kernel(_carried_once)


def _carried_length(v, vertex, nxt, prv, tangent):
    """Half the vertex's own edge that lies along the contact edge (for c·l, T·l)."""
    a = v[nxt[vertex]] - v[vertex]
    b = v[prv[vertex]] - v[vertex]
    la, lb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    ca = np.abs(np.einsum("ij,ij->i", a, tangent)) / np.where(la > 0, la, 1)
    cb = np.abs(np.einsum("ij,ij->i", b, tangent)) / np.where(lb > 0, lb, 1)
    return 0.5 * np.where(ca >= cb, la, lb)
