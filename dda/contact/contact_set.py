"""The persistent contact set: one row per (vertex, edge) pair, struct of arrays.

A contact keeps its state, multipliers, penalty and shear reference point
from step to step while the same vertex touches the same edge (matched by a
key built from the blocks' stable ids and local vertex/edge numbers).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from dda.blocks import BlockSet
from dda.jit import compiled, formula, kernel
from dda.result import LOCKED, OPEN

_LOCAL = 1 << 10  # vertices per block allowed in a key
_IDS = 1 << 20  # block ids allowed in a key


@dataclass
class ContactSet:
    """Contacts of the current step.

    vertex, edge : global vertex index of P1 and of the edge's start P2
    block_a, block_b : rows of the vertex's block and of the edge's block
    key : (m,) int64 persistent identity
    state : OPEN / SLIDING / LOCKED
    normal_multiplier, shear_multiplier : λn (compression > 0), λt (AL)
    penalty : per-contact normal penalty p (variable in AL)
    reference : edge parameter of the shear reference point P0 on P2P3
    slide_direction : +1 / -1 sign of sliding along P2->P3 (when sliding)
    intact : cohesion and tensile strength still there (lost once it slips or opens)
    fresh : found this step (no history from the last one)
    normal_force, shear_force, penetration, slip : results of the last solve
        (slip: shear position of P1 from the reference point, along P2->P3)
    """

    vertex: np.ndarray
    edge: np.ndarray
    block_a: np.ndarray
    block_b: np.ndarray
    key: np.ndarray
    state: np.ndarray
    normal_multiplier: np.ndarray
    shear_multiplier: np.ndarray
    penalty: np.ndarray
    reference: np.ndarray
    slide_direction: np.ndarray
    intact: np.ndarray
    fresh: np.ndarray
    normal_force: np.ndarray
    shear_force: np.ndarray
    penetration: np.ndarray
    slip: np.ndarray

    def __len__(self) -> int:
        return len(self.vertex)

    @classmethod
    def empty(cls) -> ContactSet:
        kinds = {"state": np.int8, "intact": bool, "fresh": bool}
        integers = {"vertex", "edge", "block_a", "block_b", "key"}
        return cls(
            **{
                f.name: np.zeros(0, kinds.get(f.name, np.int64 if f.name in integers else float))
                for f in fields(cls)
            }
        )

    def copy(self) -> ContactSet:
        return ContactSet(**{f.name: getattr(self, f.name).copy() for f in fields(self)})

    def subset(self, rows: np.ndarray) -> ContactSet:
        return ContactSet(**{f.name: getattr(self, f.name)[rows] for f in fields(self)})


def joined(first: ContactSet, second: ContactSet) -> ContactSet:
    """The rows of ``first``, then those of ``second``."""
    return ContactSet(
        **{f.name: np.concatenate([getattr(first, f.name), getattr(second, f.name)])
           for f in fields(ContactSet)}
    )  # fmt: skip


def carried_over(
    contacts: ContactSet, old: BlockSet, new: BlockSet, row_of: np.ndarray
) -> ContactSet:
    """The contacts between blocks that stay when ``old`` becomes ``new`` (an excavation,
    a fracture), with their rows and vertex numbers renumbered: ``row_of`` gives each old
    block's new row, −1 for one that is gone (its vertices keep their order)."""
    stays = row_of >= 0
    owner = old.vertex_owner
    local = np.arange(len(owner)) - old.offsets[owner]
    vertex_of = new.offsets[np.maximum(row_of, 0)[owner]] + local
    kept = contacts.subset(np.flatnonzero(stays[contacts.block_a] & stays[contacts.block_b]))
    kept.vertex, kept.edge = vertex_of[kept.vertex], vertex_of[kept.edge]
    kept.block_a, kept.block_b = row_of[kept.block_a], row_of[kept.block_b]
    return kept


