"""The motion cases' closed forms, the AL rate and the turned scene (no engine runs)."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from verify.al_rate import predicted_solves
from verify.cases import discover
from verify.motion import (
    free_block,
    observed_order,
    rocking,
    slide,
    turned_stress,
    vertex_motion,
    with_time_step,
)
from verify.turn import turned_scene

CASES = {c.name: c for c in discover()}


def scene_of(name: str):
    return dda.load_scene(CASES[name].scene_path)


def test_slide_acceleration_is_coulombs():
    scene = scene_of("slide")
    t = np.array([0.0, 0.5, 1.0])
    motion = slide(scene, free_block(scene), t)
    a = 9.81 * (np.sin(np.radians(30)) - np.tan(np.radians(25)) * np.cos(np.radians(30)))
    down = -np.array([np.cos(np.radians(30)), np.sin(np.radians(30))])
    assert motion.u == pytest.approx(np.outer(0.5 * a * t**2, down), abs=1e-9)
    assert a == pytest.approx(0.9434, abs=1e-4)


def test_stick_and_pushed_references():
    stick = scene_of("stick")
    assert np.all(slide(stick, free_block(stick), np.array([1.0])).u == 0.0)
    pushed = scene_of("pushed")
    u = slide(pushed, free_block(pushed), np.array([1.0])).u[0]
    assert u[0] == pytest.approx(0.5 * (20000 / 2700 - 9.81 * np.tan(np.radians(30))), rel=1e-9)
    assert u[1] == pytest.approx(0.0, abs=1e-12)


def test_rocking_reference_lands_at_housners_time():
    scene = scene_of("rocking")
    t = np.linspace(0.0, 0.4, 41)
    motion = rocking(scene, free_block(scene), t)
    assert motion.events["impact"] == pytest.approx(0.41854866, abs=1e-7)
    assert motion.r[0] == 0.0 and motion.r[-1] > 0.08  # falls back anticlockwise to 0.1
    # the pivot stays put: centroid motion is the turn of the arm about it
    assert np.linalg.norm(motion.u[-1]) == pytest.approx(
        2 * np.hypot(0.25, 1.0) * np.sin(motion.r[-1] / 2), rel=1e-9
    )


def test_observed_order_and_round_off():
    assert observed_order(4e-4, 2e-4, 2.0) == pytest.approx(1.0)
    assert observed_order(4e-4, 1e-4, 2.0) == pytest.approx(2.0)
    assert np.isnan(observed_order(0.0, 0.0, 2.0))


def test_vertex_motion_sees_rotation_and_strain_and_turned_stress_is_r_sigma_rt():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    angle = 7.0  # beyond 2 pi: the multiple nearest the engine's sum is added
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    stretched = square @ np.diag([1.001, 1.0]).T @ turn.T
    r, strain = vertex_motion(square, stretched, 7.0)
    assert r == pytest.approx(angle, abs=1e-12)
    # V - I in the current axes: the stretch along the turned x axis
    expected = 0.001 * np.array([np.cos(angle) ** 2, np.sin(angle) ** 2, np.sin(2 * angle)])
    assert strain == pytest.approx(expected, abs=1e-12)
    sigma = turned_stress(np.array([1.0, 0.0, 0.0]), np.array([np.pi / 2, np.pi / 4]))
    assert sigma == pytest.approx(np.array([[0.0, 1.0, 0.0], [0.5, 0.5, 0.5]]), abs=1e-12)


def test_time_step_factors_keep_duration_and_frame_times():
    scene = scene_of("rocking")
    coarse = with_time_step(scene, 4)
    a, b = scene.analysis, coarse.analysis
    assert b.time_step * b.steps == pytest.approx(a.time_step * a.steps)
    assert b.time_step * b.save_every == pytest.approx(a.time_step * a.save_every)


def test_al_rate_prediction():
    solves, rate = predicted_solves(scene_of("al_rate"))
    assert rate == pytest.approx(1.08e8 / (1.08e8 + 1e10), rel=1e-9)
    assert solves == 4


def test_turned_scene_turns_blocks_and_points_not_forces():
    scene = scene_of("swing")
    back = turned_scene(scene, -np.degrees(0.6), (0.5, 2.0))
    assert np.asarray(back.blocks[0].vertices) == pytest.approx(
        np.array([[0, 0], [1, 0], [1, 2], [0, 2]]), abs=1e-9
    )
    assert back.blocks[0].fixed_points[0] == pytest.approx((0.5, 2.0))
    loaded = scene_of("pushed")
    turned = turned_scene(loaded, 90.0, (0.0, 0.0))
    assert turned.loads[0].point == pytest.approx((-0.5, 0.0))
    assert turned.loads[0].force == loaded.loads[0].force


def test_motion_case_reports_its_dt_study_and_draws_its_picture(tmp_path):
    import json

    from verify.cli import main

    code = main(["rocking", "-o", str(tmp_path), "--no-convergence", "--no-refinement"])
    assert code == 0
    case = json.loads((tmp_path / "report.json").read_text())["cases"][0]
    study = case["dt_study"]
    assert study["time_steps"] == pytest.approx([0.02, 0.01, 0.005])
    assert study["observed_order"]["r"] == pytest.approx(0.97, abs=0.05)
    assert study["expected_order"] == 1.0
    assert (tmp_path / "images" / "verify_rocking.png").stat().st_size > 20_000
    assert "observed order in Δt" in (tmp_path / "report.md").read_text()


def test_motion_expectations_are_checked_on_loading(tmp_path):
    from verify.expect import MOTION_REFERENCES, ExpectationError, load_expectation
    from verify.motion import REFERENCES

    assert set(MOTION_REFERENCES) == set(REFERENCES)
    path = tmp_path / "x.expect.toml"
    path.write_text('kind = "motion"\nreference = "drop"\n')
    with pytest.raises(ExpectationError, match="reference"):
        load_expectation(path)
    path.write_text('kind = "motion"\nreference = "free"\ntime_steps = [4, 2]\n')
    with pytest.raises(ExpectationError, match="time_steps"):
        load_expectation(path)
