"""Below a water table the fracture criterion judges a block's total stress: the blocks
are impervious, and the water's pressure on their faces confines them (docs/fracture.md).

A 1 x 2 m rock column (c = 20 kPa, φ = 30°, T0 = 5 kPa) on a fixed base, under 300 kN
on its top: under 5 m of water it breaks in shear at its first step; under 50 m the
water's pressure on its faces, γw h ≈ 0.45 MPa more compression on every face, holds it
(σ from (−64, −356) kPa to (−433, −797) kPa): the Mohr–Coulomb criterion of a confined
specimen.
"""

from __future__ import annotations

import dda
from tests.helpers import rectangle


def column(level: float) -> dict:
    rock = {
        "density": 2700.0,
        "young": 5e9,
        "poisson": 0.25,
        "cohesion": 20e3,
        "friction_angle": 30.0,
        "tensile_strength": 5e3,
    }
    return {
        "analysis": {"time_step": 1e-3, "steps": 2, "gravity": [0.0, -9.81]},
        "materials": {"rock": rock, "base": {"density": 2700.0, "young": 5e9, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 30.0}},
        "fracture": {"min_area": 0.05},
        "water": {"table": [[-10.0, level], [10.0, level]], "unit_weight": 9810.0},
        "blocks": [
            {"name": "base", "material": "base", "fixed": True,
             "vertices": rectangle(-2.0, -1.0, 2.0, 0.0)},
            {"name": "rock", "material": "rock", "vertices": rectangle(-0.5, 0.0, 0.5, 2.0)},
        ],
        "loads": [{"block": "rock", "point": [0.0, 2.0], "force": [0.0, -300e3]}],
    }  # fmt: skip


def test_deep_water_confines_an_impervious_block():
    shallow = dda.simulate(column(5.0), keep_frames=False)
    assert [(e.step, e.parent, e.mode) for e in shallow.fracture_events[:1]] == [
        (1, "rock", "shear")
    ]
    deep = dda.simulate(column(50.0))
    assert not deep.fracture_events
    sxx, syy, _ = deep.frames[0].stresses[deep.frames[0].block("rock")]
    assert sxx < -4.0e5 and syy < -7.5e5  # the water's confinement, about γw × 45 m more
