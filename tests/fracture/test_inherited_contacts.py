"""A block that breaks hands its contacts to its pieces (dda.fracture.inherited_contacts):
at the same places, with the forces, states, bonds and shear references they had."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import dda
from dda.contact.contact_set import ContactSet
from dda.contact.pipeline import refresh_contacts
from dda.contact.rows import contact_rows
from dda.effects.base import StepContext
from dda.fracture.fragments import parent_rows
from dda.fracture.inherited_contacts import after_breaking
from dda.model import build
from dda.result import LOCKED, SLIDING
from tests.fracture.test_run import C0, CASE, ROCK, STRONG, T0, platen_scene, rect
from tests.standing.checks import run_checked

CTX = StepContext(dt=0.01, time=0.5, step=7, static=True)


def stacked() -> dict:
    """A breakable 1.6 x 4 block on a fixed base, a narrower block on top: the block's
    bottom corners touch the base's top edge, the top block's corners its top edge."""
    return {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 1},
        "materials": {"rock": STRONG, "plain": ROCK},
        "joints": {"crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack"},
        "blocks": [
            {"name": "base", "material": "plain", "fixed": True, "vertices": rect(-1, -1, 3, 0)},
            {"name": "a", "material": "rock", "vertices": rect(0, 0, 1.6, 4)},
            {"name": "top", "material": "plain", "vertices": rect(0.2, 4, 1.4, 5)},
        ],
    }


def marked(contacts: ContactSet) -> ContactSet:
    """The contacts with a distinct force, penalty, state, bond and reference each."""
    out = contacts.copy()
    m = len(out)
    out.normal_multiplier = 1e3 * (1.0 + np.arange(m))
    out.shear_multiplier = -7.0 * (1.0 + np.arange(m))
    out.penalty = 1e9 + np.arange(m)
    out.state = np.where(np.arange(m) % 2 == 0, SLIDING, LOCKED).astype(np.int8)
    out.intact = np.arange(m) % 3 == 0
    out.reference = np.full(m, 0.3)
    out.fresh[:] = False
    return out


def broken_in_tension():
    """(old blocks, contacts, new blocks): the stack's block a split by a vertical crack."""
    model = build(dda.load_scene(stacked()))
    blocks = model.blocks.copy()
    contacts = marked(refresh_contacts(blocks, ContactSet.empty(), model.contact))
    blocks.stress[blocks.names.index("a")] = [1.5 * T0, 0.0, 0.0]  # cut along x = 0.8
    new, events = model.fracture.after_step(blocks, CTX)
    assert [(e.parent, e.mode, len(e.children)) for e in events] == [("a", "tension", 2)]
    return blocks, contacts, new


def test_the_pieces_carry_the_parents_contacts_at_the_same_places():
    old, contacts, new = broken_in_tension()
    a = old.names.index("a")
    handed = np.flatnonzero((contacts.block_a == a) | (contacts.block_b == a))
    assert len(handed) == 4  # a's corners on the base, the top block's corners on a
    after = after_breaking(contacts, old, new, parent_rows(old, new))
    assert len(after) == len(contacts)  # none lost, none made
    for row in handed:
        same = np.flatnonzero(after.normal_multiplier == contacts.normal_multiplier[row])
        assert len(same) == 1
        k = int(same[0])
        for name in ("shear_multiplier", "penalty", "state", "intact"):
            assert getattr(after, name)[k] == getattr(contacts, name)[row], name
        assert not after.fresh[k]
        # the vertex is the same point; the edge lies along the same line, holding it
        np.testing.assert_allclose(
            new.vertices[after.vertex[k]], old.vertices[contacts.vertex[row]], atol=1e-12
        )
        start, end = _edge(old, contacts.edge[row]), _edge(new, after.edge[k])
        for point in end:
            assert _off_line(point, *start) < 1e-12
        t = _along(new.vertices[after.vertex[k]], *end)
        assert -1e-12 <= t <= 1 + 1e-12
        # the shear reference point keeps its place
        reference = start[0] + 0.3 * (start[1] - start[0])
        np.testing.assert_allclose(
            end[0] + after.reference[k] * (end[1] - end[0]), reference, atol=1e-12
        )
        names = {new.names[after.block_a[k]], new.names[after.block_b[k]]}
        assert names & {"a/1", "a/2"} and names & {"base", "top"}
    assert np.array_equal(
        np.sort(after.key), np.unique(after.key)
    )  # one contact a vertex-edge pair


