"""The motion cases' closed forms, the AL rate and the turned scene (no engine runs)."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from verify.fem.turn import turned_scene
from verify.harness.cases import discover
from verify.references.al_rate import predicted_solves
from verify.references.block import free_block
from verify.references.impact import (
    deepest_vertex,
    drop_of,
    free_fall,
    mass_matrix,
    placed,
    strain_frequency,
)
from verify.references.motion import (
    observed_order,
    rocking,
    slide,
    turned_stress,
    vertex_motion,
    with_time_step,
)

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
    from verify.comparison.expect import MOTION_REFERENCES, ExpectationError, load_expectation
    from verify.harness.runners import MOTION_REFERENCES as REFERENCES
    from verify.harness.runners import SYSTEM_REFERENCES

    assert set(MOTION_REFERENCES) == set(REFERENCES) | set(SYSTEM_REFERENCES)
    path = tmp_path / "x.expect.toml"
    path.write_text('kind = "motion"\nreference = "bounce"\n')
    with pytest.raises(ExpectationError, match="reference"):
        load_expectation(path)
    path.write_text('kind = "motion"\nreference = "free"\ntime_steps = [4, 2]\n')
    with pytest.raises(ExpectationError, match="time_steps"):
        load_expectation(path)


def test_a_case_runs_under_its_own_engine_settings(tmp_path, monkeypatch):
    """``[environment]``: the engine's DDA_* variables, set while the case runs and
    restored after; any other variable is refused on loading."""
    import os

    from verify.comparison.expect import ExpectationError, load_expectation
    from verify.harness.cases import engine_environment

    path = tmp_path / "x.expect.toml"
    path.write_text('quick = true\n[environment]\nPATH = "/tmp"\n')
    with pytest.raises(ExpectationError, match="environment.PATH"):
        load_expectation(path)
    check = '[checks.stress]\ntolerance = 1e-6\nwhy = "the same"\n'
    path.write_text(f'quick = true\n[environment]\nDDA_SYSTEMS = "sparse"\n{check}')
    assert load_expectation(path).environment == {"DDA_SYSTEMS": "sparse"}
    monkeypatch.setenv("DDA_THREADS", "1")
    monkeypatch.delenv("DDA_SYSTEMS", raising=False)
    with engine_environment({"DDA_SYSTEMS": "sparse", "DDA_THREADS": "2"}):
        assert (os.environ["DDA_SYSTEMS"], os.environ["DDA_THREADS"]) == ("sparse", "2")
    assert "DDA_SYSTEMS" not in os.environ and os.environ["DDA_THREADS"] == "1"


def test_drop_reference_is_the_rigid_block_on_its_springs():
    scene = scene_of("drop")
    drop = drop_of(scene, free_block(scene))
    assert (drop.height, drop.landing, drop.penalty) == pytest.approx((0.01, 2, 5e6))
    assert drop.mass == pytest.approx(2700.0)
    assert drop.time == pytest.approx(np.sqrt(0.02 / 9.81), rel=1e-12)
    assert drop.speed == pytest.approx(0.442944692, rel=1e-9)
    assert drop.omega == pytest.approx(60.858062, rel=1e-7)
    # y'' = -g - w^2 y on the springs (y < 0), from y = 0 at -v: out again at +v after
    # (pi + 2 atan(g / (w v))) / w
    w, v, g = drop.omega, drop.speed, 9.81
    t = drop.contact_time
    y = -g / w**2 * (1 - np.cos(w * t)) - v / w * np.sin(w * t)
    speed = -g / w * np.sin(w * t) - v * np.cos(w * t)
    assert y == pytest.approx(0.0, abs=1e-15)
    assert speed == pytest.approx(v, rel=1e-12)  # e = 1
    assert t == pytest.approx(0.0630915, abs=1e-7)
    motion = free_fall(scene, free_block(scene), np.array([0.0, 0.04, 0.05]))
    assert motion.valid.tolist() == [True, True, False]
    assert motion.u[1] == pytest.approx([0.0, -0.5 * 9.81 * 0.04**2])
    assert motion.energy_scale == pytest.approx(2700 * 9.81 * 0.01)


def test_drop_reference_refuses_what_would_take_energy_or_has_no_base():
    from dataclasses import replace

    from verify.comparison.expect import ExpectationError

    scene = scene_of("drop")
    block = free_block(scene)
    rough = replace(scene, joints={"default": replace(scene.joints["default"], friction_angle=30)})
    with pytest.raises(ExpectationError, match="frictionless"):
        drop_of(rough, block)
    stiff = replace(scene, contact=replace(scene.contact, penalty=5e10))  # 10 E
    with pytest.raises(ExpectationError, match="strain modes"):
        drop_of(stiff, block)
    sunk = ((0.0, -0.1), *scene.blocks[block].vertices[1:])  # one corner in the base
    moved = replace(scene.blocks[block], vertices=sunk)
    with pytest.raises(ExpectationError, match="above a level fixed base"):
        drop_of(replace(scene, blocks=(scene.blocks[0], moved)), block)


def test_overlap_reference_measures_the_drawn_overlap():
    from dataclasses import replace

    from verify.comparison.expect import ExpectationError

    scene = scene_of("overlap")
    block = free_block(scene)
    overlap = deepest_vertex(scene, block)
    assert overlap.depth == pytest.approx(2e-5, rel=1e-9)
    assert overlap.normal == pytest.approx([0.0, 1.0])
    motion = placed(scene, block, np.array([0.0, 0.001, 0.002]))
    assert motion.energy_scale == pytest.approx(0.5 * 2700 * (2e-5 / 1e-3) ** 2, rel=1e-9)
    assert motion.valid.tolist() == [True, True, False]
    # the corner under the centroid moves out by d: the least rigid push lifts the block
    # by d (a turn does not move that corner along the normal) and strains nothing
    push = np.array(motion.events["push"])
    assert push[1] == pytest.approx(2e-5, rel=1e-12)
    assert push[[0, 2, 3, 4, 5]] == pytest.approx([0.0] * 5, abs=1e-15)
    assert motion.u[1] == pytest.approx([0.0, push[1]], abs=1e-15)
    loaded = replace(scene, analysis=replace(scene.analysis, start="equilibrium"))
    with pytest.raises(ExpectationError, match="unloaded"):
        placed(loaded, block, np.array([0.0]))


def test_mass_matrix_of_a_square_is_shis():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    m = mass_matrix(square, 1.0)
    i = 2.0**4 / 12  # integral of x^2 (and of y^2) about the centroid
    expected = np.diag([4.0, 4.0, 2 * i, i, i, i / 2])
    assert m == pytest.approx(expected, abs=1e-12)


def shi_rebound(height: float, g: float, mass: float, stiffness: float, dt: float) -> float:
    """The rebound coefficient of a rigid block dropped from ``height`` onto a spring, in
    Shi's scheme: each step D minimises ½ (2m/Δt²)(D − vΔt)² + m g D (+ ½ k (x + D)² while
    x + D < 0, the contact decided at the step's end), then v ← 2D/Δt − v."""
    inertia = 2.0 * mass / dt**2
    x, v, touched = height, 0.0, False
    while True:
        d = v * dt - mass * g / inertia
        if x + d < 0.0:
            d = (inertia * v * dt - mass * g - stiffness * x) / (inertia + stiffness)
        v, x = 2.0 * d / dt - v, x + d
        touched |= x < 0.0
        if touched and x > 0.0:
            return float(np.sqrt(v * v + 2.0 * g * x) / np.sqrt(2.0 * g * height))


