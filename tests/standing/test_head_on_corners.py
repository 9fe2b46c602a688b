"""Corners that meet head-on within a step: a block dropped flush onto a thin plate.

The block's bottom corners are in line with the plate's top corners: each projects onto
an end of the other's edge, so no vertex-edge contact holds them, and the vertex radius
of a pair is a quarter of the plate's 5 mm edges. A gap wider than that closed in one
step used to let the block through the plate (20 m/s, Δt = 1e-3 s: it left the far side
at 20 m/s); the contact search now pairs corners that meet within the coming step
(dda.contact.candidate_tests.corners_meet).
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
from tests.helpers import rectangle
from tests.standing.scenes import block, scene

THICKNESS = 0.005  # m, the plate
GAP = 0.01  # m, between the block and the plate at t = 0
SPEED = 20.0  # m/s, the block's, down


def plate_drop(method: str, dt: float) -> dict:
    """A free 1 m block falling at ``SPEED`` onto a fixed plate ``GAP`` below it, no
    gravity, frictionless, every step kept; steps of up to 0.9 of the largest displacement
    the analysis allows (the default, 0.1, cuts Δt = 1e-3 s to steps that close the gap
    in several)."""
    plate = block("plate", rectangle(0.0, -THICKNESS, 1.0, 0.0), fixed=True)
    falling = block("block", rectangle(0.0, GAP, 1.0, 1.0 + GAP), velocity=[0.0, -SPEED, 0.0])
    analysis = {"time_step": dt, "duration": 0.03, "gravity": [0.0, 0.0], "save_every": 1,
                "max_displacement_ratio": 0.9}  # fmt: skip
    return scene([plate, falling], analysis, {"method": method}, friction=0.0)


@pytest.mark.parametrize("dt", [1e-3, 2.5e-4, 1e-4])
def test_a_block_dropped_flush_onto_a_thin_plate_bounces_off_it(dt):
    """At every step the block's lowest point stays above the plate within twice the
    contact tolerance (1e-5 m; the augmented Lagrangian's deepest: 1.005e-5 m at
    Δt = 1e-3 s, 3.6e-6 and 8.6e-6 m at 2.5e-4 and 1e-4 s), it leaves upwards (at 4.4,
    8.1 and 8.1 m/s: Shi's update damps the impact), and its energy never exceeds E0 (by
    1e-9 E0). Before, at Δt = 1e-3 s it passed through the plate at 20 m/s."""
    result = dda.simulate(dda.load_scene(plate_drop("augmented-lagrangian", dt)))
    lowest = min(float(frame.vertices[1][:, 1].min()) for frame in result.frames)
    assert lowest > -2e-5
    assert result.final.velocities[1][1] > 0.0
    history, e0 = result.history, result.summary["initial_energy"]
    assert np.max(history["total_energy"] - history["external_work"]) <= e0 * (1 + 1e-9)
