"""One contact refresh per step: broad phase, narrow phase, carry-over."""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.contact.broad import KeptPairs, candidate_pairs
from dda.contact.candidate_tests import geometrically_sound
from dda.contact.contact_set import (
    CARRIED,
    KEY_SCALE,
    ContactSet,
    contact_keys,
    merge,
    merge_kernel,
    merged_set,
    rows_in,
    vertex_key_parts,
)
from dda.contact.line_continuation import last_step
from dda.contact.narrow import OUTSIDE_FRACTION, _detect_kernel, detect, detect_arguments
from dda.contact.point_distance import _distances_kernel, block_polygons, point_distances
from dda.contact.refresh_arguments import (
    CarriedFields,
    NarrowInput,
    NewContacts,
    Refreshed,
    SiftRules,
)
from dda.contact.rows import _edge_geometry_kernel, edge_geometry
from dda.jit import compiled, kernel
from dda.result import LOCKED, OPEN


def refresh_contacts(
    blocks: BlockSet,
    previous: ContactSet,
    settings,
    kept_pairs: KeptPairs | None = None,
    gap: float | None = None,
    motion: np.ndarray | None = None,
) -> ContactSet:
    """Contacts at the start of a step, keeping what persists from ``previous``.

    A contact seen for the first time can be no deeper than the search
    distance (nothing moves further in one step): a deeper "penetration" is a
    vertex paired with the far side of a block. Persisting contacts may be
    deeper (a soft penalty lets blocks sink). Pairings that only an edge's
    extended line makes look like contacts are dropped (see
    ``geometrically_sound`` and ``_blocks_touch``), and so are new pairings
    deeper behind their edge's line than the vertex is from the block's boundary
    (by more than the contact tolerance): the vertex is nearer another edge, and
    the depth would push it out by far more than its overlap (fresh fracture
    fragments: 4.8e-4 m against 2.5e-8 m). Not so a vertex-vertex pairing whose
    vertex's block has an edge along the corner's other edge, facing the same way
    (``Detected.shared_line``): the two blocks share that boundary line, the edge
    the vertex is nearer is the one its own edge lies along, and its depth behind
    the paired edge is the overlap of the faces that meet there (two pieces of one
    fracture whose crack ends on the parent's face: refused, the crack end had no
    contact after its pairing passed from one piece's corner to the other's, and the
    crack faces overlapped by 1.5e-3 m² in 17 steps). Every contact's shear
    reference point is moved under its vertex: shear motion is measured from
    the step start, and the shear force carried from the last step is the
    contact's ``shear_multiplier`` (:mod:`dda.contact.law`). ``kept_pairs``: the
    run's broad-phase list, kept between steps (the same pairs as a new search,
    found faster). ``gap``: the widest gap a new or open contact may have
    (default the search distance; :mod:`dda.contact.reach`). ``motion``: each vertex's
    motion over the coming step, which decides the vertex-vertex ties nothing else does
    (:func:`dda.contact.narrow.detect`; None: unknown).
    """
    if kept_pairs is None:
        pairs = candidate_pairs(blocks, settings.search_distance)
    else:
        pairs = kept_pairs.pairs(blocks, settings.search_distance)
    if len(pairs) and compiled(_refresh_kernel):
        return _refresh_compiled(blocks, previous, settings, pairs, gap, motion)
    found = detect(
        blocks,
        pairs,
        settings.search_distance,
        settings.vertex_radius,
        settings.law.tolerance,
        previous.key,
        gap,
        last_step(previous),
        motion,
    )
    tolerance, slack = settings.touch_tolerance, OUTSIDE_FRACTION * settings.search_distance
    sift = _sift_compiled if compiled(_sift_kernel) else _sift_numpy
    sifted = sift(
        blocks, found, previous.key, settings.search_distance, slack, tolerance,
        settings.law.tolerance,
    )  # fmt: skip
    return _touching_and_merged(blocks, previous, settings, found.vertex, found.edge, *sifted)


