"""The contact law's compiled twins (dda.contact.law_kernels) against its numpy bodies.

Random contacts of every kind the law meets — closed and open, at the tensile limit,
stuck and slipping either way, exactly at a friction bound, bonded and broken, fresh
and deep, with and without friction, penalty and augmented Lagrangian — go through each
law function with the kernels and without; every array and number must be the same
(the same operations contact by contact: bit for bit).
"""

from __future__ import annotations

import numpy as np
import pytest

from dda.contact import law, law_kernels
from dda.contact.contact_set import ContactSet
from dda.contact.law import ContactLaw, JointProperties

pytestmark = pytest.mark.skipif(law_kernels.terms_kernel is None, reason="numba is not in use")

KERNELS = (
    "terms_kernel",
    "forces_and_bounds_kernel",
    "augment_kernel",
    "broken_kernel",
    "recorded_kernel",
)


def random_contacts(seed: int, m: int = 400) -> tuple[ContactSet, JointProperties]:
    rng = np.random.default_rng(seed)
    integers = np.arange(m)

    def pick(*values):
        return rng.choice(values, m)

    contacts = ContactSet(
        vertex=integers,
        edge=integers,
        block_a=integers,
        block_b=integers,
        key=integers,
        state=pick(0, 1, 2).astype(np.int8),
        normal_multiplier=rng.normal(size=m) * pick(0.0, 1.0),
        shear_multiplier=rng.normal(size=m) * pick(0.0, 1.0, 3.0),
        penalty=pick(1e3, 1e4, 1e6),
        reference=rng.random(m),
        slide_direction=pick(-1.0, 0.0, 1.0),
        intact=rng.random(m) < 0.5,
        fresh=rng.random(m) < 0.3,
        normal_force=rng.normal(size=m),
        shear_force=rng.normal(size=m),
        penetration=rng.normal(size=m) * pick(1e-6, 1e-3),
        slip=rng.normal(size=m) * 1e-4,
    )
    joints = JointProperties(
        friction=pick(0.0, 0.3, 0.58),
        cohesion=pick(0.0, 0.0, 0.5),
        tensile=pick(0.0, 0.0, 0.7),
    )
    return contacts, joints


def gaps(seed: int, terms) -> tuple[np.ndarray, np.ndarray]:
    """g and s with some contacts exactly on a kink (at −T, at ±b)."""
    rng = np.random.default_rng(seed + 100)
    m = len(terms.penalty)
    g = rng.normal(size=m) * rng.choice([1e-6, 1e-4, 1e-3], m)
    s = rng.normal(size=m) * rng.choice([1e-6, 1e-4, 1e-3], m)
    on_bound = np.flatnonzero(terms.shear_penalty > 0.0)[:20]
    s[on_bound] = (terms.bound[on_bound] - terms.shear_base[on_bound]) / terms.shear_penalty[
        on_bound
    ]
    at_limit = np.arange(20, 30)
    g[at_limit] = (-terms.tension[at_limit] - terms.normal_base[at_limit]) / terms.penalty[at_limit]
    return g, s


def both_paths(monkeypatch, work):
    """``work()`` with the kernels, then with the numpy bodies."""
    compiled = work()
    for name in KERNELS:
        monkeypatch.setattr(law_kernels, name, None)
    expected = work()
    monkeypatch.undo()
    return compiled, expected


def assert_same(compiled, expected):
    assert type(compiled) is type(expected)
    if isinstance(compiled, np.ndarray):
        assert compiled.dtype == expected.dtype
        np.testing.assert_array_equal(compiled, expected)
    elif isinstance(compiled, (tuple, list)):
        for a, b in zip(compiled, expected, strict=True):
            assert_same(a, b)
    else:
        assert compiled == expected


def contact_arrays(contacts: ContactSet) -> list[np.ndarray]:
    names = ("state", "normal_multiplier", "shear_multiplier", "penalty", "slide_direction",
             "intact", "normal_force", "shear_force", "penetration", "slip")  # fmt: skip
    return [getattr(contacts, name) for name in names]


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("friction", [True, False])
@pytest.mark.parametrize("augmented", [True, False])
@pytest.mark.parametrize("static", [True, False])
def test_the_laws_passes_compiled_equal_numpy(monkeypatch, seed, friction, augmented, static):
    contacts, joints = random_contacts(seed)
    rule = ContactLaw(
        augmented=augmented, tolerance=1e-4, shear_ratio=0.4, friction=friction,
        max_penalty=5e6,
    ).for_step(static)  # fmt: skip
    bound = law.friction_bound(contacts, joints, np.abs(contacts.normal_force))

    def run():
        mine = contacts.copy()
        terms = law.contact_terms(mine, joints, rule, bound)
        g, s = gaps(seed, terms)
        first = law.update(mine, terms, g, s, None, joints, rule)
        terms = law.contact_terms(mine, joints, rule, first.bound)
        second = law.update(mine, terms, 0.5 * g, s, g, joints, rule)
        law.record(mine, terms, 0.5 * g, s, rule.friction_tolerance, rule.persistent)
        outcomes = [(o.settled, o.augmented, o.broken, o.max_violation) for o in (first, second)]
        bonded = contacts.copy()  # the bonds of an update that settled
        outcomes.append((law.break_bonds(bonded, terms, joints, g, s), bonded.intact))
        fields = [terms.normal_base, terms.tension, terms.shear_base, terms.shear_penalty]
        return fields + [first.bound, second.bound] + outcomes + contact_arrays(mine)

    compiled, expected = both_paths(monkeypatch, run)
    assert_same(compiled, expected)
    states = expected[-10]
    assert expected[-11][0] > 0 or not friction  # bonds were broken (slipping ones)
    # open, sliding and (with friction) locked contacts were recorded
    assert len(np.unique(states)) == (3 if friction else 2)