def _edge(blocks, start: int) -> tuple[np.ndarray, np.ndarray]:
    owner = blocks.vertex_owner[start]
    after = start + 1 if start + 1 < blocks.offsets[owner + 1] else blocks.offsets[owner]
    return blocks.vertices[start], blocks.vertices[after]


def _off_line(point, p2, p3) -> float:
    u = (p3 - p2) / np.linalg.norm(p3 - p2)
    r = point - p2
    return abs(r[0] * u[1] - r[1] * u[0])


def _along(point, q2, q3) -> float:
    return float(np.dot(point - q2, q3 - q2) / np.dot(q3 - q2, q3 - q2))


@pytest.mark.parametrize("dt", [1e-4, 2.5e-5])
def test_the_platens_force_goes_on_through_the_step_that_breaks_the_rock(dt):
    """The rock between frictionless platens, loaded at 1.02 C0 and in equilibrium from
    t = 0 (the contacts' multipliers carry the load), breaks in shear at step 1. The
    bottom platen's force is the load before the break and on the pieces right after it
    (the same contacts, to 1e-9). Before, the pieces' contacts started unloaded (no force
    at the break) and the force at the next step was 0.70 of the load at Δt = 1e-4; now
    0.989 (within 2 %: the pieces move apart, their cracks starting unloaded, and at
    Δt = 2.5e-5 break again at step 2)."""
    raw = platen_scene(1.02, steps=3)
    raw["analysis"].update(mode="dynamic", time_step=dt)
    result = run_checked(raw)  # finite, no overlap, no energy made
    assert result.fracture_events[0].step == 1
    forces = [_bottom_force(frame) for frame in result.frames[:3]]
    assert forces[0] == pytest.approx(1.02 * C0 * 1.6, rel=1e-6)
    assert forces[1] == pytest.approx(forces[0], rel=1e-9)
    if dt == 1e-4:
        assert forces[2] == pytest.approx(forces[0], rel=0.02)


def _bottom_force(frame: dda.Frame) -> float:
    bottom = frame.names.index("bottom")
    c = frame.contacts
    on = (np.asarray(c.block_a) == bottom) | (np.asarray(c.block_b) == bottom)
    return float(np.asarray(c.normal_force)[on].sum())


def test_a_cascade_of_breaks_with_inherited_contacts_makes_no_energy():
    """The paper's Fig. 3 on frictionless platens at three times its load, Δt = 2.5e-5 s
    to 4 ms: 49 breaks, each handing its contacts to the pieces; at every step the
    energy stays within E0 + W, no contact is deeper than the tolerance allows and the
    blocks' area is kept (tests/standing/checks.py)."""
    raw = tomllib.loads(CASE.read_text())
    for load in raw["loads"]:
        load["force"] = [3.0 * f for f in load["force"]]
    raw["joints"]["default"]["friction_angle"] = 0.0
    raw["analysis"].update(time_step=2.5e-5, steps=160, save_every=1)
    result = run_checked(raw)
    assert len(result.fracture_events) > 20


def test_a_contact_where_a_crack_ends_goes_to_the_piece_along_its_edge():
    """A 2 × 2 block under a wider block, split by tension along its diagonal from (0, 0)
    to (2, 2): both pieces have the corners (0, 0) and (2, 2). The corner (2, 2) on the top
    block's edge goes to the piece whose edge there lies along that edge (its length 1 m,
    as the parent's), not to the first piece, whose edges there are a side and the crack
    (it took the contact with 1.41 m of length and 41 % more cohesion and tension)."""
    raw = stacked()
    raw["blocks"][1]["vertices"] = rect(0, 0, 2, 2)
    raw["blocks"][2]["vertices"] = rect(-0.5, 2, 2.5, 3)
    model = build(dda.load_scene(raw))
    blocks = model.blocks.copy()
    contacts = marked(refresh_contacts(blocks, ContactSet.empty(), model.contact))
    s = 3.0 * T0
    blocks.stress[blocks.names.index("a")] = [s / 2, s / 2, -s / 2]  # σ3 along (1, −1)
    new, events = model.fracture.after_step(blocks, CTX)
    assert [(e.mode, len(e.children)) for e in events] == [("tension", 2)]
    after = after_breaking(contacts, blocks, new, parent_rows(blocks, new))
    rows = contact_rows(new, after)
    top = new.names.index("top")
    for c in np.flatnonzero(after.block_b == top):
        piece = after.block_a[c]
        ring = new.vertices[new.offsets[piece] : new.offsets[piece + 1]]
        assert np.any(np.all(np.isclose(ring, [0.0, 2.0]), axis=1))  # the top edge's piece
        assert rows.length[c] == pytest.approx(1.0)