def test_drop_case_rebound_is_shis_update_and_converges_at_first_order(tmp_path):
    import json

    from verify.cli import main

    code = main(["drop", "-o", str(tmp_path), "--no-convergence", "--no-refinement"])
    assert code == 0
    study = json.loads((tmp_path / "report.json").read_text())["cases"][0]["dt_study"]
    assert study["time_steps"] == pytest.approx([2.5e-3, 1.25e-3, 6.25e-4])
    assert study["rebound"] == pytest.approx([0.81719, 0.90573, 0.95236], abs=1e-5)
    # the loss is the integrator's: a rigid block on two springs (no strain modes)
    # in Shi's scheme rebounds the same, to 5e-5
    for dt, e in zip(study["time_steps"], study["rebound"], strict=True):
        assert e == pytest.approx(shi_rebound(0.01, 9.81, 2700.0, 1e7, dt), abs=1e-4)
    assert study["observed_order"]["e"] == pytest.approx(0.985, abs=0.01)
    assert study["rebound_limit"] == pytest.approx(1.0, abs=2e-3)
    assert study["events"]["contact_time"] == pytest.approx(0.0630915, abs=1e-7)
    assert (tmp_path / "images" / "verify_drop.png").stat().st_size > 20_000


def test_drop_limit_is_one_for_the_block_with_its_strain_modes():
    """Δt → 0: the drop scene's block (translation v0 and strains ex, ey; the turn and
    shear stay 0 by symmetry, no friction) on its two corner springs, integrated with
    scipy from the first touch until it is in flight again, rebounds at 1 − 4e-8: the
    strain modes (69 times as fast as the springs) give their energy back."""
    from scipy.integrate import solve_ivp

    scene = scene_of("drop")
    block = free_block(scene)
    drop = drop_of(scene, block)
    assert strain_frequency(scene, block) == pytest.approx(np.sqrt(5e9 / 1.25 / 225), rel=1e-9)
    assert strain_frequency(scene, block) / drop.omega == pytest.approx(69.28, abs=0.01)
    g, h, p = drop.gravity, drop.height, drop.penalty
    mass = mass_matrix(np.asarray(scene.blocks[block].vertices), 2700.0)[[1, 3, 4]][:, [1, 3, 4]]
    c = 5e9 / (1 - 0.25**2) * np.array([[1.0, 0.25], [0.25, 1.0]])  # plane stress, S = 1
    lever = np.array([1.0, 0.0, -0.5])  # a lower corner's uy from (v0, ex, ey)
    inverse = np.linalg.inv(mass)

    def rhs(_t, y):
        q, v = y[:3], y[3:]
        force = -np.concatenate([[0.0], c @ q[1:]]) - [drop.mass * g, 0.0, 0.0]
        force = force + 2 * p * max(-(h + lever @ q), 0.0) * lever
        return np.concatenate([v, inverse @ force])

    start = [-h, 0.0, 0.0, -drop.speed, 0.0, 0.0]  # at the first touch
    end = drop.time + 1.3 * drop.contact_time
    sol = solve_ivp(rhs, (drop.time, end), start, method="DOP853", rtol=1e-11, atol=1e-14)
    uy, vy = sol.y[0, -1], sol.y[3, -1]
    assert h + lever @ sol.y[:3, -1] > 0.0  # in flight
    e = np.sqrt(vy * vy + 2 * g * (uy + h)) / drop.speed
    assert 1 - e == pytest.approx(0.0, abs=1e-6)


