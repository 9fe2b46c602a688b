"""Energy accounting (dda/run/energy.py) and its per-step record in Result.history."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.model import build
from dda.run.energy import EnergyTerms, contact_energy, elastic_energy, kinetic_energy
from tests.helpers import ROCK, G, projectile_scene, rectangle, slope_scene


def one_block(**block) -> dda.Scene:
    return dda.load_scene(
        {
            "analysis": {"time_step": 0.01, "steps": 10, "max_displacement_ratio": 0.5},
            "materials": {"rock": ROCK},
            "blocks": [
                {"name": "b", "material": "rock", "vertices": rectangle(0, 0, 2, 1), **block}
            ],
        }
    )


def test_kinetic_energy_of_translation_and_spin():
    """½ m |v|² + ½ ρ (Ixx + Iyy) ω² for a 2 x 1 block."""
    model = build(one_block(velocity=[3.0, -4.0, 2.0]))
    mass = ROCK["density"] * 2.0
    polar = ROCK["density"] * (2.0**3 * 1.0 + 2.0 * 1.0**3) / 12.0
    expected = 0.5 * mass * 25.0 + 0.5 * polar * 4.0
    assert kinetic_energy(model.material_density, model.blocks) == pytest.approx(expected)


def test_elastic_energy_of_uniaxial_stress_is_sigma_squared_over_two_e():
    """Plane stress, σxx only: U = S σ² / (2E)."""
    model = build(one_block(stress=[-1e6, 0.0, 0.0]))
    energy = elastic_energy(model.elastic.block_elasticity(model.blocks), model.blocks)
    assert energy == pytest.approx(2.0 * 1e12 / (2 * ROCK["young"]), rel=1e-12)


def test_energy_terms_total():
    terms = EnergyTerms(1.0, 2.0, 3.0, 4.0, 5.0)
    assert terms.total == 15.0
    assert terms.as_dict()["total"] == 15.0


def test_history_has_every_energy_column_per_step():
    result = dda.simulate(one_block(velocity=[1.0, 0.0, 0.5]))
    steps = result.summary["steps"]
    for key in (
        "kinetic_energy",
        "potential_energy",
        "elastic_energy",
        "contact_energy",
        "springs_energy",
        "total_energy",
        "external_work",
    ):
        assert result.history[key].shape == (steps,)


def test_free_flight_conserves_kinetic_plus_potential():
    """Shi's scheme is exact for constant acceleration: T + V constant to round-off."""
    scene = projectile_scene(omega=1.0)
    result = dda.simulate(scene)
    initial = result.summary["initial_energy"]
    # datum: the lowest vertex at t = 0 (y = 0); V0 = m g / 2, T0 = m 25 / 2 + I / 2
    mass = ROCK["density"]
    assert initial == pytest.approx(mass * G / 2 + mass * 12.5 + ROCK["density"] / 12.0)
    np.testing.assert_allclose(result.history["total_energy"], initial, rtol=1e-9)


def test_sliding_block_loses_energy_to_friction_at_the_coulomb_rate():
    """ΔE = −μ m g cos θ · s for a block sliding down a slope."""
    friction = 20.0
    result = dda.simulate(slope_scene(friction))
    moved = np.linalg.norm(result.final.displacements[1])
    mass = ROCK["density"] * 0.5
    loss = np.tan(np.radians(friction)) * mass * G * np.cos(np.radians(30.0)) * moved
    lost = result.summary["initial_energy"] - result.history["total_energy"][-1]
    assert lost == pytest.approx(loss, rel=0.01)


@pytest.mark.parametrize("method", ["augmented-lagrangian", "penalty"])
def test_friction_dissipation_is_the_coulomb_force_times_the_slide(method):
    """summary["friction_dissipation"] = μ m g cos θ · s for a block sliding down a slope."""
    friction = 20.0
    result = dda.simulate(slope_scene(friction, method))
    moved = np.linalg.norm(result.final.displacements[1])
    mass = ROCK["density"] * 0.5
    coulomb = np.tan(np.radians(friction)) * mass * G * np.cos(np.radians(30.0))
    assert result.summary["friction_dissipation"] == pytest.approx(coulomb * moved, rel=1e-4)