def _touching_and_merged(blocks, previous, settings, vertex, edge, penetration, parameter, keys,
                         previous_rows, plausible, to_block, asked) -> ContactSet:  # fmt: skip
    """The step's contacts from the sifted pairings: the shapely test, then the merge."""
    tolerance = settings.touch_tolerance
    # the shapely test last, on the pairings still plausible (on the 100 x 100 wall
    # ~24,000 deep new pairings a step fail the tests above; it would check 10,000)
    plausible &= _blocks_touch(blocks, vertex, edge, to_block, asked, tolerance)
    vertex, edge = vertex[plausible], edge[plausible]
    penetration, parameter = penetration[plausible], parameter[plausible]
    contacts = merge(
        previous,
        blocks,
        vertex,
        edge,
        initial_penetration=penetration,
        initial_penalty=settings.initial_penalty,
        initial_parameter=parameter,
        touch_tolerance=settings.touch_tolerance,
        keys=keys[plausible],
        previous_rows=previous_rows[plausible],
    )
    contacts.reference = parameter  # shear motion is measured from the step start
    contacts.penetration = penetration
    return contacts


def _sift_numpy(blocks, found, previous_keys, search, slack, tolerance, depth_tolerance):
    """(penetration, parameter, keys, rows in the last step's set, plausible, distance
    to the edge's block, the pairings asked of :func:`_blocks_touch`) of the pairings
    found: the tests of :func:`refresh_contacts` before the shapely one (the nearer-edge
    test not on pairings along a shared line, ``found.shared_line``)."""
    penetration, parameter, far = edge_geometry(blocks, found.vertex, found.edge)
    keys = contact_keys(blocks, found.vertex, found.edge)
    previous_rows = rows_in(keys, previous_keys)
    persisting = previous_rows >= 0
    # a contact within ``slack`` of its edge, penetrating less than ``slack``, passes the
    # soundness tests by construction (distance to the block <= to the edge <= slack)
    doubtful = (far > slack) | (penetration > slack)
    new_and_deep = ~persisting & (penetration > tolerance)
    boundary, to_block = _distances_where(blocks, found.vertex, found.edge, doubtful | new_and_deep)
    plausible = persisting | (penetration <= search)
    plausible &= ~doubtful | geometrically_sound(
        far, penetration, boundary, to_block, tolerance, slack
    )
    nearer = penetration > boundary + depth_tolerance  # another edge is nearer
    plausible &= ~new_and_deep | found.shared_line | ~nearer
    asked = new_and_deep & plausible
    return penetration, parameter, keys, previous_rows, plausible, to_block, asked


def _sift_compiled(blocks, found, previous_keys, search, slack, tolerance, depth_tolerance):
    """:func:`_sift_numpy` in one compiled call (:func:`_sift`)."""
    return _sift_kernel(
        found.vertex.astype(np.int64),
        found.edge.astype(np.int64),
        found.shared_line.astype(np.bool_),
        np.ascontiguousarray(blocks.vertices, dtype=np.float64),
        blocks.next_vertex.astype(np.int64),
        blocks.vertex_owner.astype(np.int64),
        blocks.offsets.astype(np.int64),
        vertex_key_parts(blocks),
        np.asarray(previous_keys, dtype=np.int64),
        float(search),
        float(slack),
        float(tolerance),
        float(depth_tolerance),
    )


