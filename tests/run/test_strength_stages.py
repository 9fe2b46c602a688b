"""A ``[[stages]]`` entry with ``strength_factor``: the joints' strengths divided from its
time on (tan φ / F, c / F, T / F).

Expectation: a rigid block on a plane at θ = 30° with φ = 40° stands (tan φ > tan θ);
from a stage with tan φ / F < tan θ on it slides from rest with the Coulomb closed form

    s(t) = ½ g (sin θ − cos θ tan φ / F) (t − t_s)²,

t_s the stage's time. Times are binary fractions (Δt = 1/128 s, t_s = 1/8 s) so that
the stage shortens no step: a stage with F = 1 must then repeat the run without it to
the bit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dda
from dda.errors import SceneError
from tests.helpers import G
from tests.standing.checks import check_energy
from tests.standing.incline import incline_scene

THETA, PHI = 30.0, 40.0
DT, STAGE, DURATION = 1.0 / 128.0, 0.125, 0.5


def block(factor: float | None = None, **stage) -> dict:
    """The block on the plane at θ with φ = 40°, a stage at t_s dividing by ``factor``."""
    scene = incline_scene(1.0, DT, DURATION, theta=THETA)
    scene["joints"]["default"] = {"friction_angle": PHI}
    scene["analysis"]["save_every"] = 1
    if factor is not None:
        scene["stages"] = [{"time": STAGE, "strength_factor": factor, **stage}]
    return scene


def closed_form(factor: float, t: float) -> float:
    th = math.radians(THETA)
    a = G * (math.sin(th) - math.cos(th) * math.tan(math.radians(PHI)) / factor)
    return 0.5 * a * t * t


def test_the_block_stands_until_the_stage_then_slides_as_the_closed_form():
    factor = 2.0  # tan 40° / 2 = 0.42 < tan 30° = 0.58
    result = dda.simulate(block(factor))
    assert result.summary["status"] == "finished"
    assert result.summary["cut_steps"] == 0
    times = np.array([f.time for f in result.frames])
    centroid = np.array([f.centroids[1] for f in result.frames])
    k = int(np.flatnonzero(times == STAGE)[0])
    assert np.linalg.norm(centroid[: k + 1] - centroid[0], axis=1).max() < 1e-8
    slid = float(np.linalg.norm(centroid[-1] - centroid[k]))
    exact = closed_form(factor, DURATION - STAGE)
    assert slid == pytest.approx(exact, rel=1e-3)  # measured: 3.6e-5
    check_energy(result)  # never above E0 + W


def test_a_factor_of_one_changes_nothing():
    plain = dda.simulate(block())
    staged = dda.simulate(block(1.0))
    assert staged.summary["stages_done"] == 1
    for name, values in plain.history.items():
        assert np.array_equal(values, staged.history[name]), name
    assert np.array_equal(plain.final.centroids, staged.final.centroids)
    assert np.array_equal(plain.final.velocities, staged.final.velocities)


def test_a_later_stage_replaces_the_factor():
    """F = 2 at t_s, then F = 1 (the scene's own strengths) at 1/4 s: the block slides,
    then friction brings it to rest after v² / 2 a₂ more, a₂ = g (cos θ tan φ − sin θ)."""
    scene = block(2.0)
    scene["stages"].append({"time": 0.25, "strength_factor": 1.0})
    result = dda.simulate(scene)
    times = np.array([f.time for f in result.frames])
    moved = np.array([np.linalg.norm(f.centroids[1] - result.frames[0].centroids[1])
                      for f in result.frames])  # fmt: skip
    th = math.radians(THETA)
    speed = 2.0 * closed_form(2.0, 0.125) / 0.125
    stop = G * (math.cos(th) * math.tan(math.radians(PHI)) - math.sin(th))
    exact = closed_form(2.0, 0.125) + speed * speed / (2.0 * stop)
    # the stop falls inside a step: measured −9.3e-4
    assert moved[-1] == pytest.approx(exact, rel=2e-3)
    assert np.ptp(moved[times > 0.4]) < 1e-6  # at rest (measured 1.3e-7 m)
    check_energy(result)


@pytest.mark.parametrize(
    ("stage", "reason"),
    [
        ({"strength_factor": 0.0}, "stages[0].strength_factor: must be > 0"),
        ({"strength_factor": -2.0}, "stages[0].strength_factor: must be > 0"),
        ({"strength_factor": math.inf}, "stages[0].strength_factor: must be finite"),
        ({"strength_factor": "2"}, "stages[0].strength_factor: expected a number"),
        ({"intact": True}, "stages[0].intact: needs strength_factor"),
        ({"strength_factor": 2.0, "intact": 1}, "stages[0].intact: expected true or false"),
    ],
)
def test_a_bad_strength_factor_is_refused_naming_its_key(stage, reason):
    raw = block()
    raw["stages"] = [{"time": STAGE, **stage}]
    with pytest.raises(SceneError) as caught:
        dda.load_scene(raw)
    assert reason in str(caught.value)
    assert "\n" not in str(caught.value)


def test_a_run_resumed_after_the_stage_keeps_the_reduced_strengths(tmp_path):
    """The model is rebuilt from the scene on resume: the factor comes back from the
    stages done (a resumed run without it would stop the block, tan 40° > tan 30°)."""
    from dda.run.checkpoint import CheckpointPlan, read_checkpoint
    from tests.run.test_runs import stop_after

    scene = dda.load_scene(block(2.0))
    whole = dda.simulate(scene)
    plan = CheckpointPlan(tmp_path / "c.npz", every_steps=None, every_seconds=None)
    dda.simulate(scene, stop=stop_after(32), checkpoints=plan)  # 1/4 s: after the stage
    rest = dda.simulate(scene, resume=read_checkpoint(tmp_path / "c.npz"))
    assert rest.frames[0].time == 0.25
    assert np.allclose(rest.final.centroids, whole.final.centroids, rtol=0, atol=1e-9)


@pytest.mark.parametrize("intact", [False, True])
def test_intact_divides_the_breakable_materials_strengths(intact):
    """After the stage the fracture criterion sees c / F, atan(tan φ / F), T / F with
    ``intact``, the scene's own values without; the joints get F either way."""
    from types import SimpleNamespace

    from dda.model import build
    from dda.run.stages import set_strengths

    raw = block(4.0, intact=intact)
    raw["materials"]["rock"].update(cohesion=1e6, friction_angle=50.0, tensile_strength=2e5)
    model = build(dda.load_scene(raw))
    set_strengths(SimpleNamespace(model=model, stages_done=1))
    assert model.contact.joints.factor == 4.0
    s, f = model.fracture.strength, 4.0 if intact else 1.0
    assert (s.cohesion[0], s.tensile_strength[0]) == (1e6 / f, 2e5 / f)
    assert math.tan(s.friction_angle[0]) == pytest.approx(math.tan(math.radians(50.0)) / f)
    set_strengths(SimpleNamespace(model=model, stages_done=0))  # before the stage
    assert model.contact.joints.factor == 1.0 and model.fracture.strength.cohesion[0] == 1e6


def _slide_error(dt: float) -> tuple[float, float]:
    """(largest move before the stage, relative error of the distance slid after it) of the
    block at time step ``dt``, F = 2 at t_s = 1/8 s, run to 1/4 s."""
    scene = incline_scene(1.0, dt, 0.25, theta=THETA)
    scene["joints"]["default"] = {"friction_angle": PHI}
    scene["analysis"]["save_every"] = round(DT / dt)  # a frame every 1/128 s
    scene["stages"] = [{"time": STAGE, "strength_factor": 2.0}]
    result = dda.simulate(scene)
    assert result.summary["cut_steps"] == 0
    times = np.array([f.time for f in result.frames])
    centroid = np.array([f.centroids[1] for f in result.frames])
    k = int(np.flatnonzero(np.isclose(times, STAGE, rtol=0, atol=1e-12))[0])
    stood = float(np.linalg.norm(centroid[: k + 1] - centroid[0], axis=1).max())
    slid = float(np.linalg.norm(centroid[-1] - centroid[k]))
    check_energy(result)  # never above E0 + W, at every time step
    return stood, slid / closed_form(2.0, 0.25 - STAGE) - 1.0


@pytest.mark.slow
def test_stick_before_and_slip_after_the_stage_do_not_worsen_as_the_time_step_shrinks():
    """Δt = 1/128 … 1/16384 s (6.1e-5): the block stands before the stage (< 1e-8 m, its
    elastic settlement being already carried from the equilibrium start) and the slide's
    error against the closed form is no worse at the finest step than at the coarsest
    (+ 1e-5 relative). Measured: stood 2e-14 … 8e-11 m; errors −1.08e-4, −4.4e-5,
    +1.45e-5, +3.1e-6 at Δt = 1/128, 1/1024, 1/8192, 1/16384 s."""
    steps = (1 / 128, 1 / 1024, 1 / 8192, 1 / 16384)
    measured = [_slide_error(dt) for dt in steps]
    for stood, _ in measured:
        assert stood < 1e-8
    errors = [abs(e) for _, e in measured]
    assert max(errors) < 1e-3
    assert errors[-1] <= errors[0] + 1e-5, errors
