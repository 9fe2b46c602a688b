"""An elastic block sliding on Coulomb friction flutters: the model's physics, not the scheme's.

A 2 x 1 m block (E = 1e9 Pa, ν = 0.25, plane stress, ρ = 2700 kg/m³) on a level fixed
base, its two bottom corners on contact springs p = 10 E, pushed at its centroid at 1.5
times its friction bound (φ = 30°), so it slides from t = 0. While it slides, each
corner's friction force is μ N with N = p g: a small motion that changes g changes the
friction, and the linearised equations of motion M D̈ + K D = 0 have a stiffness K that
is not symmetric,

    K = S E (strain rows) + Σ_corners Tᵀ [[0, −μ p], [0, p]] T,

T the corner's 2 x 6 displacement matrix (docs/theory.md §1). Its eigenvalues ω² are a
complex pair above μ ≈ 0.36 (φ ≈ 20°): a mode of 153 Hz that grows at Re s (s² = −ω²),
here 129 /s without material damping (ξ = 0), and not at all with the default ξ = 0.2
(β = 2ξ/ω₁, docs/theory.md §3). Without material damping a sliding block therefore has
no rigid answer to converge to as Δt shrinks: Shi's scheme damps the mode by about
ω² Δt / 4 per second, so a large Δt hides it and a small one resolves it. The engine's
growth rate at Δt = 2e-5 s is the linear theory's less that damping.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dda
from tests.helpers import rectangle

WIDTH, HEIGHT = 2.0, 1.0
YOUNG, POISSON, DENSITY = 1e9, 0.25, 2700.0
PENALTY = 10.0 * YOUNG
MU = math.tan(math.radians(30.0))
SEED = 1e-6  # rad/s: the block's initial spin, which starts the mode
DT = 2e-5


def displacement_matrix(x: float, y: float) -> np.ndarray:
    """T(x, y) about the centroid (0, h/2): u = T D, D = (u0, v0, r0, εx, εy, γxy)."""
    dx, dy = x, y - HEIGHT / 2
    return np.array([[1, 0, -dy, dx, 0, dy / 2], [0, 1, dx, 0, dy, dx / 2]])


def linear_system(mu: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, K (sliding on both corners) and the strain stiffness S E of the block."""
    points, weights = np.polynomial.legendre.leggauss(6)
    mass = np.zeros((6, 6))
    for a, wa in zip(points, weights, strict=True):
        for b, wb in zip(points, weights, strict=True):
            t = displacement_matrix(a * WIDTH / 2, (1 + b) * HEIGHT / 2)
            mass += DENSITY * wa * wb * WIDTH * HEIGHT / 4 * t.T @ t
    plane_stress = np.array([[1, POISSON, 0], [POISSON, 1, 0], [0, 0, (1 - POISSON) / 2]])
    strain = np.zeros((6, 6))
    strain[3:, 3:] = WIDTH * HEIGHT * YOUNG / (1 - POISSON**2) * plane_stress
    stiffness = strain.copy()
    for x in (-WIDTH / 2, WIDTH / 2):
        t = displacement_matrix(x, 0.0)
        stiffness += t.T @ np.array([[0, -mu * PENALTY], [0, PENALTY]]) @ t
    return mass, stiffness, strain


def fastest_mode(mu: float, damping: float = 0.0) -> complex:
    """The eigenvalue s of M ẍ + C ẋ + K x = 0 of largest real part (growth rate, 1/s;
    angular frequency in its imaginary part), C = β S E, β = 2ξ/ω₁ (ω₁ the block's
    slowest strain mode)."""
    mass, stiffness, strain = linear_system(mu)
    omega_1 = math.sqrt(min(np.linalg.eigvals(np.linalg.solve(mass[3:, 3:], strain[3:, 3:])).real))
    damper = 2 * damping / omega_1 * strain
    state = np.block(
        [
            [np.zeros((6, 6)), np.eye(6)],
            [-np.linalg.solve(mass, stiffness), -np.linalg.solve(mass, damper)],
        ]
    )
    eigenvalues = np.linalg.eigvals(state)
    return complex(eigenvalues[np.argmax(eigenvalues.real)])


def sliding_scene(damping: float, duration: float) -> dict:
    weight = DENSITY * 9.81 * WIDTH * HEIGHT
    return {
        "analysis": {"mode": "dynamic", "time_step": DT, "duration": duration,
                     "gravity": [0.0, -9.81], "save_every": 1},
        "materials": {"rock": {"density": DENSITY, "young": YOUNG, "poisson": POISSON,
                               "damping": damping}},
        "joints": {"default": {"friction_angle": 30.0}},
        "contact": {"method": "penalty", "penalty": PENALTY},
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True,
             "vertices": rectangle(-5.0, -1.0, 15.0, 0.0)},
            {"name": "block", "material": "rock", "velocity": [0.0, 0.0, SEED],
             "vertices": rectangle(-WIDTH / 2, 0.0, WIDTH / 2, HEIGHT)},
        ],
        "loads": [{"block": "block", "point": [0.0, HEIGHT / 2],
                   "force": [1.5 * MU * weight, 0.0]}],
    }  # fmt: skip


def spin_amplitudes(result: dda.Result, period: float) -> tuple[np.ndarray, np.ndarray]:
    """(times, ranges) of the block's spin over consecutive windows of one period."""
    times = np.array([f.time for f in result.frames])
    spin = np.array([f.velocities[f.block("block"), 2] for f in result.frames])
    width = int(round(period / DT))
    starts = range(0, len(times) - width, width)
    return times[list(starts)], np.array([np.ptp(spin[s : s + width]) for s in starts])


def test_the_linear_theory_has_a_growing_mode_above_a_friction_threshold():
    """Without friction the sliding block's K is symmetric (no growth); at μ = tan 30° a
    mode of about 153 Hz grows at about 129 /s; the default damping ξ = 0.2 stops it."""
    assert fastest_mode(0.0).real == pytest.approx(0.0, abs=1e-6)
    mode = fastest_mode(MU)
    assert 100.0 < mode.real < 160.0
    assert 140.0 < mode.imag / (2 * math.pi) < 170.0
    assert fastest_mode(MU, damping=0.2).real <= 1e-6


def test_the_engine_flutters_at_the_rate_of_the_linear_theory():
    """Undamped, the engine's spin grows as e^{st} with s the linear theory's less Shi's
    damping ω² Δt / 4 (4.7 /s, 3.6 % here), within 2 % of the expected rate, at its
    frequency within 2 %; with the default ξ = 0.2 the seeded spin does not grow."""
    mode = fastest_mode(MU)
    period = 2 * math.pi / mode.imag
    expected = mode.real - mode.imag**2 * DT / 4
    times, ranges = spin_amplitudes(dda.simulate(sliding_scene(0.0, 0.08)), period)
    linear = (ranges > 10 * SEED) & (ranges < 1e-2)  # grown out of the seed; still linear
    assert linear.sum() >= 8
    rate = np.polyfit(times[linear], np.log(ranges[linear]), 1)[0]
    assert rate == pytest.approx(expected, rel=0.02)

    _, damped = spin_amplitudes(dda.simulate(sliding_scene(0.2, 0.03)), period)
    assert damped[-1] < damped[0]