def _sift(vertex, edge, shared, v, nxt, owner, offsets, parts, previous_keys, search, slack,
          tolerance, depth_tolerance):  # fmt: skip
    """Compiled :func:`_sift_numpy`: the same tests, pairing by pairing."""
    penetration, parameter, far = _edge_geometry_kernel(v, vertex, edge, nxt)
    m = vertex.shape[0]
    order = np.argsort(previous_keys, kind="mergesort")
    known = previous_keys[order]
    keys = np.empty(m, np.int64)
    previous_rows = np.full(m, -1, np.int64)
    doubtful, new_and_deep = np.empty(m, np.bool_), np.empty(m, np.bool_)
    for k in range(m):
        keys[k] = parts[vertex[k]] * KEY_SCALE + parts[edge[k]]
        at = np.searchsorted(known, keys[k])
        if at < known.shape[0] and known[at] == keys[k]:
            previous_rows[k] = order[at]
        doubtful[k] = far[k] > slack or penetration[k] > slack
        new_and_deep[k] = previous_rows[k] < 0 and penetration[k] > tolerance
    rows = np.flatnonzero(doubtful | new_and_deep)
    boundary, to_block = np.full(m, np.nan), np.full(m, np.nan)
    if rows.shape[0]:
        points = np.empty((rows.shape[0], 2))
        for i in range(rows.shape[0]):
            points[i, 0], points[i, 1] = v[vertex[rows[i]], 0], v[vertex[rows[i]], 1]
        near, inside = _distances_kernel(points, owner[edge[rows]], offsets, v)
        for i in range(rows.shape[0]):
            boundary[rows[i]], to_block[rows[i]] = near[i], inside[i]
    plausible = np.empty(m, np.bool_)
    asked = np.zeros(m, np.bool_)
    for k in range(m):
        keep = previous_rows[k] >= 0 or penetration[k] <= search
        if doubtful[k]:
            keep = keep and geometrically_sound(
                far[k], penetration[k], boundary[k], to_block[k], tolerance, slack
            )
        if new_and_deep[k] and not shared[k]:
            keep = keep and penetration[k] <= boundary[k] + depth_tolerance
        plausible[k] = keep
        asked[k] = new_and_deep[k] and keep
    return penetration, parameter, keys, previous_rows, plausible, to_block, asked


_sift_kernel = kernel(_sift)


def _refresh_compiled(blocks, previous, settings, pairs, gap, motion=None) -> ContactSet:
    """:func:`refresh_contacts` after its broad phase in one compiled call
    (:func:`_refresh`); from the shapely test on in Python when a pairing asks for it."""
    search, depth = settings.search_distance, settings.law.tolerance
    last = last_step(previous)
    arguments = detect_arguments(
        blocks, pairs, search, settings.vertex_radius, depth, previous.key, gap, last, motion
    )
    narrow = NarrowInput(*arguments)
    rules = SiftRules(
        np.asarray(previous.key, dtype=np.int64),
        float(OUTSIDE_FRACTION * search),
        float(settings.touch_tolerance),
        float(depth),
    )
    carried = CarriedFields(*(getattr(previous, name) for name in CARRIED))
    out = _refresh_kernel(
        narrow, rules, carried, NewContacts(float(settings.initial_penalty), LOCKED, OPEN)
    )
    if out.touch_asked:
        return _touching_and_merged(
            blocks, previous, settings, out.vertex, out.edge, out.penetration, out.parameter,
            out.keys, out.previous_rows, out.plausible, out.to_block, out.asked,
        )  # fmt: skip
    contacts = merged_set(blocks.vertex_owner, out.vertex, out.edge, out.keys, out.carried)
    contacts.reference = out.parameter  # shear motion is measured from the step start
    contacts.penetration = out.penetration
    return contacts


