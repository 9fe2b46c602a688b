"""Three-parameter Mohr–Coulomb criterion (paper §4, eqs. 22–25)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dda.fracture.criterion import (
    NONE,
    SHEAR,
    TENSION,
    evaluate,
    principal_stresses,
    strength_numbers,
)

S0, PHI, T0 = 1.78e5, math.radians(39.1), 0.85e5  # the paper's rock, psf
N_PAPER, C0_PAPER, S1C_PAPER = 4.415296, 7.480488e5, -3.727486e5


def test_worked_numbers_of_the_paper():
    n_phi, c0, s1c = strength_numbers(S0, PHI, T0)
    assert n_phi == pytest.approx(N_PAPER, rel=1e-6)
    assert c0 == pytest.approx(C0_PAPER, rel=1e-6)
    assert s1c == pytest.approx(S1C_PAPER, rel=1e-6)


def test_shear_planes_at_25_45_degrees_to_sigma1():
    state = evaluate([[0.0, -1.02 * C0_PAPER, 0.0]], S0, PHI, T0)
    assert state.mode[0] == SHEAR
    assert math.degrees(state.principal.angle1[0]) == pytest.approx(90.0)
    offsets = np.sort(np.degrees(state.planes[0]) - 90.0)
    offsets = (offsets + 90.0) % 180.0 - 90.0
    np.testing.assert_allclose(np.sort(offsets), [-25.450, 25.450], rtol=1e-6)


def _rotated(s1: float, s3: float, theta1: float) -> list[float]:
    """Stress with sigma1 along direction theta1 and sigma3 normal to it."""
    c, s = math.cos(theta1), math.sin(theta1)
    sxx = s1 * c * c + s3 * s * s
    syy = s1 * s * s + s3 * c * c
    sxy = (s1 - s3) * s * c
    return [sxx, syy, sxy]


@given(
    s1=st.floats(-1e6, 1e6),
    gap=st.floats(0.0, 1e6),
    theta=st.floats(-1.5, 1.5),
)
@settings(max_examples=100, deadline=None)
def test_principal_stresses_recover_a_rotated_state(s1, gap, theta):
    p = principal_stresses(_rotated(s1, s1 + gap, theta))
    assert p.sigma1[0] == pytest.approx(s1, abs=1e-9 * (abs(s1) + gap + 1))
    assert p.sigma3[0] == pytest.approx(s1 + gap, abs=1e-9 * (abs(s1) + gap + 1))
    assert p.sigma1[0] <= p.sigma3[0]
    if gap > 1e-3 * (abs(s1) + 1):
        diff = (p.angle1[0] - theta + math.pi / 2) % math.pi - math.pi / 2
        assert abs(diff) < 1e-6


def test_sigma1_direction_is_an_eigenvector():
    stress = np.array([[1.0e5, -3.0e5, 1.2e5], [-2.0, 5.0, -7.0], [4.0, 4.0, 0.0]])
    p = principal_stresses(stress)
    for row, s1, a in zip(stress, p.sigma1, p.angle1, strict=True):
        tensor = np.array([[row[0], row[2]], [row[2], row[1]]])
        d = np.array([math.cos(a), math.sin(a)])
        np.testing.assert_allclose(tensor @ d, s1 * d, atol=1e-9 * np.abs(row).max())


def test_uniaxial_compression_two_percent_either_side_of_c0():
    stress = [[0.0, -1.02 * C0_PAPER, 0.0], [0.0, -0.98 * C0_PAPER, 0.0]]
    assert evaluate(stress, S0, PHI, T0).mode.tolist() == [SHEAR, NONE]


def test_uniaxial_tension_two_percent_either_side_of_t0():
    stress = [[1.02 * T0, 0.0, 0.0], [0.98 * T0, 0.0, 0.0]]
    state = evaluate(stress, S0, PHI, T0)
    assert state.mode.tolist() == [TENSION, NONE]
    # the plane is normal to sigma3 (the pull, along x): it runs along y
    assert abs(math.cos(state.planes[0, 0])) < 1e-12
    assert np.isnan(state.planes[0, 1]) and np.isnan(state.planes[1]).all()


def test_branches_meet_at_the_transition_stress():
    # sigma3 = T0 on the tensile branch; sigma1 on both sides of sigma1c
    above = _rotated(S1C_PAPER * 0.99, T0 * 1.001, 0.3)
    below = _rotated(S1C_PAPER * 1.01, T0 * 1.001, 0.3)
    assert evaluate([above, below], S0, PHI, T0).mode.tolist() == [TENSION, SHEAR]


def test_confinement_raises_the_shear_strength():
    confined = -1.0e5
    limit = -C0_PAPER + confined * N_PAPER
    stress = [_rotated(limit * 1.001, confined, 0.0), _rotated(limit * 0.999, confined, 0.0)]
    assert evaluate(stress, S0, PHI, T0).mode.tolist() == [SHEAR, NONE]


def test_per_block_strengths_and_no_tension_cut_off():
    stress = np.array([[1.5e5, 0.0, 0.0]] * 3)  # below C0 / N = 1.69e5
    cohesion = np.array([S0, S0, 10 * S0])
    tensile = np.array([T0, np.inf, 10 * T0])
    mode = evaluate(stress, cohesion, PHI, tensile).mode
    assert mode.tolist() == [TENSION, NONE, NONE]
    # without a tension cut-off, equal biaxial tension fails on the shear branch
    deep = C0_PAPER / (N_PAPER - 1) * 1.01
    assert evaluate([[deep, deep, 0.0]], S0, PHI, np.inf).mode[0] == SHEAR


def test_intact_blocks_have_no_planes():
    state = evaluate(np.zeros((4, 3)), S0, PHI, T0)
    assert (state.mode == NONE).all() and np.isnan(state.planes).all()
    assert state.failing.size == 0


@pytest.mark.parametrize("cohesion, tensile", [(1e5, 0.0), (0.0, 0.0)])
def test_a_block_with_no_tensile_strength_breaks_beyond_the_criterion_not_on_it(cohesion, tensile):
    """T0 = 0 (and s0 = 0): an unstressed block lies on the criterion and stays whole
    (it was split at every step, 1 block into 64 in 6 steps, with no load); the least
    tension (1 Pa) breaks it, or, without cohesion, σ1 < N σ3 (N = 3 at 30°)."""
    phi = math.radians(30.0)
    assert evaluate([[0.0, 0.0, 0.0]], cohesion, phi, tensile).mode[0] == NONE
    assert evaluate([[1.0, 0.0, 0.0]], cohesion, phi, tensile).mode[0] == TENSION
    if cohesion == 0.0:
        assert evaluate([[-1.0, -4.0, 0.0]], cohesion, phi, tensile).mode[0] == SHEAR


@pytest.mark.parametrize("tensile, said", [(2e5, True), (1e5, False)])
def test_a_tensile_strength_above_the_shear_lines_intercept_is_said(
    caplog, monkeypatch, tensile, said
):
    """c = 1e5 Pa and φ = 30° put the shear criterion's tension intercept at C0 / N =
    1.155e5 Pa: a tensile strength above it is never reached in uniaxial tension (the
    block breaks in shear first), and building the model says so; below it, nothing."""
    import dda
    import dda.fracture.effect
    from dda.model import build

    monkeypatch.setattr(dda.fracture.effect, "_SAID", set())  # said once a process

    rock = {"density": 2500.0, "young": 1e9, "poisson": 0.25, "cohesion": 1e5,
            "friction_angle": 30.0, "tensile_strength": tensile}  # fmt: skip
    raw = {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 1},
        "materials": {"rock": rock},
        "blocks": [{"name": "a", "material": "rock", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]}],
    }
    with caplog.at_level("WARNING"):
        build(dda.load_scene(raw))
    noted = [r.getMessage() for r in caplog.records if "tension intercept" in r.getMessage()]
    assert bool(noted) == said
    if said:
        assert "C0 / N = 1.155e+05" in noted[0] and "materials.rock" in noted[0]
