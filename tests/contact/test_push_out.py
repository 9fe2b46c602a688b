"""Overlap found at a new contact: removed by the displacement of least step energy, not by
velocity."""

from __future__ import annotations

import tomllib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import dda
from dda.contact.push_out import (
    found_overlap,
    pay_for_the_push,
    push_metric,
    push_out_displacement,
)
from dda.result import LOCKED, OPEN
from dda.run.run_warnings import energy_excess

CASES = Path(__file__).resolve().parents[2] / "cases"


def normal_rows(normal_i, normal_j, penetration=None) -> SimpleNamespace:
    """Contact rows with these normal rows (m, 6), no shear rows, the penetration given
    or 0."""
    normal_i, normal_j = np.asarray(normal_i, float), np.asarray(normal_j, float)
    m = len(normal_i)
    zeros = np.zeros((m, 6))
    penetration = np.zeros(m) if penetration is None else np.asarray(penetration, float)
    return SimpleNamespace(normal_i=normal_i, normal_j=normal_j, shear_i=zeros,
                           shear_j=zeros, penetration=penetration, slip=np.zeros(m))  # fmt: skip


def contacts_and_rows(seed: int = 0):
    """Three contacts of free block 1 on fixed block 0 and on free block 2; random rows."""
    rng = np.random.default_rng(seed)
    contacts = SimpleNamespace(
        block_a=np.array([1, 1, 2]),
        block_b=np.array([0, 2, 0]),
        state=np.array([LOCKED, LOCKED, OPEN]),
        fresh=np.array([True, True, True]),
    )
    rows = normal_rows(
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


def kkt_holds(metric, fixed, contacts, rows, room, push, scale, dofs=3):
    """The push's optimality (sufficient for the convex problem) on the first ``dofs`` of
    each block's unknowns (the rigid motion where it can; the others 0): G D ≤ room,
    W D = −Gᵀν on the free blocks with ν ≥ 0 (pushing apart), ν = 0 where a contact has
    room left."""
    n, m = len(fixed), len(room)
    assert not push[:, dofs:].any()
    metric = metric.copy()
    metric[:, dofs:, :] = metric[:, :, dofs:] = 0.0
    metric[:, range(dofs, 6), range(dofs, 6)] = 1.0  # the other unknowns: 0 by the line above
    g = np.zeros((m, 6 * n))
    for c in range(m):
        for block, row in ((contacts.block_a[c], rows.normal_i[c]),
                           (contacts.block_b[c], rows.normal_j[c])):  # fmt: skip
            if not fixed[block]:
                g[c, 6 * block : 6 * block + 6] += row
    motion = g @ push.ravel()
    assert np.all(motion <= room + 1e-9 * scale)
    g.reshape(m, n, 6)[:, :, dofs:] = 0.0  # stationary on the unknowns the push moves
    at_room = motion >= room - 1e-9 * scale
    w = np.zeros((6 * n, 6 * n))
    for i in np.flatnonzero(~fixed):
        w[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = metric[i]
    force = w @ push.ravel()
    nu = np.linalg.lstsq(-g[at_room].T, force, rcond=None)[0]
    np.testing.assert_allclose(-g[at_room].T @ nu, force, atol=1e-9 * np.abs(force).max())
    assert np.all(nu >= -1e-9 * np.abs(nu).max())
    return at_room


def test_push_out_removes_the_overlap_with_the_least_energy_in_its_metric():
    """Two contacts found overlapping, left at touch by the step, one open far away: the
    push leaves both at most touching, D = 0 on the fixed block, and it is a rigid motion
    (no strain) and no other rigid motion that does has less ½ Dᵀ W D (W any
    block-diagonal SPD): checked by the KKT conditions on the rigid unknowns."""
    contacts, rows = contacts_and_rows(1)
    metric, fixed = spd_masses(2), np.array([True, False, False])
    overlap = np.array([1.9e-3, 4e-4, 0.0])
    after = np.array([0.0, 0.0, -1.0])  # the other contact 1 m open: the push does not reach it
    push = push_out_displacement(metric, fixed, contacts, rows, overlap, after)
    assert np.all(push[0] == 0.0)
    room = np.array([-1.9e-3, -4e-4, 1.0])
    at_room = kkt_holds(metric, fixed, contacts, rows, room, push, 1.9e-3)
    assert at_room[0] and not at_room[2]


def test_an_overlap_the_step_parted_is_not_pushed():
    """A contact found 1e-3 deep whose step moved its blocks apart by more (its
    penetration from touch after the step −2e-3): no push; by less (−4e-4): the rest."""
    contacts, rows = contacts_and_rows(1)
    metric, fixed = spd_masses(2), np.array([True, False, False])
    overlap = np.array([1e-3, 0.0, 0.0])
    parted = np.array([-2e-3, -1.0, -1.0])
    assert not push_out_displacement(metric, fixed, contacts, rows, overlap, parted).any()
    partly = np.array([-4e-4, -1.0, -1.0])
    push = push_out_displacement(metric, fixed, contacts, rows, overlap, partly)
    kkt_holds(metric, fixed, contacts, rows, np.array([-6e-4, 1.0, 1.0]), push, 1e-3)


def test_the_push_moves_a_block_rigidly_where_it_can():
    """A block found 1e-4 into a fixed one: pushed out by a rigid motion, with no strain
    (which its spring-back would turn into motion)."""
    x = np.eye(6)[1]  # the contact's penetration changes with −v of block 1
    contacts = SimpleNamespace(block_a=np.array([1]), block_b=np.array([0]))
    rows = normal_rows(normal_i=np.array([-x + 0.3 * np.eye(6)[4]]), normal_j=np.array([x]))
    young, mass = 1e10, 2700.0
    springs = np.zeros((2, 6, 6))
    springs[:, 3:, 3:] = young * np.eye(3)
    masses = np.broadcast_to(mass * np.eye(6), (2, 6, 6)).copy()
    metric = push_metric(springs, masses, np.full(2, young / mass))
    fixed = np.array([True, False])
    push = push_out_displacement(metric, fixed, contacts, rows, np.array([1e-4]), np.zeros(1))
    assert push[1, 1] == pytest.approx(1e-4, rel=1e-12)
    assert not push[1, 3:].any()


def test_a_block_pinched_between_two_fixed_ones_is_pushed_by_its_strain():
    """A unit block found 1e-3 into fixed blocks on both sides: no rigid motion clears
    both (its left face moves u − εx/2, its right face u + εx/2), so the push is the
    least ½ DᵀWD with strain: u = 0, εx = −2e-3 (W diagonal)."""
    u, ex = np.eye(6)[0], np.eye(6)[3]
    contacts = SimpleNamespace(block_a=np.array([1, 1]), block_b=np.array([0, 2]))
    rows = normal_rows(normal_i=np.array([-u + 0.5 * ex, u + 0.5 * ex]),
                           normal_j=np.zeros((2, 6)))  # fmt: skip
    metric = np.broadcast_to(np.eye(6), (3, 6, 6)).copy()
    fixed = np.array([True, False, True])
    push = push_out_displacement(metric, fixed, contacts, rows, np.full(2, 1e-3), np.zeros(2))
    np.testing.assert_allclose(push[1], -2e-3 * ex, atol=1e-15)
    assert not push[fixed].any()


def in_a_row(gap_ab: float, fixed_b: bool = False):
    """Blocks B, A, C side by side along x (stiffness 2, 1 and 3 on every D component):
    C found overlapping A (contact 0, C's vertex in A's edge) and A's vertex on B's edge
    (contact 1) open by ``gap_ab`` at the step's end. Penetrations change with the
    translations u: contact 0 by u_A − u_C, contact 1 by u_B − u_A."""
    x = np.eye(6)[0]
    contacts = SimpleNamespace(block_a=np.array([2, 0]), block_b=np.array([0, 1]))
    rows = normal_rows(normal_i=np.array([-x, -x]), normal_j=np.array([x, x]))
    stiffness = np.array([1.0, 2.0, 3.0])[:, None, None] * np.eye(6)  # A, B, C
    fixed = np.array([False, fixed_b, False])
    return stiffness, fixed, contacts, rows, np.array([0.0, -gap_ab])


@pytest.mark.parametrize(
    "gap_ab, fixed_b, expected",
    [(None, False, (-0.75, 0.0, 0.25)),  # B out of reach: A and C part as the old push
     (0.0, False, (-0.5, -0.5, 0.5)),  # A on B: A and B go together, 1/(1 + 2) against 1/3
     (0.25, False, (-7 / 12, -1 / 3, 5 / 12)),  # A closes the gap, then pushes B
     (0.0, True, (0.0, 0.0, 1.0))],  # A on a fixed B: C goes alone
)  # fmt: skip
def test_the_push_drives_no_block_into_another(gap_ab, fixed_b, expected):
    """C found 1 (any unit) into A, A touching or near B: the push may not drive A into
    B. The least ½ Σ k u² with u_A − u_C = −1 and u_B − u_A ≤ gap, by hand: unbounded,
    u_A = −(1/1)/(1/1 + 1/3) = −0.75 (into B by 0.75); touching (gap 0), A and B move as
    one of stiffness 3: u_A = u_B = −0.5, u_C = 0.5; with a gap of 0.25, u_C = u_A + 1,
    u_B = u_A + 0.25 and ∂/∂u_A (u_A² + 2 u_B² + 3 u_C²)/2 = 6 u_A + 3.5 = 0:
    u_A = −7/12; B fixed: u_A = 0, u_C = 1."""
    stiffness, fixed, contacts, rows, after = in_a_row(0.0 if gap_ab is None else gap_ab, fixed_b)
    if gap_ab is None:
        after[1] = -10.0
    push = push_out_displacement(stiffness, fixed, contacts, rows, np.array([1.0, 0.0]), after)
    np.testing.assert_allclose(push[:, 0], expected, atol=1e-12)
    assert not push[:, 1:].any()


def test_the_push_is_the_least_energy_within_the_other_contacts():
    """Random rows among five blocks (one fixed), two contacts found overlapping (left at
    touch by the step) and ten others at the step's end, some closed (penetration ≥ 0),
    some open: the push is the minimum of ½ Dᵀ W D with G D ≤ −e at the overlapping ones
    and G D ≤ max(−g, 0) at the others (its KKT conditions), and the others matter."""
    rng = np.random.default_rng(7)
    n, m = 5, 12
    fixed = np.array([True, False, False, False, False])
    a = rng.integers(1, n, m)
    b = (a + rng.integers(1, n, m)) % n
    contacts = SimpleNamespace(block_a=a, block_b=b)
    rows = normal_rows(normal_i=rng.normal(size=(m, 6)), normal_j=rng.normal(size=(m, 6)))
    metric = spd_masses(3, n)
    overlap = np.zeros(m)
    overlap[:2] = [1e-3, 4e-4]
    after = np.where(rng.random(m) < 0.5, rng.uniform(0.0, 1e-4, m), -rng.uniform(0, 1e-3, m))
    after[:2] = 0.0
    push = push_out_displacement(metric, fixed, contacts, rows, overlap, after)
    assert not push[fixed].any()
    room = np.where(overlap > 0, -overlap, np.maximum(-after, 0.0))
    at_room = kkt_holds(metric, fixed, contacts, rows, room, push, 1e-3)
    assert at_room[2:].any()  # the other contacts matter here


def test_no_overlap_no_push():
    contacts, rows = contacts_and_rows()
    none = np.zeros(3)
    push = push_out_displacement(spd_masses(0), np.zeros(3, bool), contacts, rows, none, none)
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


@pytest.mark.parametrize("size, dt", [(1.0, 1e-5), (1.0, 1e-6), (10.0, 1e-5)])
def test_the_push_clears_the_overlap_whatever_the_metrics_scale(size, dt):
    """A block found 1e-6 m into a fixed base with the metric K₀ = 2M/Δt² + S E (the packed
    mass's): the least-distance problem is scaled by its rows, so the push clears the
    overlap at any Δt and block size (unscaled, the last residual fell into round-off at
    Δt = 1e-6 s and at a 10 m block: no push)."""
    x = np.eye(6)[1]
    contacts = SimpleNamespace(block_a=np.array([1]), block_b=np.array([0]))
    rows = normal_rows(normal_i=np.array([-x + 0.5 * size * np.eye(6)[4]]),
                           normal_j=np.array([x]))  # fmt: skip
    mass = 2700.0 * size**2
    metric = np.zeros((2, 6, 6))
    metric[:] = 2.0 * mass * np.diag([1, 1, size**2 / 6, size**2 / 12, size**2 / 12, size**2 / 24])
    metric /= dt**2
    metric[:, 3:, 3:] += 1e10 * size**2 * np.eye(3)
    fixed = np.array([True, False])
    push = push_out_displacement(metric, fixed, contacts, rows, np.array([1e-6]), np.zeros(1))
    cleared = -(rows.normal_i[0] @ push[1])
    assert cleared == pytest.approx(1e-6, rel=1e-9)


@pytest.mark.parametrize("dt", [1e-3, 1e-4, pytest.param(1e-5, marks=pytest.mark.slow)])
def test_a_rock_block_drawn_into_its_base_is_lifted_out_without_energy(dt):
    """cases/verify/overlap.toml with rock (E = 1e10 Pa, 2600 kg/m³): its corner, 2e-5 m in,
    under its centroid, is lifted out by d exactly (the least rigid push) and the block's
    energy stays 0 at every Δt (the step-energy push strained it instead: 0.16, 2.9 and
    3.1 J at Δt = 1e-3, 1e-4 and 1e-5 s, as much as moved)."""
    raw = tomllib.loads((CASES / "verify" / "overlap.toml").read_text())
    raw["materials"]["soft"].update(density=2600.0, young=1e10)
    raw["analysis"].update(time_step=dt, steps=20)
    result = dda.simulate(dda.load_scene(raw))
    row = result.frames[0].block("block")
    lifted = result.frames[1].centroids[row, 1] - result.frames[0].centroids[row, 1]
    assert lifted == pytest.approx(2e-5, rel=1e-6)
    excess, _, _ = energy_excess(result.history, result.summary["initial_energy"], False)
    assert excess <= 0.0
    assert result.history["kinetic_energy"].max() == 0.0


def test_the_pushed_blocks_pay_for_the_push_with_their_motion():
    """A 2 kg block (M = 2 I on its translations) moving at (3, 4) m/s, pushed at a cost of
    0.01962 J (m g e for 1 mm up): its kinetic energy 25 J falls by that, the block the
    push left alone keeps its speed; no cost, no change; a cost beyond its motion stops
    it."""
    masses = np.zeros((2, 6, 6))
    masses[:, [0, 1], [0, 1]] = 2.0
    masses[:, 2, 2] = 1.0
    velocity = np.array([[3.0, 4.0, 0, 0, 0, 0], [1.0, 0, 0, 0, 0, 0]])
    pushed = np.array([[0.0, 1e-3, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]])
    cost = 2.0 * 9.81 * 1e-3
    pay_for_the_push(velocity, pushed, masses, cost)
    kinetic = 0.5 * np.einsum("ni,nij,nj->n", velocity, masses, velocity)
    np.testing.assert_allclose(kinetic, [25.0 - cost, 1.0], rtol=1e-12)
    kept = velocity.copy()
    pay_for_the_push(kept, pushed, masses, -cost)
    np.testing.assert_array_equal(kept, velocity)
    slow = np.array([[0.0, 0.1, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]])  # 0.01 J < the cost
    pay_for_the_push(slow, pushed, masses, cost)
    assert not slow.any()


@pytest.mark.parametrize("weight", ["gravity", "point load"])
def test_a_sliding_block_found_in_its_base_pays_for_its_push(weight):
    """cases/verify/overlap.toml's block (rock, 1 m/s along its base, its corner found
    2e-5 m in) under its weight as gravity or as an equal point load: the push lifts it
    against either, and it pays with its motion (0.50 J above E0 + W unpaid against the
    load, when only a lift against gravity was paid)."""
    raw = tomllib.loads((CASES / "verify" / "overlap.toml").read_text())
    raw["materials"]["soft"].update(density=2600.0, young=1e10)
    raw["analysis"].update(time_step=1e-3, steps=20)
    raw["blocks"][1]["velocity"] = [1.0, 0.0, 0.0]
    if weight == "gravity":
        raw["analysis"]["gravity"] = [0.0, -9.81]
    else:
        force = [0.0, -2600.0 * 9.81]
        raw["loads"] = [{"block": "block", "point": [0.0, 0.7071], "force": force}]
    result = dda.simulate(dda.load_scene(raw))
    excess, moved, _ = energy_excess(result.history, result.summary["initial_energy"])
    assert excess <= 1e-9 * moved


FAN = Path(__file__).parent / "fan_of_four.toml"


def test_a_node_of_four_frictionless_wedges_parting_makes_no_energy():
    """A square cut along both diagonals into four frictionless wedges on a base (a
    helper's scene): the side wedges part, the top one sinks between them, and its apex
    is found 0.2-0.6 mm inside the bottom one (the node kept them apart while the side
    corners were within the contact tolerance); the push lifted it out and its motion
    stayed: 1.4 J above E0 + W (3.5 J before the face-to-face pairing). The pushed
    blocks pay for the lift: none above E0 + W at any step."""
    result = dda.simulate(dda.load_scene(FAN))
    excess, moved, _ = energy_excess(result.history, result.summary["initial_energy"])
    assert moved > 1e3
    assert excess <= 1e-9 * moved
    # its time is a stage of its own (an audit: 330 s of a 362 s run in the push, which
    # stage_seconds hid)
    assert result.summary["stage_seconds"]["push_out"] > 0.0
