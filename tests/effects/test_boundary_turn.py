"""Boundary stresses turn with the loaded boundary's rigid turn
(dda.effects.boundary_stresses.BoundaryStresses, rigid_turn).

A model that boundary stresses alone hold, with nothing fixed, is balanced by them; under
forces of fixed directions its rigid turn is unstable (their moment θ Σ f·(x − c) grows
it). Measured before the forces turned: a free T of two blocks under (−1, −2, 0.2) MPa,
no gravity, turned 4.6e-10 rad by 0.1 s, 0.65 rad by 0.7 s and 4.96 rad by 0.8 s.
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.effects.base import StepContext
from dda.effects.boundary_stresses import rigid_turn
from dda.model import build
from tests.scene.test_in_situ import scene, square

FIELD = [-1.0e6, -2.0e6, 0.2e6]


def free_tee(duration: float = 0.8) -> dict:
    """A 3 × 1 m block with a 1 m block on it, in the field FIELD, held by its traction on
    every outer edge; nothing fixed, no gravity."""
    blocks = [
        {"name": "base", "material": "rock", "vertices": square(0.0, 0.0, 3.0, 1.0)},
        {"name": "top", "material": "rock", "vertices": square(1.0, 1.0, 2.0, 2.0)},
    ]
    raw = scene(
        blocks,
        duration=duration,
        in_situ={"stress": FIELD},
        boundary_stresses=[{"stress": FIELD, "box": [-1.0, -1.0, 4.0, 3.0]}],
    )
    raw["analysis"]["save_every"] = 1
    return raw


@pytest.mark.parametrize("angle", [1e-9, 0.3, -2.0])
def test_the_rigid_turn_of_turned_points_is_their_angle(angle):
    rng = np.random.default_rng(3)
    anchors = rng.uniform(-5.0, 5.0, (7, 2))
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    moved = anchors @ turn.T + [10.0, -4.0]
    assert rigid_turn(anchors, moved) == pytest.approx((np.cos(angle), np.sin(angle)), abs=1e-15)
    assert rigid_turn(anchors[:1], moved[:1]) == (1.0, 0.0)


def test_the_forces_turn_with_the_model_and_keep_their_balance():
    """Turn the whole T by 0.1 rad about a point: the forces turn by 0.1 rad, and their sum
    and moment are those of the forces before, turned (the pieces' own imbalance, 0.012 N
    of 3 MN, turned with them)."""
    model = build(dda.load_scene(free_tee()))
    loads = next(e for e in model.effects if e.name == "boundary_stresses")
    before = loads.current_forces(1e-3).copy()
    angle, pivot = 0.1, np.array([7.0, -3.0])
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    x0 = loads.points.positions - pivot
    loads.points.positions = x0 @ turn.T + pivot
    after = loads.current_forces(1e-3)
    scale = np.abs(before).max()
    assert after == pytest.approx(before @ turn.T, abs=1e-12 * scale)
    round_off = 1e-14 * scale * len(after)  # of a sum of 20 forces of up to 3 MN
    assert after.sum(axis=0) == pytest.approx(turn @ before.sum(axis=0), abs=round_off)
    x = loads.points.positions - pivot

    def moment(points, forces):
        return np.sum(points[:, 0] * forces[:, 1] - points[:, 1] * forces[:, 0])

    assert moment(x, after) == pytest.approx(moment(x0, before), abs=1e-8 * scale)


def test_a_model_held_by_boundary_stresses_alone_stands_as_it_is():
    """The free T stands for 0.8 s to round-off: it turns by 6e-15 rad and moves by 1e-13 m
    (with its outline's pieces 3e-9 m short of the corners, 1.1e-8 rad and 3.7e-7 m), and
    the energy never exceeds E0 and the loads' work."""
    result = dda.simulate(dda.load_scene(free_tee()))
    turns = np.array([frame.rotations for frame in result.frames])
    assert np.abs(turns).max() < 1e-12
    moved = np.array([frame.centroids - result.frames[0].centroids for frame in result.frames])
    assert np.abs(moved).max() < 1e-10
    history = result.history
    excess = history["total_energy"] - result.summary["initial_energy"] - history["external_work"]
    assert excess.max() <= 1e-9 * abs(result.summary["initial_energy"]) + 1e-9


def test_two_sets_pair_each_piece_start_with_its_end():
    """Points k and count + k are one outer edge piece's ends, on the same block, with two
    boundary-stress sets as with one (the ends of a piece split by fracture are found so)."""
    raw = free_tee()
    raw["boundary_stresses"] = [
        {"stress": FIELD, "box": [-1.0, -1.0, 4.0, 0.75], "name": "below"},
        {"stress": FIELD, "box": [-1.0, 0.75, 4.0, 3.0], "name": "above"},
    ]
    model = build(dda.load_scene(raw))
    loads = next(e for e in model.effects if e.name == "boundary_stresses")
    count = len(loads.points) // 2
    assert count == 8  # the base's bottom, two sides and two top parts; the top's three
    rows, positions = loads.points.rows, loads.points.positions
    assert np.array_equal(rows[:count], rows[count:])
    lengths = np.hypot(*(positions[count:] - positions[:count]).T)
    assert lengths.sum() == pytest.approx(3.0 + 1.0 + 1.0 + 2.0 + 3.0)
    assert np.all(lengths > 0.0)
    ctx = StepContext(dt=1e-3, time=1e-3, step=1, static=False)
    assert np.abs(loads.forces(model.blocks, ctx)[:, :2].sum(axis=0)).max() < 0.1  # of 3 MN
