"""The contact law between Newton solves (dda.contact.law): multipliers (paper eq. 7),
the variable penalty, friction bounds that follow the normal forces, broken bonds."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from dda.contact.contact_set import ContactSet
from dda.contact.law import (
    UNBOUNDED,
    BoundIteration,
    ContactLaw,
    JointProperties,
    contact_terms,
    friction_bound,
    record,
    update,
)
from dda.result import LOCKED, OPEN, SLIDING

LAW = ContactLaw(augmented=True, tolerance=1e-6, shear_ratio=0.4, friction=True)


def contact_set(m: int, penalty: float = 1e8) -> ContactSet:
    empty = ContactSet.empty()
    contacts = ContactSet(
        **{f.name: np.zeros(m, getattr(empty, f.name).dtype) for f in fields(empty)}
    )
    contacts.penalty[:] = penalty
    contacts.intact[:] = True
    contacts.state[:] = LOCKED  # touching, as bonded contacts are
    return contacts


def joints(m: int, tan_phi: float = 0.5, cohesion: float = 0.0, tensile: float = 0.0):
    return JointProperties(np.full(m, tan_phi), np.full(m, cohesion), np.full(m, tensile))


def test_multipliers_move_only_beyond_the_tolerance():
    """λn ← λn + p g where |g| > tol on a closed contact; within, λn is kept; an open
    contact's λn becomes 0. λt ← λt + ps s on a stuck contact with |s| > tol."""
    contacts = contact_set(4)
    contacts.normal_multiplier[:] = [100.0, 100.0, 100.0, 10.0]
    joint = joints(4)
    g = np.array([0.5e-6, 3e-6, -0.5e-6, -1e-3])  # within, beyond, within (gap), open
    s = np.array([0.0, 2e-6, 0.0, 0.0])
    terms = contact_terms(contacts, joint, LAW, np.full(4, 1e4))
    outcome = update(contacts, terms, g, s, None, joint, LAW)
    assert not outcome.settled and outcome.augmented == 1
    np.testing.assert_allclose(contacts.normal_multiplier, [100.0, 400.0, 100.0, 0.0])
    assert contacts.shear_multiplier[1] == pytest.approx(0.4 * 1e8 * 2e-6)
    assert contacts.shear_multiplier[[0, 2, 3]].tolist() == [0.0, 0.0, 0.0]


def test_a_contact_found_deeper_than_the_tolerance_is_not_augmented():
    """A fresh contact that starts overlapping beyond the tolerance (fresh fracture
    fragments) is pushed out by its penalty spring, not augmented: in the paper's Fig. 3
    at three times the load a 4.6 cm overlap among fragments had the augmentation ask
    for more than any step could give, down to Δt = 1e-13 s. One that started within
    the tolerance is augmented as usual."""
    contacts = contact_set(2)
    contacts.fresh[:] = True
    contacts.penetration[:] = [5e-2, 0.5e-6]  # found 5 cm deep / within the tolerance
    joint = joints(2, tan_phi=0.0)
    law = ContactLaw(augmented=True, tolerance=1e-6, shear_ratio=0.4, friction=False)
    terms = contact_terms(contacts, joint, law, np.zeros(2))
    g = np.array([3e-2, 3e-6])
    outcome = update(contacts, terms, g, np.zeros(2), np.array([5e-2, 3e-6]), joint, law)
    assert outcome.augmented == 1
    assert contacts.normal_multiplier.tolist() == [0.0, pytest.approx(1e8 * 3e-6)]
    assert contacts.penalty.tolist() == [1e8, 1e9]


def test_the_penalty_grows_where_the_penetration_does_not_shrink():
    contacts = contact_set(2)
    joint = joints(2, tan_phi=0.0)
    law = ContactLaw(augmented=True, tolerance=1e-6, shear_ratio=0.4, friction=False)
    terms = contact_terms(contacts, joint, law, np.zeros(2))
    g = np.array([5e-6, 5e-6])
    update(contacts, terms, g, np.zeros(2), np.array([6e-6, 1e-4]), joint, law)
    assert contacts.penalty.tolist() == [1e9, 1e8]  # the first shrank by 5/6 only


def test_friction_bounds_follow_the_normal_forces_until_they_agree():
    """A sliding contact (trial far beyond b) carries b = tan φ N of the last solve; the
    step is settled once that changes its force by less than 1e-3 of the largest bound."""
    contacts = contact_set(1)
    joint = joints(1)
    law = ContactLaw(augmented=False, tolerance=1e-6, shear_ratio=0.4, friction=True)
    g, s = np.array([1e-5]), np.array([1e-3])  # N = 1e3, sliding hard
    stale = contact_terms(contacts, joint, law, np.array([400.0]))
    outcome = update(contacts, stale, g, s, None, joint, law)
    assert not outcome.settled and outcome.bound[0] == pytest.approx(500.0)
    fresh = contact_terms(contacts, joint, law, outcome.bound)
    assert update(contacts, fresh, g, s, None, joint, law).settled


