"""Earthquake input (dda/effects/seismic.py): the ground motion, Newmark's sliding block,
no slip below the yield acceleration, and the energy balance with the ground's work."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.effects.seismic import GroundMotion
from tests.helpers import ROCK, G, rectangle, rotated


def shaken_block(theta: float, phi: float, record, duration: float = 0.6, dt: float = 0.005):
    """A 1 m x 0.5 m block on a long slab inclined at ``theta``; the slab follows ``record``."""
    return {
        "analysis": {"time_step": dt, "duration": duration, "gravity": [0.0, -G]},
        "contact": {"penalty": 5e10, "tolerance": 1e-6},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": phi}},
        "blocks": [
            {"name": "ground", "material": "rock", "fixed": True,
             "vertices": rotated(rectangle(-10, -1, 10, 0), theta)},
            {"name": "block", "material": "rock",
             "vertices": rotated(rectangle(-0.5, 0, 0.5, 0.5), theta)},
        ],
        "seismic": {"acceleration": record},
    }  # fmt: skip


def pulse(amplitude: float, length: float) -> list[list[float]]:
    """A rectangular pulse of horizontal ground acceleration (1e-9 s ramp down)."""
    return [[0.0, amplitude], [length, amplitude], [length + 1e-9, 0.0]]


def newmark(theta: float, phi: float, amplitude: float, length: float) -> float:
    """Newmark's slide down a slope under a horizontal rectangular pulse A for t0:
    a_y = g tan(φ − θ), c = cos θ + tan φ sin θ, d = c (A − a_y) A t0² / (2 a_y)."""
    t, p = np.radians(theta), np.radians(phi)
    yield_acceleration = G * np.tan(p - t)
    c = np.cos(t) + np.tan(p) * np.sin(t)
    return c * (amplitude - yield_acceleration) * amplitude * length**2 / (2 * yield_acceleration)


def test_the_ground_motion_is_the_exact_integral_of_the_record():
    times = np.array([0.0, 1.0, 3.0])
    ground = GroundMotion(times, np.array([[2.0, 0.0], [2.0, -1.0], [0.0, 1.0]]), np.zeros(1))
    u, v = ground.ground(0.5)
    np.testing.assert_allclose(u, [0.25, -(0.5**3) / 6], rtol=1e-12)  # ½ a t²; a = -t: -t³/6
    np.testing.assert_allclose(v, [1.0, -0.125], rtol=1e-12)
    u1, v1 = ground.ground(1.0)
    u3, v3 = ground.ground(3.0)  # on [1, 3]: a = 2 - (t-1), (0, -1) -> (0, 1) linearly
    np.testing.assert_allclose(v3, v1 + [2.0, 0.0], rtol=1e-12)
    np.testing.assert_allclose(u3, u1 + 2 * v1 + [8 / 3, -2 / 3], rtol=1e-12)
    u5, v5 = ground.ground(5.0)  # after the record: its last velocity
    np.testing.assert_allclose(v5, v3)
    np.testing.assert_allclose(u5, u3 + 2 * v3)
    assert np.array_equal(ground.ground(-1.0)[0], [0.0, 0.0])


@pytest.mark.parametrize(("theta", "phi", "g_fraction"), [(0.0, 20.0, 0.6), (20.0, 35.0, 0.5)])
def test_newmark_sliding_block_under_a_rectangular_pulse(theta, phi, g_fraction):
    """Horizontal base (the classic) and the one-sided slope: within 2 % (measured 1e-5
    and 2e-4 with Δt = 5 ms)."""
    amplitude, length = g_fraction * G, 0.2
    result = dda.simulate(shaken_block(theta, phi, pulse(amplitude, length)))
    d = result.final.displacements
    slide = d[1] - d[0]
    expected = newmark(theta, phi, amplitude, length)
    assert np.linalg.norm(slide) == pytest.approx(expected, rel=0.02)
    assert np.linalg.norm(slide) == pytest.approx(expected, rel=5e-4)  # what it does
    down = -np.array([np.cos(np.radians(theta)), np.sin(np.radians(theta))])
    assert slide @ down == pytest.approx(np.linalg.norm(slide), rel=1e-6)  # down the slope
    assert d[0, 0] == pytest.approx(amplitude * length * (0.6 - length / 2), rel=1e-8)
    assert "seismic" in result.summary["active_effects"]


def rigid_slide(theta: float, phi: float, record, seconds: float = 0.6) -> float:
    """The rigid block's slide down the slope under a piecewise-linear horizontal ground
    acceleration a(t): from the moment a exceeds a_y, the relative velocity is
    c ∫ (a − a_y) dt until it falls back to 0 (one episode: one pulse), the slide its
    integral; on a grid of 1 µs (the trapezoid rule: 1e-10 here)."""
    t_, p_ = np.radians(theta), np.radians(phi)
    yield_acceleration = G * np.tan(p_ - t_)
    c = np.cos(t_) + np.tan(p_) * np.sin(t_)
    t = np.linspace(0.0, seconds, int(round(seconds / 1e-6)) + 1)
    a = np.interp(t, [r[0] for r in record], [r[1] for r in record], right=0.0)
    excess = c * (a - yield_acceleration)[np.argmax(a > yield_acceleration) :]
    step = t[1] - t[0]
    v = np.concatenate([[0.0], np.cumsum(0.5 * (excess[1:] + excess[:-1]) * step)])
    v = v[: np.argmax(v[1:] <= 0.0) + 1]
    return float(np.sum(0.5 * (v[1:] + v[:-1])) * step)


@pytest.mark.parametrize("dt", [1e-3, 1e-4])
def test_a_ramped_pulse_converges_to_the_rigid_slide_as_the_time_step_shrinks(dt):
    """The slope of cases/seismic_slope.toml (20°, φ = 35°) under 0.5 g ramped up in
    50 ms, held to 0.2 s and ramped down in 50 ms: within 3e-4 of the rigid block's
    slide (the elastic block's own: measured 8.6e-4, 1.8e-4, 2.1e-4 and 1.4e-4 at
    Δt = 5, 1, 0.25 and 0.1 ms). A rectangular pulse (a jump of the acceleration) is no
    such limit: the elastic block and its contact spring overshoot at the jump and it
    slips for an instant beyond the rigid block (1.5e-3 of its slide as Δt → 0:
    docs/engineering.md)."""
    record = [[0.0, 0.0], [0.05, 0.5 * G], [0.2, 0.5 * G], [0.25, 0.0]]
    result = dda.simulate(shaken_block(20.0, 35.0, record, dt=dt))
    d = result.final.displacements
    assert np.linalg.norm(d[1] - d[0]) == pytest.approx(rigid_slide(20.0, 35.0, record), rel=3e-4)


def test_below_the_yield_acceleration_the_block_does_not_slide():
    """A 2 Hz sine of 0.95 g tan φ for 1 s: the block moves with the ground (< 1e-6 m)."""
    critical = G * np.tan(np.radians(20.0))
    t = np.linspace(0.0, 1.0, 201)
    record = np.column_stack([t, 0.95 * critical * np.sin(4 * np.pi * t)]).tolist()
    result = dda.simulate(shaken_block(0.0, 20.0, record, duration=1.0, dt=0.01))
    relative = [f.displacements[1, 0] - f.displacements[0, 0] for f in result.frames]
    assert max(np.abs(relative)) < 1e-6
    assert max(abs(f.displacements[0, 0]) for f in result.frames) > 0.1  # the ground moved


def test_the_ground_does_work_and_the_energy_stays_within_it():
    """E ≤ E0 + W at every step, W counting the ground's work through the contacts; during
    the pulse the ground feeds the block kinetic energy it could not get otherwise."""
    result = dda.simulate(shaken_block(20.0, 35.0, pulse(0.5 * G, 0.2)))
    h = result.history
    e0 = result.summary["initial_energy"]
    assert np.all(h["total_energy"] - e0 - h["external_work"] <= 1e-9 * e0)
    assert h["external_work"].max() > 100.0 and h["kinetic_energy"].max() > 100.0


def test_the_moving_blocks_carry_the_ground_velocity_and_bolts_follow_them():
    """A block bolted to the ground, no gravity, no contact, the ground moving up: the
    block follows it through the bolt (the known step of the ground stretches it)."""
    scene = shaken_block(0.0, 20.0, pulse(2.0, 0.1), duration=0.3, dt=0.01)
    scene["seismic"]["component"] = "y"
    scene["analysis"]["gravity"] = [0.0, 0.0]
    scene["blocks"][1]["vertices"] = rectangle(-0.5, 1.0, 0.5, 1.5)
    scene["bolts"] = [{"start": [0.0, 1.0], "end": [0.0, -0.5], "stiffness": 1e9}]
    result = dda.simulate(scene)
    final = result.final
    assert final.velocities[0, 1] == pytest.approx(0.2, rel=1e-8)  # the ground's 2 x 0.1
    assert final.displacements[0, 1] == pytest.approx(0.05, rel=1e-6)
    assert final.displacements[1, 1] == pytest.approx(final.displacements[0, 1], abs=1e-3)
    h = result.history
    e0 = result.summary["initial_energy"]
    assert np.all(h["total_energy"] - e0 - h["external_work"] <= 1e-9 * h["external_work"].max())