def vertex_key_parts(blocks: BlockSet) -> np.ndarray:
    """Per packed vertex: block id x 2**10 + local number, the halves of a contact key;
    kept on ``blocks`` while its ``offsets`` and ``ids`` are the same arrays (like
    :attr:`BlockSet.vertex_owner`)."""
    return blocks.kept("_key_parts", lambda: _key_parts(blocks), blocks.offsets, blocks.ids)


def _key_parts(blocks: BlockSet) -> np.ndarray:
    if blocks.ids.max(initial=0) >= _IDS or np.diff(blocks.offsets).max(initial=0) >= _LOCAL:
        raise ValueError("contact keys need block ids < 2**20 and < 1024 vertices per block")
    owner = blocks.vertex_owner
    return blocks.ids[owner].astype(np.int64) * _LOCAL + (
        np.arange(len(owner)) - blocks.offsets[owner]
    )


KEY_SCALE = _IDS * _LOCAL  # key = part(vertex) x KEY_SCALE + part(edge start)


@formula
def same_block(part, other_part):
    """Two vertices' key parts (:func:`vertex_key_parts`) are of one block."""
    return part // _LOCAL == other_part // _LOCAL


def contact_keys(blocks: BlockSet, vertex: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """Stable int64 key of each (vertex, edge) pair from block ids and local numbers."""
    parts = vertex_key_parts(blocks)
    return parts[vertex] * KEY_SCALE + parts[edge]


def rows_in(keys: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Row of each key in ``known``, -1 where it is not there (keys are unique in both:
    one contact per vertex-edge pair). One sort of ``known`` and a binary search per key."""
    rows = np.full(len(keys), -1, dtype=np.int64)
    if len(keys) == 0 or len(known) == 0:
        return rows
    order = np.argsort(known)
    at = order[np.minimum(np.searchsorted(known, keys, sorter=order), len(known) - 1)]
    found = known[at] == keys
    rows[found] = at[found]
    return rows


# the fields a persisting contact carries from the last step (merge)
CARRIED = (
    "state", "normal_multiplier", "shear_multiplier", "penalty", "reference",
    "slide_direction", "intact", "normal_force", "shear_force", "penetration",
)  # fmt: skip


def merge(
    previous: ContactSet,
    blocks: BlockSet,
    vertex: np.ndarray,
    edge: np.ndarray,
    initial_penetration: np.ndarray,
    initial_penalty: float,
    initial_parameter: np.ndarray,
    touch_tolerance: float,
    keys: np.ndarray | None = None,
    previous_rows: np.ndarray | None = None,
) -> ContactSet:
    """Build this step's set, carrying over what persists from ``previous``.

    New contacts start LOCKED and intact (bonded: the joint's cohesion and tensile
    strength hold) when touching (penetration ≥ -``touch_tolerance``), else OPEN and
    not bonded (a gap has no bond); multipliers 0; penalty ``initial_penalty``; shear
    reference at the vertex's current projection ``initial_parameter``. ``keys``: the pairs'
    :func:`contact_keys`, and ``previous_rows`` their :func:`rows_in` ``previous``,
    when the caller has them already.
    """
    owner = blocks.vertex_owner
    m = len(vertex)
    keys = contact_keys(blocks, vertex, edge) if keys is None else keys
    if previous_rows is not None and compiled(merge_kernel):
        return _merge_compiled(
            previous, owner, vertex, edge, keys, initial_penetration, initial_penalty,
            initial_parameter, touch_tolerance, previous_rows,
        )  # fmt: skip
    touching = np.asarray(initial_penetration) >= -touch_tolerance  # a new bool array
    new = ContactSet(
        vertex=vertex,
        edge=edge,
        block_a=owner[vertex],
        block_b=owner[edge],
        key=keys,
        state=np.where(touching, LOCKED, OPEN).astype(np.int8),
        normal_multiplier=np.zeros(m),
        shear_multiplier=np.zeros(m),
        penalty=np.full(m, float(initial_penalty)),
        reference=np.asarray(initial_parameter, float).copy(),
        slide_direction=np.zeros(m),
        intact=touching,
        fresh=np.ones(m, bool),
        normal_force=np.zeros(m),
        shear_force=np.zeros(m),
        penetration=np.zeros(m),
        slip=np.zeros(m),
    )
    if previous_rows is None:
        previous_rows = rows_in(keys, previous.key)
    new_rows = np.flatnonzero(previous_rows >= 0)
    if len(new_rows):
        old_rows = previous_rows[new_rows]
        for name in CARRIED:
            getattr(new, name)[new_rows] = getattr(previous, name)[old_rows]
        new.fresh[new_rows] = False
    # An open contact has no shear reference yet: measure from the vertex's current
    # projection, so a contact that closes during the step does not start with the
    # slip accumulated since it was first detected (a spurious shear spring force).
    still_open = new.state == OPEN
    new.reference[still_open] = np.asarray(initial_parameter, float)[still_open]
    return new


def _merge_compiled(previous, owner, vertex, edge, keys, penetration, penalty, parameter,
                    touch_tolerance, previous_rows) -> ContactSet:  # fmt: skip
    """:func:`merge` in one compiled call (:func:`_merge`)."""
    carried = merge_kernel(
        *(getattr(previous, name) for name in CARRIED),
        np.asarray(previous_rows, np.int64),
        np.asarray(penetration, np.float64),
        np.asarray(parameter, np.float64),
        float(penalty),
        float(touch_tolerance),
        LOCKED,
        OPEN,
    )
    return merged_set(owner, vertex, edge, keys, carried)


def merged_set(owner, vertex, edge, keys, carried) -> ContactSet:
    """The ContactSet of pairings (``vertex``, ``edge``) with the fields :func:`_merge`
    returns (``carried``: :data:`CARRIED`, then ``fresh``) and no slip yet."""
    return ContactSet(
        vertex=vertex, edge=edge, block_a=owner[vertex], block_b=owner[edge], key=keys,
        slip=np.zeros(len(vertex)), **dict(zip((*CARRIED, "fresh"), carried, strict=True)),
    )  # fmt: skip


def _merge(state, normal_multiplier, shear_multiplier, penalty, reference, slide_direction,
           intact, normal_force, shear_force, penetration, previous_rows, initial_penetration,
           initial_parameter, initial_penalty, touch_tolerance, locked, open_):  # fmt: skip
    """Compiled :func:`merge` (the carried fields and ``fresh``): a new contact as
    :func:`merge` starts it, a persisting one with its last step's fields."""
    m = previous_rows.shape[0]
    new_state, new_intact = np.empty(m, np.int8), np.empty(m, np.bool_)
    fresh = np.empty(m, np.bool_)
    new_normal, new_shear = np.zeros(m), np.zeros(m)
    new_penalty, new_reference, new_direction = np.empty(m), np.empty(m), np.zeros(m)
    new_normal_force, new_shear_force, new_penetration = np.zeros(m), np.zeros(m), np.zeros(m)
    for r in range(m):
        old = previous_rows[r]
        if old < 0:
            touching = initial_penetration[r] >= -touch_tolerance
            new_state[r] = locked if touching else open_
            new_intact[r], fresh[r] = touching, True
            new_penalty[r], new_reference[r] = initial_penalty, initial_parameter[r]
            continue
        new_state[r], new_intact[r], fresh[r] = state[old], intact[old], False
        new_normal[r], new_shear[r] = normal_multiplier[old], shear_multiplier[old]
        new_penalty[r], new_reference[r] = penalty[old], reference[old]
        new_direction[r], new_normal_force[r] = slide_direction[old], normal_force[old]
        new_shear_force[r], new_penetration[r] = shear_force[old], penetration[old]
        if new_state[r] == open_:  # an open contact measures shear from where it is now
            new_reference[r] = initial_parameter[r]
    return (new_state, new_normal, new_shear, new_penalty, new_reference, new_direction,
            new_intact, new_normal_force, new_shear_force, new_penetration, fresh)  # fmt: skip


merge_kernel = kernel(_merge)
