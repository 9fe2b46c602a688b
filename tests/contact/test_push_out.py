"""Overlap found at a new contact: removed by the least-inertia displacement, not by velocity."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from dda.contact.push_out import push_out_displacement, pushed_overlap
from dda.result import LOCKED, OPEN


def contacts_and_rows(seed: int = 0):
    """Three contacts of free block 1 on fixed block 0 and on free block 2; random rows."""
    rng = np.random.default_rng(seed)
    contacts = SimpleNamespace(
        block_a=np.array([1, 1, 2]),
        block_b=np.array([0, 2, 0]),
        state=np.array([LOCKED, LOCKED, OPEN]),
        fresh=np.array([True, True, True]),
    )
    rows = SimpleNamespace(
        normal_i=rng.normal(size=(3, 6)),
        normal_j=rng.normal(size=(3, 6)),
        penetration=np.array([2e-3, 5e-4, 3e-3]),
    )
    return contacts, rows


def spd_masses(seed: int, n: int = 3) -> np.ndarray:
    a = np.random.default_rng(seed).normal(size=(n, 6, 6))
    return np.einsum("nij,nkj->nik", a, a) + 6.0 * np.eye(6)


def test_only_fresh_closed_contacts_found_deeper_than_the_tolerance_count():
    contacts, rows = contacts_and_rows()
    final = np.array([1e-5, 1e-5, 1e-5])
    overlap = pushed_overlap(contacts, rows, final, tolerance=1e-4)
    np.testing.assert_allclose(overlap, [2e-3 - 1e-4, 5e-4 - 1e-4, 0.0])  # the open one: none
    contacts.fresh[0] = False  # a contact with history keeps its own
    assert pushed_overlap(contacts, rows, final, 1e-4)[0] == 0.0


def test_push_out_removes_the_overlap_with_the_least_kinetic_energy():
    """G D = -e at the chosen contacts, D = 0 on fixed blocks, and D = M⁻¹Gᵀλ
    (so no other D with G D = -e has less ½ Dᵀ M D)."""
    contacts, rows = contacts_and_rows(1)
    masses, fixed = spd_masses(2), np.array([True, False, False])
    overlap = np.array([1.9e-3, 4e-4, 0.0])
    push = push_out_displacement(masses, fixed, contacts, rows, overlap)
    assert np.all(push[0] == 0.0)
    moved = np.einsum("cr,cr->c", rows.normal_i[:2], push[contacts.block_a[:2]])
    moved += np.einsum(
        "cr,cr->c",
        rows.normal_j[:2],
        push[contacts.block_b[:2]] * ~fixed[contacts.block_b[:2], None],
    )
    np.testing.assert_allclose(moved, -overlap[:2], rtol=1e-10)
    # the least-energy solution of the same constraints, by a dense KKT system
    g = np.zeros((2, 12))
    for c in range(2):
        for block, row in (
            (contacts.block_a[c], rows.normal_i[c]),
            (contacts.block_b[c], rows.normal_j[c]),
        ):
            if not fixed[block]:
                g[c, 6 * (block - 1) : 6 * block] += row
    m = np.zeros((12, 12))
    m[:6, :6], m[6:, 6:] = masses[1], masses[2]
    kkt = np.block([[m, g.T], [g, np.zeros((2, 2))]])
    expected = np.linalg.solve(kkt, np.concatenate([np.zeros(12), -overlap[:2]]))[:12]
    np.testing.assert_allclose(push[1:].ravel(), expected, rtol=1e-9, atol=1e-15)


def test_no_overlap_no_push():
    contacts, rows = contacts_and_rows()
    push = push_out_displacement(spd_masses(0), np.zeros(3, bool), contacts, rows, np.zeros(3))
    assert push.shape == (3, 6) and not push.any()
