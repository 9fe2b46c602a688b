"""Contacts that keep flipping state within a step are held, and the step settles.

In a jointed rock mass hundreds of contacts touch at forces 1e-3 of the
typical one; their states feed back on each other and the open–close
iteration cycles (period 4 to 12 among a handful of contacts in the slope of
cases/rock_slope.toml) until the step is cut, and cut again. A contact that
flipped ``StateFlips.LIMIT`` times in one step is held closed (sliding) while
its gap (its shear motion) is within the contact tolerance.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from dda.contact import law as contact_law
from dda.contact.contact_set import ContactSet
from dda.result import LOCKED, OPEN, SLIDING
from dda.step import StateFlips, friction_work
from tests.stability.checks import run_checked

CASES = Path(__file__).resolve().parents[2] / "cases"
LAW = contact_law.ContactLaw(augmented=False, tolerance=1e-3, shear_ratio=0.4, friction=True)
JOINT = contact_law.JointProperties(np.full(2, 0.5), np.zeros(2), np.zeros(2))


def two_contacts() -> ContactSet:
    """Contact 0 locked, contact 1 sliding in the +s direction; both squeezed."""
    empty = ContactSet.empty()
    values = {name: np.zeros(2, array.dtype) for name, array in vars(empty).items()}
    values["state"][:] = [LOCKED, SLIDING]
    values["slide_direction"][1] = 1.0
    values["penalty"][:] = 1e6
    return ContactSet(**values)


def apply_law(held=None):
    """Contact 0 pulled apart by 1e-5 m; contact 1 moved back 1e-4 m under a 1e-5 m squeeze."""
    contacts = two_contacts()
    rows = SimpleNamespace(slip=np.zeros(2))
    d = np.array([-1e-5, 1e-5])  # tension 10 N on contact 0; 10 N squeeze on contact 1
    s = np.array([0.0, -1e-4])
    contact_law.update(contacts, rows, d, s, None, JOINT, LAW, held)
    return contacts.state


def test_free_contacts_open_and_stick():
    assert apply_law().tolist() == [OPEN, LOCKED]


def test_held_contacts_stay_closed_and_sliding():
    held = (np.array([True, False]), np.array([False, True]))
    assert apply_law(held).tolist() == [LOCKED, SLIDING]


def test_friction_work_splits_dissipation_from_what_holds_put_in():
    """Contact 1 slides in +s with a 5 N friction force. Moved back 1e-4 m and held, its
    friction pushed the blocks with 5e-4 J; not held it would stick. Moved forward 2e-4 m,
    its friction dissipated 1e-3 J. Contact 0 is locked: a spring, no friction work."""
    contacts = two_contacts()
    contacts.shear_multiplier[:] = [3.0, 5.0]
    back, forward = np.array([-1e-4, -1e-4]), np.array([-1e-4, 2e-4])
    both = np.array([True, True])
    assert friction_work(contacts, both, back) == pytest.approx((0.0, 5e-4), rel=1e-12)
    assert friction_work(contacts, np.array([True, False]), back) == (0.0, 0.0)
    assert friction_work(contacts, both, forward) == pytest.approx((1e-3, 0.0), rel=1e-12)
    contacts.slide_direction[1] = -1.0  # sliding in -s: moving +2e-4 m is moving back
    assert friction_work(contacts, both, forward) == pytest.approx((0.0, 1e-3), rel=1e-12)


def test_flips_are_counted_per_direction_and_hold_only_within_tolerance():
    flips = StateFlips(2)
    cycle = [LOCKED, OPEN, LOCKED, SLIDING]  # contact 0 cycles open/closed, 1 locked/sliding
    states = cycle * 4
    for before, after in zip(states[:-1], states[1:], strict=True):
        flips.count(np.array([before, LOCKED]), np.array([after, LOCKED]))
    assert flips.normal[0] >= StateFlips.LIMIT and flips.shear[1] == 0
    keep_closed, _ = flips.held(np.array([1e-4, 0.0]), np.zeros(2), tolerance=1e-3)
    assert keep_closed.tolist() == [True, False]
    far, _ = flips.held(np.array([2e-3, 0.0]), np.zeros(2), tolerance=1e-3)
    assert not far.any()  # a 2 mm gap is not a detail to hold over


def test_a_contact_is_held_after_its_second_round_trip_not_before():
    """closed -> open -> closed is a neighbour settling; doing it again is a cycle."""
    flips = StateFlips(1)
    states = [LOCKED, OPEN, LOCKED, OPEN, LOCKED]
    gap, still = np.array([1e-4]), np.zeros(1)
    for flip, (before, after) in enumerate(zip(states[:-1], states[1:], strict=True), start=1):
        flips.count(np.array([before]), np.array([after]))
        keep_closed, _ = flips.held(gap, still, tolerance=1e-3)
        assert keep_closed[0] == (flip >= 4), flip


@pytest.mark.parametrize("compiled", [True, False])
def test_a_contact_held_closed_piles_up_no_tension_in_its_multiplier(monkeypatch, compiled):
    """AL: λ ← λ + p d would make a held contact's multiplier more tensile every solve
    (the tunnel had held contacts at -68 MN against a median contact force of 0.14 MN).
    Held closed, it stops at the joint's tensile strength; the spring p d stays."""
    if not compiled:
        monkeypatch.setattr(contact_law, "_decide_kernel", None)
    law = contact_law.ContactLaw(augmented=True, tolerance=1e-3, shear_ratio=0.4, friction=True)
    strong = contact_law.JointProperties(np.full(2, 0.5), np.zeros(2), np.full(2, 3.0))
    for joint, floor in ((JOINT, 0.0), (strong, -3.0)):
        contacts = two_contacts()
        contacts.normal_multiplier[:] = [-2.0, 5.0]
        contacts.intact[:] = True  # the tensile strength is still there
        rows = SimpleNamespace(slip=np.zeros(2))
        d = np.array([-1e-5, 1e-5])  # trial forces: -2 - 10 N (tensile), 5 + 10 N
        held = (np.array([True, True]), np.zeros(2, bool))
        contact_law.update(contacts, rows, d, np.zeros(2), None, joint, law, held)
        assert contacts.state[0] != OPEN  # held closed
        assert contacts.normal_multiplier.tolist() == [floor, 15.0]
        assert contacts.normal_force[0] == pytest.approx(-12.0)  # this solve's force, as it was


def test_rock_slope_steps_settle_without_cutting_the_time_step():
    """40 steps of the jointed slope: every step settles at the full Δt, energy and areas hold.

    Before contacts were held, 20 steps of this run needed 29 cuts (Δt down to 1.5e-5 s).
    """
    raw = tomllib.loads((CASES / "rock_slope.toml").read_text())
    raw["analysis"].pop("duration")
    raw["analysis"]["steps"] = 40
    result = run_checked(raw)
    assert result.summary["cut_steps"] == 0
    assert result.final.time == pytest.approx(40 * raw["analysis"]["time_step"], rel=1e-12)
