"""Below a water table the fracture criterion judges effective stress (Terzaghi).

A 1 x 2 m rock column (c = 20 kPa, φ = 30°, T0 = 5 kPa) on a fixed base, loaded by
300 kN on its top, under water. The water's pressure on every face compresses the
block by about the pore pressure p at its centroid (γw times the depth), and the
criterion is met by σ' = σ + p I: the column breaks in shear at its first step
whatever the water's depth, with the same σ'yy; judged on the total stress it did not
break at all under 20 m or 50 m of water (its σ from (−64, −356) kPa at 5 m to (−433,
−797) kPa at 50 m: the deeper the water, the stronger the rock).
"""

from __future__ import annotations

import pytest

import dda
from tests.helpers import rectangle


def column(level: float, water: bool = True) -> dict:
    rock = {
        "density": 2700.0,
        "young": 5e9,
        "poisson": 0.25,
        "cohesion": 20e3,
        "friction_angle": 30.0,
        "tensile_strength": 5e3,
    }
    scene = {
        "analysis": {"time_step": 1e-3, "steps": 2, "gravity": [0.0, -9.81]},
        "materials": {"rock": rock, "base": {"density": 2700.0, "young": 5e9, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 30.0}},
        "fracture": {"min_area": 0.05},
        "blocks": [
            {"name": "base", "material": "base", "fixed": True,
             "vertices": rectangle(-2.0, -1.0, 2.0, 0.0)},
            {"name": "rock", "material": "rock", "vertices": rectangle(-0.5, 0.0, 0.5, 2.0)},
        ],
        "loads": [{"block": "rock", "point": [0.0, 2.0], "force": [0.0, -300e3]}],
    }  # fmt: skip
    if water:
        scene["water"] = {"table": [[-10.0, level], [10.0, level]], "unit_weight": 9810.0}
    return scene


def test_the_column_breaks_at_any_depth_of_water_on_the_same_effective_stress():
    first = {}
    for level in (5.0, 20.0, 50.0):
        result = dda.simulate(column(level), keep_frames=False)
        event = result.fracture_events[0]
        assert (event.step, event.parent, event.mode) == (1, "rock", "shear")
        first[level] = event.stress
    # σ'yy: the load and the buoyant weight, the same at every depth (within 1e-4)
    assert first[20.0][1] == pytest.approx(first[5.0][1], rel=1e-4)
    assert first[50.0][1] == pytest.approx(first[5.0][1], rel=1e-4)


def test_without_water_the_criterion_judges_the_stress_itself():
    result = dda.simulate(column(0.0, water=False), keep_frames=False)
    event = result.fracture_events[0]
    assert event.step == 1
    assert event.stress == pytest.approx(tuple(result.frames[0].stresses[1]), rel=1e-12)
