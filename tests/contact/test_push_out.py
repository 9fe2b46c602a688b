"""Overlap found at a new contact: removed by the displacement of least step energy, not by
velocity."""

from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import dda
from dda.contact.push_out import found_overlap, push_out_displacement
from dda.result import LOCKED, OPEN
from dda.run.run_warnings import energy_excess

CASES = Path(__file__).resolve().parents[2] / "cases"


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


def test_only_fresh_closed_contacts_found_overlapping_count():
    """Every overlap a contact is found with (not only what is deeper than the contact
    tolerance: the spring of any overlap would turn ½ p g₀² into motion)."""
    contacts, rows = contacts_and_rows()
    contacts.penetration = rows.penetration.copy()  # as found (rows: after the ground's move)
    contacts.normal_multiplier = np.zeros(3)
    rows.penetration = rows.penetration + 1e-3
    overlap = found_overlap(contacts, touch=1e-9)
    np.testing.assert_allclose(overlap, [2e-3, 5e-4, 0.0])  # the open one: none
    contacts.fresh[0] = False  # a contact with history keeps its own
    assert found_overlap(contacts, 1e-9)[0] == 0.0
    contacts.normal_multiplier[1] = 3.0  # one preloaded by an in-situ field keeps its own
    assert found_overlap(contacts, 1e-9)[1] == 0.0
    contacts.normal_multiplier[1], contacts.penetration[1] = 0.0, 1e-10  # within touch
    assert found_overlap(contacts, 1e-9)[1] == 0.0


def test_push_out_removes_the_overlap_with_the_least_step_energy():
    """G D = -e at the chosen contacts, D = 0 on fixed blocks, and D = K₀⁻¹Gᵀλ
    (so no other D with G D = -e has less ½ Dᵀ K₀ D; K₀ any block-diagonal SPD)."""
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


def test_an_overlap_within_the_contact_tolerance_is_removed_without_energy():
    """cases/verify/overlap.toml (a block drawn 2e-5 m into its base, no loads) with a
    contact tolerance of 1e-4 m, five times the overlap: the contact is found overlapping,
    within the tolerance, and the overlap goes by position as it does beyond it. Its
    spring pushed the block out before, with 0.31 J of kinetic energy from nowhere (the
    scale ½ m (d/Δt)² is 0.54 J); now the blocks hold at most the elastic energy of the
    strain the push leaves (1.6e-4 J, as beyond the tolerance)."""
    raw = tomllib.loads((CASES / "verify" / "overlap.toml").read_text())
    raw["contact"]["tolerance"] = 1e-4
    result = dda.simulate(dda.load_scene(raw), keep_frames=False)
    scale = 0.5 * 2700.0 * (2e-5 / 1e-3) ** 2
    excess, _, _ = energy_excess(result.history, result.summary["initial_energy"], False)
    assert excess <= 1e-3 * scale
    assert result.history["kinetic_energy"].max() <= 1e-4 * scale