def _refresh(narrow, rules, carried, new):
    """Compiled :func:`refresh_contacts` after its broad phase: the narrow phase
    (:func:`dda.contact.narrow._detect`), the tests of :func:`_sift` and the merge with
    the last step's set (:func:`dda.contact.contact_set._merge`), the same calls with
    the same arguments as the stages make one by one, so the same contacts to the bit.

    ``narrow``, ``rules``, ``carried``, ``new``: a
    :class:`~dda.contact.refresh_arguments.NarrowInput`, ``SiftRules``,
    ``CarriedFields`` and ``NewContacts``. Returns a
    :class:`~dda.contact.refresh_arguments.Refreshed`: ``touch_asked`` when a pairing
    needs the shapely test of :func:`_blocks_touch` (the pairings are then all those
    found, the merge not made: its fields empty, and the caller goes on from the
    tests); else the pairings are the plausible ones, merged.
    """
    n = narrow
    vertex, edge, _, shared = _detect_kernel(
        n.pairs, n.offsets, n.vertices, n.next_vertex, n.previous_vertex, n.owner, n.area,
        n.parts, n.known, n.partner_ptr, n.partner_edges, n.held, n.motion, n.vertex_radius,
        n.search, n.gap, n.inside,
    )  # fmt: skip
    penetration, parameter, keys, previous_rows, plausible, to_block, asked = _sift_kernel(
        vertex, edge, shared, n.vertices, n.next_vertex, n.owner, n.offsets, n.parts,
        rules.previous_keys, n.search, rules.slack, rules.touch_tolerance,
        rules.depth_tolerance,
    )  # fmt: skip
    touch_asked = False
    for k in range(vertex.shape[0]):  # _blocks_touch's test: asked, outside the block
        touch_asked = touch_asked or (asked[k] and to_block[k] > rules.touch_tolerance)
    keep = np.arange(vertex.shape[0]) if touch_asked else np.flatnonzero(plausible)
    merged = keep[:0] if touch_asked else keep
    c = carried
    fields = merge_kernel(
        c.state, c.normal_multiplier, c.shear_multiplier, c.penalty, c.reference,
        c.slide_direction, c.intact, c.normal_force, c.shear_force, c.penetration,
        previous_rows[merged], penetration[merged], parameter[merged], new.initial_penalty,
        rules.touch_tolerance, new.locked, new.open_,
    )  # fmt: skip
    return Refreshed(
        touch_asked, vertex[keep], edge[keep], penetration[keep], parameter[keep], keys[keep],
        previous_rows[keep], plausible[keep], to_block[keep], asked[keep], fields,
    )  # fmt: skip


_refresh_kernel = kernel(_refresh)


def _distances_where(blocks, vertex, edge, needed) -> tuple[np.ndarray, np.ndarray]:
    """Distances of each vertex to its edge's block boundary and to the block (0 inside),
    computed where ``needed`` (NaN elsewhere)."""
    boundary, to_block = np.full(len(vertex), np.nan), np.full(len(vertex), np.nan)
    rows = np.flatnonzero(needed)
    boundary[rows], to_block[rows] = point_distances(
        blocks, blocks.vertices[vertex[rows]], blocks.vertex_owner[edge[rows]]
    )
    return boundary, to_block


def _blocks_touch(blocks, vertex, edge, to_block, asked, tolerance) -> np.ndarray:
    """False for a pairing that claims to penetrate two blocks that are apart.

    ``asked``: the pairings seen for the first time that claim more than the
    touch ``tolerance`` of penetration. Near a corner a vertex outside a block can
    lie "behind" the extended line of one of its edges: 0.2 mm apart, 0.5 mm
    of penetration in a pile of fragments. Enforcing it launches the block
    (2 d/Δt after Shi's velocity update). Such a pairing is kept only when its
    two blocks touch or overlap: its vertex is inside the other block
    (``to_block``), or the blocks' shapely distance is within the tolerance.
    """
    keep = np.ones(len(vertex), dtype=bool)
    if not asked.any():
        return keep
    check = np.flatnonzero(asked & (to_block > tolerance))
    if len(check) == 0:
        return keep
    owners = np.column_stack([blocks.vertex_owner[vertex[check]], blocks.vertex_owner[edge[check]]])
    rows, local = np.unique(owners.ravel(), return_inverse=True)
    polygons = block_polygons(blocks, rows)[local.reshape(-1, 2)]
    keep[check] = shapely.distance(polygons[:, 0], polygons[:, 1]) <= tolerance
    return keep


def pair_count(contacts: ContactSet) -> int:
    """Number of distinct block pairs in contact."""
    if not len(contacts):
        return 0
    return len(np.unique(np.column_stack([contacts.block_a, contacts.block_b]), axis=0))