def test_point_load_work_enters_the_budget():
    """A free block pushed by a constant force: T = W (no gravity, no contact)."""
    scene = {
        "analysis": {"time_step": 0.01, "steps": 50, "max_displacement_ratio": 0.9},
        "materials": {"rock": ROCK},
        "blocks": [{"name": "b", "material": "rock", "vertices": rectangle(0, 0, 1, 1)}],
        "loads": [{"block": "b", "point": [0.5, 0.5], "force": [1000.0, 0.0]}],
    }
    result = dda.simulate(scene)
    moved = result.final.displacements[0, 0]
    assert result.summary["external_work"] == pytest.approx(1000.0 * moved, rel=1e-9)
    np.testing.assert_allclose(
        result.history["kinetic_energy"], result.history["external_work"], rtol=1e-9
    )


def test_penalty_contact_energy_is_half_p_d_squared():
    """The stack at rest with a pure penalty: C = ½ Σ N²/p + ½ Σ T²/p_s (p_s = 0.4 p).

    With a pure penalty N = p d and T = p_s s, so this is ½ p d² + ½ p_s s² (Shi's start:
    the springs unloaded at t = 0, so that each carries p d; the equilibrium start's
    preload is in test_engine_acceptance.py).
    """
    from tests.test_engine_acceptance import stack_scene

    raw = stack_scene("penalty")
    raw["analysis"].update(duration=0.05, start="unloaded")
    result = dda.simulate(raw)
    c = result.final.contacts
    closed = c.state > 0
    locked = c.state == 2
    expected = 0.5 * 5e10 * np.sum(c.penetration[closed] ** 2)
    expected += 0.5 * np.sum(c.shear_force[locked] ** 2) / (0.4 * 5e10)
    np.testing.assert_allclose(c.normal_force[closed], 5e10 * c.penetration[closed], rtol=1e-9)
    assert result.history["contact_energy"][-1] == pytest.approx(expected, rel=1e-9)


def test_contact_energy_of_an_empty_set_is_zero():
    from dda.contact.contact_set import ContactSet

    assert contact_energy(ContactSet.empty(), 0.4, True) == 0.0


@pytest.mark.skipif(not dda.jit.numba_enabled(), reason="numba is not in use")
@pytest.mark.parametrize("case", ["cases/rock_slope.toml", "cases/stack.toml"])
@pytest.mark.parametrize("with_gravity", [True, False])
def test_compiled_block_energies_equal_the_numpy_terms(case, with_gravity):
    """T, V and U in one compiled pass against kinetic_energy, gravity_potential and
    elastic_energy, with random velocities and stresses (1e-12 relative)."""
    from dda.run.energy import block_energies, gravity_potential

    model = build(dda.load_scene(case))
    blocks = model.blocks.copy()
    rng = np.random.default_rng(7)
    blocks.velocity = rng.normal(size=blocks.velocity.shape)
    blocks.stress = rng.normal(scale=1e6, size=blocks.stress.shape)
    density = model.material_density[blocks.material]
    elasticity = model.elastic.block_elasticity(blocks)
    gravity = np.array([0.3, -G]) if with_gravity else None
    datum = blocks.vertices.min(axis=0)
    kinetic, potential, elastic = block_energies(density, elasticity, blocks, gravity, datum)
    assert kinetic == pytest.approx(kinetic_energy(density, blocks), rel=1e-12)
    expected = gravity_potential(density, blocks, gravity, datum) if with_gravity else 0.0
    assert potential == pytest.approx(expected, rel=1e-12)
    assert elastic == pytest.approx(elastic_energy(elasticity, blocks), rel=1e-12)
