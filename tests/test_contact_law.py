"""The contact law's compiled pass against its numpy twin: the same numbers, bit for bit."""

from __future__ import annotations

import tomllib
from dataclasses import fields
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import dda
import dda.contact.law as law_module
from dda.contact.contact_set import ContactSet
from dda.contact.law import ContactLaw, JointProperties, update
from dda.result import LOCKED, OPEN, SLIDING

compiled = pytest.mark.skipif(law_module._decide_kernel is None, reason="numba is not in use")

FIELDS = (
    "state",
    "slide_direction",
    "intact",
    "normal_multiplier",
    "shear_multiplier",
    "normal_force",
    "shear_force",
    "penetration",
    "slip",
)


def random_contacts(seed: int, m: int = 4000):
    """Contacts in every state, near every threshold of the law (forces and motions of
    the order of the band), some without cohesion or tensile strength left."""
    rng = np.random.default_rng(seed)
    empty = ContactSet.empty()
    contacts = ContactSet(
        **{f.name: np.zeros(m, getattr(empty, f.name).dtype) for f in fields(empty)}
    )
    contacts.state = rng.choice(np.array([OPEN, SLIDING, LOCKED], np.int8), m)
    contacts.penalty = rng.choice([1e5, 5e7, 1e9], m)
    contacts.normal_multiplier = np.where(contacts.state != OPEN, rng.normal(0, 1e-2, m), 0.0)
    contacts.shear_multiplier = rng.normal(0, 1e-2, m)
    contacts.slide_direction = rng.choice([-1.0, 0.0, 1.0], m)
    contacts.intact = rng.random(m) < 0.5
    band = 1e-9
    d = rng.normal(0, 3 * band, m)
    s = rng.normal(0, 3 * band, m)
    rows = SimpleNamespace(slip=s + rng.normal(0, 3 * band, m))
    joint = JointProperties(
        friction=rng.choice([0.0, 0.58], m),
        cohesion=rng.choice([0.0, 1e-3], m),
        tensile=rng.choice([0.0, 1e-3], m),
    )
    held = (rng.random(m) < 0.1, rng.random(m) < 0.1)
    return contacts, rows, d, s, joint, held, band


def law_for(band: float, augmented: bool = True, friction: bool = True) -> ContactLaw:
    """The law the random contacts are judged by: tolerance 1e-9, shear ratio 0.4."""
    return ContactLaw(
        augmented=augmented,
        tolerance=1e-9,
        shear_ratio=0.4,
        friction=friction,
        state_band=band,
        band_stiffness=1e6,
    )


@compiled
@pytest.mark.parametrize("augmented", [False, True])
@pytest.mark.parametrize("friction", [False, True])
@pytest.mark.parametrize("with_held", [False, True])
def test_compiled_law_equals_numpy(monkeypatch, augmented, friction, with_held):
    contacts, rows, d, s, joint, held, band = random_contacts(int(augmented) + 2 * int(friction))
    law = law_for(band, augmented, friction)
    held = held if with_held else None
    ours, theirs = contacts.copy(), contacts.copy()
    fast = update(ours, rows, d, s, None, joint, law, held)
    monkeypatch.setattr(law_module, "_decide_kernel", None)
    slow = update(theirs, rows, d, s, None, joint, law, held)
    assert fast == slow
    assert 0 < fast.state_changes < len(contacts)  # the thresholds were crossed both ways
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(ours, name), getattr(theirs, name), err_msg=name)


@compiled
def test_a_run_with_the_compiled_law_equals_one_with_numpy(monkeypatch):
    """The tunnel's first steps (augmented Lagrangian, friction, held contacts) give the
    same displacements and iterations, bit for bit, with either pass."""
    raw = tomllib.loads(Path("cases/tunnel.toml").read_text())
    raw["analysis"].pop("duration", None)
    raw["analysis"]["steps"] = 10
    scene = dda.load_scene(raw)
    monkeypatch.setattr("dda.jit.MIN_WORK", 0)  # the kernels, however short the run
    fast = dda.simulate(scene)
    monkeypatch.setattr(law_module, "_decide_kernel", None)
    slow = dda.simulate(scene)
    for ours, theirs in zip(fast.final.vertices, slow.final.vertices, strict=True):
        np.testing.assert_array_equal(ours, theirs)
    assert fast.summary["iterations"] == slow.summary["iterations"]
