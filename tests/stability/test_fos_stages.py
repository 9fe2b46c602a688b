"""Strength reduction of a scene with ``[[stages]]``: the stages run with the scene's own
strengths, and the reduction comes after them, at the end of the scene's run T_r.

The scene: a 1 × 1 m block on a plane at θ = 30° (tan φ / tan θ = 1.3), held in front
by a fixed stop block that a stage removes at 1/4 s; the run ends at T_r = 1/2 s.
Freed, the block stands on its friction alone, so its factor of safety is the
limit-equilibrium one, FoS = tan φ / tan θ.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dda
from dda.stability.criterion import criterion_of
from dda.stability.fos import factor_of_safety
from dda.stability.trial import Trial, run_trial, trial_scene
from tests.helpers import rectangle, rotated
from tests.standing.incline import incline_scene

THETA, FOS = 30.0, 1.3
PHI = math.degrees(math.atan(FOS * math.tan(math.radians(THETA))))
REMOVED, T_R = 0.25, 0.5


def held_block() -> dict:
    """The block with the stop block in front of it (x < 4 along the slope), removed
    by a stage at 1/4 s; Δt = 0.025 s, a run of 1/2 s."""
    scene = incline_scene(1.0, 0.025, T_R, theta=THETA)
    scene["joints"]["default"] = {"friction_angle": PHI}
    stop = rotated(rectangle(3.0, 0.0, 4.0, 0.5), THETA)
    scene["blocks"].append({"name": "stop", "material": "rock", "fixed": True, "vertices": stop})
    scene["stages"] = [{"time": REMOVED, "remove": ["stop"]}]
    return scene


def test_the_stages_run_with_the_given_strengths_and_the_reduction_comes_after():
    scene = dda.load_scene(held_block())
    criterion = criterion_of(scene)
    assert (criterion.start, criterion.end) == (T_R, 2 * T_R)
    assert T_R < criterion.judged_from == pytest.approx(T_R + 0.8 * T_R)
    trial = trial_scene(scene, 2.0)
    assert trial.joints == scene.joints  # the scene's own strengths ...
    assert [(s.time, s.strength_factor) for s in trial.stages] == [(REMOVED, None), (T_R, 2.0)]
    assert trial.analysis.duration == 2 * T_R
    frames = dda.simulate(trial).frames
    times = np.array([f.time for f in frames])
    moved = np.array([np.linalg.norm(f.displacements[-1]) for f in frames])  # the block
    assert moved[times <= REMOVED].max() < 1e-8  # ... hold it, with its stop, ...
    # ... and without: the stop carried part of the load from the equilibrium start, and
    # the joint's springs take it up (measured 1.03e-5 m); reduced by 2 from t = 0 it
    # would have slid ½ g (sin θ − cos θ tan φ / 2) (1/4 s)² = 0.054 m by T_r
    assert moved[times <= T_R].max() < 1e-4
    assert moved[-1] > 0.1  # F = 2: tan φ / F < tan θ, it slides after T_r


@pytest.mark.parametrize(("factor", "fails"), [(1.2, False), (1.4, True)])
def test_a_staged_trial_stands_below_the_fos_and_fails_above(factor, fails):
    row = run_trial(Trial(held_block(), factor))
    assert row["status"] == "ran"
    assert row["failed"] is fails, row


def test_dda_fos_finds_the_fos_of_the_staged_scene():
    answer, rows = factor_of_safety(held_block())
    assert answer.verdict == "found"
    assert abs(answer.fos - FOS) <= 0.02, answer
    assert answer.stands <= FOS <= answer.fails
    assert all(r["status"] == "ran" for r in rows)
