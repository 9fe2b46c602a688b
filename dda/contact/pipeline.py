"""One contact refresh per step: broad phase, narrow phase, carry-over."""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.contact.broad import candidate_pairs
from dda.contact.contact_set import ContactSet, contact_keys, merge
from dda.contact.narrow import detect
from dda.contact.rows import edge_projection
from dda.result import SLIDING

OUTSIDE_FRACTION = 0.01  # of the search distance: a vertex farther out than this penetrates nothing


def refresh_contacts(blocks: BlockSet, previous: ContactSet, settings) -> ContactSet:
    """Contacts at the start of a step, keeping what persists from ``previous``.

    A contact seen for the first time can be no deeper than the search
    distance (nothing moves further in one step): a deeper "penetration" is a
    vertex paired with the far side of a block. Persisting contacts may be
    deeper (a soft penalty lets blocks sink). A penetrating vertex must lie
    inside the other block: beyond the end of an edge, its distance behind the
    edge's extended line is no penetration at all. Sliding contacts get their shear
    reference point moved under the vertex: their slip is measured from the
    step start.
    """
    pairs = candidate_pairs(blocks, settings.search_distance)
    found = detect(blocks, pairs, settings.search_distance, settings.vertex_radius)
    penetration, parameter = edge_projection(blocks, found.vertex, found.edge)
    persisting = np.isin(contact_keys(blocks, found.vertex, found.edge), previous.key)
    plausible = persisting | (penetration <= settings.search_distance)
    plausible &= _inside_when_penetrating(
        blocks,
        found.vertex,
        found.edge,
        penetration,
        settings.touch_tolerance,
        OUTSIDE_FRACTION * settings.search_distance,
    )
    vertex, edge = found.vertex[plausible], found.edge[plausible]
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
    )
    sliding = contacts.state == SLIDING
    contacts.reference[sliding] = parameter[sliding]
    contacts.penetration = penetration
    return contacts


def _inside_when_penetrating(blocks, vertex, edge, penetration, tolerance, outside) -> np.ndarray:
    """False for a vertex that claims to penetrate an edge but lies outside its block.

    "Outside" means farther than ``outside`` from the block: a corner resting
    on a coincident corner sits on the boundary, or just off it after the
    blocks strain, and is a real contact.
    """
    keep = np.ones(len(vertex), dtype=bool)
    deep = np.flatnonzero(penetration > tolerance)
    if len(deep) == 0:
        return keep
    owner = blocks.vertex_owner
    rows, local = np.unique(owner[edge[deep]], return_inverse=True)
    starts = blocks.offsets[rows]
    counts = blocks.offsets[rows + 1] - starts
    take = np.concatenate([np.arange(a, a + c) for a, c in zip(starts, counts, strict=True)])
    rings = shapely.linearrings(
        blocks.vertices[take], indices=np.repeat(np.arange(len(rows)), counts)
    )
    polygons = shapely.polygons(rings)
    points = blocks.vertices[vertex[deep]]
    keep[deep] = shapely.distance(polygons[local], shapely.points(points)) <= outside
    return keep


def pair_count(contacts: ContactSet) -> int:
    """Number of distinct block pairs in contact."""
    if not len(contacts):
        return 0
    return len(np.unique(np.column_stack([contacts.block_a, contacts.block_b]), axis=0))
