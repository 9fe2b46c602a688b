"""Blocks on an incline, for the stick and slip tests: scenes, runs and closed forms.

A w x h block (ρ = 2700 kg/m³, E = 1e9 Pa, ν = 0.25) rests on a fixed slab inclined at
θ, with joints of friction angle φ set by the ratio tan θ / tan φ; it is released from
rest with every contact spring unloaded in the scene (the usual DDA scene). Runs are
cached per process: the stick tests and the energy tests read the same runs.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

import dda
from tests.helpers import G, rectangle, rotated

ROCK_1E9 = {"density": 2700.0, "young": 1e9, "poisson": 0.25}
THETA = 30.0  # degrees
SLAB = 20.0  # m along the slope
METHODS = ("augmented-lagrangian", "penalty")
STEPS = (1e-3, 2.5e-4, 1e-4, 2.5e-5)  # Δt of the matrices


def friction_angle(ratio: float, theta: float = THETA) -> float:
    """φ (degrees) with tan θ / tan φ = ``ratio``."""
    return math.degrees(math.atan(math.tan(math.radians(theta)) / ratio))


def sliding_distance(ratio: float, t: float, theta: float = THETA) -> float:
    """½ g (sin θ − cos θ tan φ) t² (rigid block, Coulomb friction)."""
    th = math.radians(theta)
    tan_phi = math.tan(th) / ratio
    return 0.5 * G * (math.sin(th) - math.cos(th) * tan_phi) * t * t


def incline_scene(
    ratio: float,
    time_step: float,
    duration: float,
    penalty_factor: float = 10.0,
    method: str = "augmented-lagrangian",
    stack: int = 1,
    width: float = 1.0,
    height: float = 1.0,
    theta: float = THETA,
) -> dict:
    """``stack`` blocks of ``width`` x ``height`` on the slab, each on the one below,
    the lowest 4 m up the slope; the engine's default physics (start, damping)."""
    young = ROCK_1E9["young"]
    blocks = [
        {
            "name": "slope",
            "material": "rock",
            "fixed": True,
            "vertices": rotated(rectangle(0.0, -1.0, SLAB, 0.0), theta),
        }
    ]
    for k in range(stack):
        y0 = k * height
        corners = rectangle(4.0, y0, 4.0 + width, y0 + height)
        blocks.append({"name": f"b{k}", "material": "rock", "vertices": rotated(corners, theta)})
    return {
        "analysis": {
            "time_step": time_step,
            "duration": duration,
            "gravity": [0.0, -G],
            "save_every": max(1, round(2e-3 / time_step)),
        },
        "contact": {"method": method, "penalty": penalty_factor * young},
        "materials": {"rock": dict(ROCK_1E9)},
        "joints": {"default": {"friction_angle": friction_angle(ratio, theta)}},
        "blocks": blocks,
    }


@cache
def run(*scene_args, mode: str = "dynamic", **scene_kwargs) -> dda.Result:
    """The run of ``incline_scene(*scene_args, **scene_kwargs)`` in ``mode`` (cached)."""
    scene = incline_scene(*scene_args, **scene_kwargs)
    scene["analysis"]["mode"] = mode
    return dda.simulate(scene)


def largest_move(result: dda.Result) -> float:
    """The largest centroid displacement of any free block over the kept frames."""
    return max(float(np.linalg.norm(f.displacements[1:], axis=1).max()) for f in result.frames)


def settlement(
    ratio: float, penalty_factor: float, method: str = "augmented-lagrangian", **shape
) -> float:
    """The elastic settlement: the largest centroid displacement of a static run (Shi's
    static analysis: every step from rest, 300 steps of 1e-3 s, settled to round-off);
    ``shape``: ``stack``, ``width``, ``height`` of :func:`incline_scene`."""
    return largest_move(run(ratio, 1e-3, 0.3, penalty_factor, method, mode="static", **shape))


def largest_gain(result: dda.Result) -> float:
    """max over steps of (T + V + U + C − W − E₀) / E₀."""
    h = result.history
    e0 = result.summary["initial_energy"]
    return float(np.max(h["total_energy"] - h["external_work"] - e0) / e0)
