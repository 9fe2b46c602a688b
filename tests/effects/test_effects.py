"""Effects: the mass matrix, elasticity, and that absent effects never run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import dda
from dda.blocks import BlockSet
from dda.effects import damping
from dda.effects import inertia as inertia_module
from dda.effects.base import StepContext
from dda.effects.elastic import elasticity_matrices
from dda.effects.inertia import mass_matrices
from dda.geometry import pack_polygons
from dda.kinematics import displacement_matrices
from dda.model import build
from tests.helpers import ROCK, rectangle

CASES = Path(__file__).resolve().parents[2] / "cases"


def one_block(polygon: np.ndarray) -> BlockSet:
    v, o = pack_polygons([polygon])
    z = np.zeros
    return BlockSet(
        ["b"],
        np.array([0]),
        np.array([0]),
        v,
        o,
        np.full(len(v), -1),
        z((1, 6)),
        z((1, 3)),
        z(1),
        z((1, 2)),
        np.array([False]),
    )


def test_mass_matrix_matches_quadrature_on_a_concave_polygon():
    """M = ρ ∫ TᵀT dA, checked by Monte-Carlo-free midpoint quadrature on a fine grid."""
    import shapely

    poly = np.array([[0, 0], [3, 0], [3, 1], [1, 1], [1, 2.5], [0, 2.5]], float)
    blocks = one_block(poly)
    m = mass_matrices(np.array([2.0]), blocks)[0]
    h = 0.005
    xs, ys = np.meshgrid(np.arange(h / 2, 3, h), np.arange(h / 2, 2.5, h))
    pts = np.column_stack([xs.ravel(), ys.ravel()])
    inside = shapely.contains_xy(shapely.Polygon(poly), pts[:, 0], pts[:, 1])
    pts = pts[inside]
    t = displacement_matrices(pts, np.repeat(blocks.centroid, len(pts), axis=0))
    quad = 2.0 * np.einsum("mki,mkj->ij", t, t) * h * h
    np.testing.assert_allclose(m, quad, rtol=2e-3, atol=2e-3 * np.abs(m).max())


@pytest.mark.skipif(not dda.jit.numba_enabled(), reason="numba is not in use")
def test_the_compiled_mass_matrices_equal_numpy_to_the_bit():
    """In a run with the kernels :func:`mass_matrices` is compiled: the same numbers, the
    infinities and NaN of a block of no area too."""
    from dda.bench.scenes import wall_scene
    from dda.model import build

    blocks = build(dda.load_scene(wall_scene(4, 3))).blocks.copy()
    blocks.ixy = blocks.ixy + np.linspace(-0.1, 0.1, blocks.count)
    blocks.area = blocks.area.copy()
    blocks.area[1] = 0.0
    density = np.linspace(2000.0, 2700.0, blocks.count)
    with np.errstate(divide="ignore", invalid="ignore"):  # the block of no area
        plain = mass_matrices(density, blocks)
        with dda.jit.run_work(blocks=1000, steps=10_000):
            compiled = mass_matrices(density, blocks)
    assert not np.isfinite(plain[1]).any()
    np.testing.assert_array_equal(plain, compiled)


def test_polygon_moments_of_a_rectangle():
    blocks = one_block(np.array(rectangle(1, 2, 3, 3), float))
    assert blocks.area[0] == pytest.approx(2.0)
    np.testing.assert_allclose(blocks.centroid[0], [2.0, 2.5])
    assert blocks.ixx[0] == pytest.approx(2.0**3 * 1.0 / 12)
    assert blocks.iyy[0] == pytest.approx(2.0 * 1.0**3 / 12)
    assert blocks.ixy[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.skipif(not dda.jit.numba_enabled(), reason="numba is not in use")
@pytest.mark.parametrize("case", ["cases/rock_slope.toml", "cases/tunnel.toml"])
def test_compiled_polygon_moments_equal_numpy_bit_for_bit(case):
    """The kernel sums each polygon's edge terms in vertex order, as the numpy
    bincount does: the same numbers, bit for bit (a run's dynamics does not change)."""
    from dda.geometry import polygon_moments
    from dda.model import build

    blocks = build(dda.load_scene(case)).blocks.copy()
    reference = polygon_moments(blocks.vertices, blocks.offsets)
    blocks.area = None
    with dda.jit.run_work(10**6, 10**6):
        blocks.update_moments()
    assert blocks.area is not None
    for name, values in reference.items():
        np.testing.assert_array_equal(getattr(blocks, name), values)


@pytest.mark.parametrize("plane", ["stress", "strain"])
def test_elasticity_inverts_hooke(plane):
    e, nu = 5e9, 0.25
    c = elasticity_matrices(np.array([e]), np.array([nu]), plane)[0]
    sxx = 1e6
    if plane == "stress":  # uniaxial stress: ex = s/E, ey = -nu s/E
        strain = np.array([sxx / e, -nu * sxx / e, 0.0])
    else:  # plane strain uniaxial stress in x: ex = (1-nu²) s/E, ey = -nu(1+nu) s/E
        strain = np.array([(1 - nu**2) * sxx / e, -nu * (1 + nu) * sxx / e, 0.0])
    np.testing.assert_allclose(c @ strain, [sxx, 0.0, 0.0], atol=1e-6 * sxx)
    shear = c @ np.array([0.0, 0.0, 1e-4])
    assert shear[2] == pytest.approx(e / (2 * (1 + nu)) * 1e-4)


def single_block_scene() -> dict:
    return {
        "analysis": {"time_step": 0.01, "steps": 5},
        "materials": {"rock": ROCK},
        "blocks": [{"name": "b", "material": "rock", "vertices": rectangle(0, 0, 1, 1)}],
    }


def test_only_declared_effects_are_active():
    """A dynamic block's elasticity comes with its material damping (dda.effects.damping)
    unless its material sets none."""
    summary = dda.simulate(single_block_scene()).summary
    assert summary["active_effects"] == ["elastic", "inertia", "material_damping"]
    assert "contact_search" not in summary["stage_seconds"]
    undamped = single_block_scene()
    undamped["materials"] = {"rock": {**ROCK, "damping": 0.0}}
    assert dda.simulate(undamped).summary["active_effects"] == ["elastic", "inertia"]


def test_undeclared_effects_never_run(monkeypatch):
    """Gravity, loads, fixed points, contact and fracture code is not even called."""

    def forbidden(*args, **kwargs):
        raise AssertionError("an undeclared effect ran")

    import dda.contact.pipeline
    import dda.effects.fixed_points
    import dda.effects.gravity
    import dda.effects.loads
    import dda.run.simulation

    monkeypatch.setattr(dda.effects.gravity.Gravity, "forces", forbidden)
    monkeypatch.setattr(dda.effects.loads.PointLoads, "forces", forbidden)
    monkeypatch.setattr(dda.effects.fixed_points.FixedPoints, "stiffness", forbidden)
    monkeypatch.setattr(dda.run.simulation, "refresh_contacts", forbidden)
    monkeypatch.setattr(dda.run.simulation, "_fracture", forbidden)
    result = dda.simulate(single_block_scene())
    assert result.summary["steps"] == 5


def test_static_mode_names_its_mass_term_damping():
    scene = single_block_scene()
    scene["analysis"]["mode"] = "static"
    assert dda.simulate(scene).summary["active_effects"] == ["elastic", "static_damping"]


def test_frictionless_joints_build_no_friction():
    scene = single_block_scene()
    scene["blocks"].append(
        {"name": "base", "material": "rock", "fixed": True, "vertices": rectangle(-1, -1, 2, 0)}
    )
    active = dda.simulate(scene).summary["active_effects"]
    assert "contact_augmented" in active and "friction" not in active


@pytest.mark.skipif(damping.slowest_frequencies_kernel is None, reason="numba is not in use")
def test_slowest_strain_frequency_compiled_equals_numpy():
    """ω₁ of the material damping: the compiled Cholesky and Jacobi rotations against
    numpy's LAPACK, on random strain blocks (well and badly conditioned, equal
    eigenvalues, one eigenvalue split by 1e-9) and on the rock slope's blocks."""
    rng = np.random.default_rng(0)
    n = 500
    masses = np.zeros((n, 6, 6))
    x = rng.normal(size=(n, 3, 3))
    masses[:, 3:, 3:] = x @ np.swapaxes(x, 1, 2) + 0.1 * np.eye(3)
    y = rng.normal(size=(n, 3, 3))
    stiffness = y @ np.swapaxes(y, 1, 2) + 0.01 * np.eye(3)
    stiffness[:10], masses[:10, 3:, 3:] = 5.0 * np.eye(3), 2.0 * np.eye(3)
    stiffness[10:20] = np.diag([1.0, 1.0, 1.0 + 1e-9])
    expected = damping.slowest_strain_frequency(stiffness, masses)  # numpy outside a run
    got = damping.slowest_frequencies_kernel(stiffness, masses)
    np.testing.assert_allclose(got, expected, rtol=1e-9)  # eps x the condition number
    model = build(dda.load_scene(CASES / "rock_slope.toml"))
    effect = next(e for e in model.effects if e.name == "material_damping")
    blocks = model.blocks
    elastic = blocks.area[:, None, None] * effect.material_elasticity[blocks.material]
    masses = mass_matrices(effect.density[blocks.material], blocks)
    expected = damping.slowest_strain_frequency(elastic, masses)
    got = damping.slowest_frequencies_kernel(elastic, masses)
    np.testing.assert_allclose(got, expected, rtol=1e-13)


def test_inertia_and_damping_share_a_steps_mass_matrices(monkeypatch):
    """K₀ and F₀ of the inertia and the material damping's frequencies use one
    computation of the mass matrices a step (kept on the blocks while their moments
    are the same arrays), equal to one made afresh; new moments make a new one."""
    model = build(dda.load_scene(single_block_scene()))
    assert [e.name for e in model.effects] == ["elastic", "inertia", "material_damping"]
    calls = []
    original = inertia_module.mass_matrices
    monkeypatch.setattr(inertia_module, "mass_matrices", lambda *a: calls.append(1) or original(*a))
    blocks, ctx = model.blocks, StepContext(dt=0.01, time=0.0, step=0, static=False)
    for effect in model.effects:
        effect.stiffness(blocks, ctx)
        effect.forces(blocks, ctx)
    assert len(calls) == 1
    inertia = model.effects[1]
    expected = original(inertia.material_density[blocks.material], blocks)
    np.testing.assert_array_equal(inertia.masses(blocks), expected)
    blocks.vertices = blocks.vertices * 1.01
    blocks.update_moments()
    np.testing.assert_array_equal(
        inertia.masses(blocks), original(inertia.material_density[blocks.material], blocks)
    )
    assert len(calls) == 2