def test_newmark_reference_slides_the_block_by_newmarks_d_relative_to_the_base():
    from verify.references.shaking import ground_displacement, newmark

    scene = scene_of("shaken")
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    motion = newmark(scene, free_block(scene), t)
    mu_g, a, t0 = 9.81 * np.tan(np.radians(20.0)), 0.6 * 9.81, 0.2
    assert motion.events["stop"] == pytest.approx(a * t0 / mu_g, rel=1e-12)
    assert motion.events["slide"] == pytest.approx(0.076340, abs=5e-7)
    # the ground's exact integral of the pulse (its 1e-9 s ramp aside) minus the block's
    ground = ground_displacement(np.array([[0.0, a], [t0, a], [t0 + 1e-9, 0.0]]), t)
    exact = np.where(t <= t0, 0.5 * a * t**2, a * t0 * (t - t0 / 2))
    assert ground == pytest.approx(exact, abs=1e-8)
    assert motion.events["slide_at_end"] == pytest.approx(motion.events["slide"], abs=1e-8)
    assert motion.u[:3, 0] == pytest.approx(0.5 * mu_g * t[:3] ** 2, rel=1e-12)
    assert not motion.u[:, 1].any() and not motion.r.any()


def test_water_force_is_gamma_area_normal_to_a_table_parallel_to_the_slope():
    from verify.references.motion import applied_force
    from verify.references.water import uniform_under_table, water_force

    scene = scene_of("wet_slide")
    block = free_block(scene)
    up = np.array([-np.sin(np.radians(30.0)), np.cos(np.radians(30.0))])
    lift = 9810.0 * 2.0 / np.cos(np.radians(30.0))  # γw A (−h′, 1), h′ = tan 30°
    assert water_force(scene, block) == pytest.approx(lift * up, rel=1e-9)
    assert uniform_under_table(scene, block)
    a = 9.81 * np.sin(np.radians(30.0)) - np.tan(np.radians(25.0)) * (
        9.81 * np.cos(np.radians(30.0)) - 9810.0 / (2700.0 * np.cos(np.radians(30.0)))
    )
    assert a == pytest.approx(2.8997, abs=1e-4)
    motion = slide(scene, block, np.array([0.5]))
    assert np.linalg.norm(motion.u[0]) == pytest.approx(0.5 * a * 0.25, rel=1e-9)
    assert applied_force(scene_of("slide"), block)[0] == 0.0  # dry: the weight alone


def test_a_partly_wet_block_has_no_slide_reference():
    from dataclasses import replace

    from verify.comparison.expect import ExpectationError

    scene = scene_of("wet_slide")
    low = replace(scene.water, table=((-20.0, 0.0), (20.0, 0.0)))
    with pytest.raises(ExpectationError, match="water"):
        slide(replace(scene, water=low), free_block(scene), np.array([0.1]))


def test_bolt_reference_oscillates_about_f0_over_k_with_period_two_pi_root_m_over_k():
    from verify.references.bolt import bolt

    scene = scene_of("bolted")
    motion = bolt(scene, free_block(scene), np.array([0.0, 0.25, 0.5, 1.0]))
    assert motion.events["period"] == pytest.approx(1.0, rel=1e-12)
    amplitude = 1000.0 / (2700.0 * (2 * np.pi) ** 2)
    assert motion.u[:, 0] == pytest.approx([0.0, amplitude, 2 * amplitude, 0.0], abs=1e-15)
    assert motion.energy_scale == pytest.approx(0.5 * 1000.0 * amplitude, rel=1e-12)