def test_bonds_break_at_the_tensile_strength_only_once_the_forces_agree():
    contacts = contact_set(2)
    joint = joints(2, tan_phi=0.0, cohesion=0.0, tensile=50.0)
    law = ContactLaw(augmented=False, tolerance=1e-6, shear_ratio=0.4, friction=False)
    terms = contact_terms(contacts, joint, law, np.zeros(2))
    g = np.array([-1e-6, -1e-5])  # pulled by 100 N and by 1000 N: beyond 50 N, both held
    assert terms.normal_force(g).tolist() == [-50.0, -50.0]
    outcome = update(contacts, terms, g, np.zeros(2), None, joint, law)
    assert outcome.broken == 2 and not outcome.settled
    assert not contacts.intact.any()
    assert contact_terms(contacts, joint, law, np.zeros(2)).tension.tolist() == [0.0, 0.0]


def test_an_open_bond_without_tensile_strength_keeps_its_cohesion():
    """A contact bonded by cohesion alone (T = 0) that opens is not pulled to a
    tensile strength: its bond stays (it recloses with c l in its friction bound)."""
    contacts = contact_set(1)
    joint = joints(1, tan_phi=0.5, cohesion=1e3, tensile=0.0)
    law = ContactLaw(augmented=False, tolerance=1e-6, shear_ratio=0.4, friction=True)
    terms = contact_terms(contacts, joint, law, friction_bound(contacts, joint, np.zeros(1)))
    outcome = update(contacts, terms, np.array([-1e-4]), np.zeros(1), None, joint, law)
    assert outcome.settled and outcome.broken == 0
    assert contacts.intact.tolist() == [True]


def test_the_first_bounds_after_the_guess_are_the_target():
    """While a bound is the first guess (UNBOUNDED) the iteration takes G(b) as it is:
    mixed with 1e300, the bounds would cancel to 0."""
    bounds = BoundIteration(np.full(3, UNBOUNDED))
    assert bounds.guessing
    target = np.array([10.0, 0.0, 250.0])
    bounds.advance(target)
    assert bounds.bound.tolist() == target.tolist() and not bounds.guessing


def test_the_bounds_iteration_settles_a_swinging_linear_map_in_a_few_steps():
    """G(b) = c − A b with A's eigenvalues near −1 (b ← G(b) swings and crawls):
    after 8 iterations Anderson mixing (depth 4) is within 1e-4 of the fixed point
    (measured 2.0e-5), plain iteration not within 1e-2."""
    rng = np.random.default_rng(0)
    q = np.linalg.qr(rng.normal(size=(6, 6)))[0]
    a = q @ np.diag([0.97, 0.9, 0.5, -0.2, 0.3, 0.1]) @ q.T
    c = rng.uniform(50, 100, 6)
    exact = np.linalg.solve(np.eye(6) + a, c)
    plain = BoundIteration(np.full(6, 10.0))
    mixed = BoundIteration(np.full(6, 10.0))
    for _ in range(8):
        plain.bound = c - a @ plain.bound
        mixed.advance(np.maximum(c - a @ mixed.bound, 0.0))
    assert np.abs(mixed.bound - exact).max() <= 1e-4 * exact.max()
    assert np.abs(plain.bound - exact).max() > 1e-2 * exact.max()


def test_record_states_forces_and_the_carried_shear_force():
    contacts = contact_set(3)
    joint = joints(3)
    law = ContactLaw(augmented=False, tolerance=1e-6, shear_ratio=0.4, friction=True)
    normal = np.array([1e3, 1e3, 0.0])
    terms = contact_terms(contacts, joint, law, friction_bound(contacts, joint, normal))
    g = np.array([1e-5, 1e-5, -1e-4])
    s = np.array([1e-6, 1e-4, 0.0])  # stuck (40 N < 500 N), sliding (4000 N > 500 N), open
    record(contacts, terms, g, s)
    assert contacts.state.tolist() == [LOCKED, SLIDING, OPEN]
    np.testing.assert_allclose(contacts.normal_force, [1e3, 1e3, 0.0])
    np.testing.assert_allclose(contacts.shear_force, [40.0, 500.0, 0.0])
    np.testing.assert_allclose(contacts.shear_multiplier, contacts.shear_force)
    assert contacts.slide_direction.tolist() == [0.0, 1.0, 0.0]


def test_a_shear_force_within_the_bound_tolerance_is_at_the_friction_limit():
    """The bounds settle to friction_tolerance: a contact stuck at 1 - 1e-6 of its bound
    (a block in limiting equilibrium) is reported sliding in the band, locked without;
    one at 0.99 of it stays locked."""
    contacts = contact_set(2)
    joint = joints(2)
    law = ContactLaw(augmented=False, tolerance=1e-6, shear_ratio=0.4, friction=True)
    terms = contact_terms(contacts, joint, law, friction_bound(contacts, joint, np.full(2, 1e3)))
    s = np.array([1 - 1e-6, 0.99]) * 500.0 / (0.4 * 1e8)  # ps s = 0.999999 b, 0.99 b
    record(contacts, terms, np.full(2, 1e-5), s, 1e-3)
    assert contacts.state.tolist() == [SLIDING, LOCKED]
    record(contacts, terms, np.full(2, 1e-5), s)
    assert contacts.state.tolist() == [LOCKED, LOCKED]
