"""The compiled contact refresh's arguments and result, named
(:func:`dda.contact.pipeline._refresh`).

Each is a ``NamedTuple``: numba passes them to the compiled refresh as they are, so it
takes four records instead of thirty positional values, and its caller reads the result
by name.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dda.contact.contact_set import CARRIED


class NarrowInput(NamedTuple):
    """The narrow phase's data (:func:`dda.contact.narrow.detect_arguments`)."""

    pairs: np.ndarray  # (q, 2) candidate block pairs
    offsets: np.ndarray  # each block's first vertex
    vertices: np.ndarray  # (N, 2)
    next_vertex: np.ndarray
    previous_vertex: np.ndarray
    owner: np.ndarray  # each vertex's block
    area: np.ndarray  # each block's area
    parts: np.ndarray  # the vertices' key parts (dda.contact.contact_set.vertex_key_parts)
    known: np.ndarray  # the last step's contact keys, sorted
    partner_ptr: np.ndarray  # each vertex's (line, via) rows of the lines it moved along
    partner_edges: np.ndarray  # last step, (k, 2) (line_continuation.previous_partners)
    held: np.ndarray  # the sorted keys of the last step's closed contacts (LastStep)
    motion: np.ndarray  # (N, 2) each vertex's motion over the coming step, or (0, 2)
    vertex_radius: float
    search: float  # the search distance
    gap: float  # the widest gap of a new or open contact
    inside: float  # the depth a contact may have inside its edge's block


class SiftRules(NamedTuple):
    """The tests on the narrow phase's pairings (:func:`dda.contact.pipeline._sift`)."""

    previous_keys: np.ndarray  # the last step's contact keys, in its order
    slack: float  # how far outside an edge a pairing may start
    touch_tolerance: float
    depth_tolerance: float


# The last step's contact fields a persisting contact keeps, named as the contact set
# names them (:data:`dda.contact.contact_set.CARRIED`, in that order).
CarriedFields = NamedTuple("CarriedFields", [(name, np.ndarray) for name in CARRIED])


class NewContacts(NamedTuple):
    """How a contact seen for the first time starts (:func:`dda.contact.contact_set._merge`)."""

    initial_penalty: float
    locked: int  # the state of a new contact that touches
    open_: int  # ... and of one that does not


class Refreshed(NamedTuple):
    """The compiled refresh's pairings, their tests and the merge's fields."""

    touch_asked: bool  # a pairing needs the shapely test: all pairings kept, no merge made
    vertex: np.ndarray
    edge: np.ndarray
    penetration: np.ndarray
    parameter: np.ndarray
    keys: np.ndarray
    previous_rows: np.ndarray  # rows in the last step's set (−1: new)
    plausible: np.ndarray
    to_block: np.ndarray  # distance to the edge's block
    asked: np.ndarray  # the shapely test asked for
    carried: tuple  # the merge's fields (CARRIED, then fresh); empty when touch_asked
