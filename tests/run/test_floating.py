"""A model that nothing fixed holds (dda/run/floating.py): boundary stresses on free
blocks balance the weight of the whole section; a stage that excavates a block leaves
its weight W_c as a net upward force, and the section accelerates as a whole.

Closed form: the momentum of the blocks, Σ m_i ü_i = Σ F_ext = W_c (the contact forces
act in pairs; the boundary stresses turn only with the section's rigid turn, nil here by
symmetry): the mass-weighted mean of the centroids rises by ½ (W_c / M) (t − t_s)² after
the stage at t_s, M the blocks' mass that is left.
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
from tests.scene.test_in_situ import RHO, G, grid, scene, square

TOP = 3.0  # the top of the 3 x 3 grid of unit blocks
STAGE = 0.02  # s: the centre block is excavated
FIELD = {"stress": [-1.0e6, -1.0e6 - RHO * G * TOP, 0.0], "gradient": [0.0, RHO * G, 0.0]}


def section(base: bool, **more) -> dict:
    """The grid in the field σyy = −1 MPa + ρ g (y − 3), σxx = −1 MPa + ... (in
    equilibrium with its weight), loaded on its outer edges by the same field; with
    ``base`` it stands on a fixed block instead of a boundary stress along its bottom."""
    blocks = grid(3, 3)
    if base:
        blocks.append({"name": "base", "material": "rock", "fixed": True,
                       "vertices": square(-1.0, -1.0, 4.0, 0.0)})  # fmt: skip
    raw = scene(
        blocks,
        gravity=(0.0, -G),
        duration=0.06,
        in_situ=FIELD,
        boundary_stresses=[dict(FIELD, box=[-0.5, -0.5, 3.5, 3.5], name="far field")],
        stages=[{"time": STAGE, "remove": ["b1_1"]}],
        **more,
    )
    raw["analysis"]["save_every"] = 1
    return raw


def test_an_excavation_in_a_section_held_by_boundary_stresses_alone_is_said_and_drifts(caplog):
    result = dda.simulate(dda.load_scene(section(base=False)))
    said = [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    assert len(said) == 1, result.summary["warnings"]  # after the stage, not at the start
    assert "after stages[0] (t = 0.02 s)" in said[0]
    assert "nothing fixed holds" in caplog.text  # at once, too
    weight, mass = RHO * G * 1.0, RHO * 8.0
    assert f"({0.0:.4g}, {weight:.4g}) N" in said[0].replace("-0,", "0,")
    assert f"at {weight / mass:.3g} m/s²" in said[0]
    times = np.array([f.time for f in result.frames])
    later = times > STAGE + 1e-9
    # the blocks that stay keep their rows' order: the mass-weighted mean of their centroids
    rise = np.array([f.centroids[:, 1].mean() for f in result.frames])
    at_stage = rise[np.argmin(np.abs(times - STAGE))]
    expected = 0.5 * weight / mass * (times[later] - STAGE) ** 2
    assert rise[later] - at_stage == pytest.approx(expected, rel=1e-8)  # measured 1.7e-10
    history = result.history  # the drift is the loads' work, not energy the numerics made
    excess = history["total_energy"] - result.summary["initial_energy"] - history["external_work"]
    assert excess.max() <= 1e-9 * result.summary["initial_energy"]


def test_a_section_on_a_fixed_base_is_held_and_not_said():
    result = dda.simulate(dda.load_scene(section(base=True)))
    assert not [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    free = result.final.centroids[:8]
    assert np.abs(free[:, 1].mean() - result.frames[0].centroids[:9][:, 1].mean()) < 1e-3


def test_a_balanced_section_is_not_said_at_the_start():
    raw = section(base=False)
    del raw["stages"]
    result = dda.simulate(dda.load_scene(raw))
    assert not [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    assert np.abs(result.final.displacements).max() < 1e-9


def test_a_section_in_its_field_that_nothing_holds_is_said_at_the_start():
    """In-situ stress, gravity, no fixed block and no boundary stress: its weight moves it
    as a whole at g (the momentum closed form, ½ g t²), said at the start with the remedy
    and not again after a stage that leaves the net force as it was."""
    raw = section(base=False)
    del raw["boundary_stresses"]
    raw["stages"] = [{"time": STAGE, "strength_factor": 1.5}]
    result = dda.simulate(dda.load_scene(raw))
    said = [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    assert len(said) == 1 and "at the start" in said[0], result.summary["warnings"]
    assert f"at {G:.3g} m/s²" in said[0] and "[[boundary_stresses]]" in said[0]
    times = np.array([f.time for f in result.frames])
    fall = np.array([f.centroids[:, 1].mean() for f in result.frames]) - 1.5
    assert fall[1:] == pytest.approx(-0.5 * G * times[1:] ** 2, rel=1e-6)


def test_a_static_run_that_nothing_holds_drifts_half_a_dt_t():
    """In a static analysis every step starts at rest, so the section's weight moves it by
    ½ g Δt² a step: ½ g Δt T by the end, as the warning says (½ g T² there would be 50
    times too much)."""
    raw = section(base=False)
    del raw["stages"], raw["boundary_stresses"]
    raw["analysis"].update(mode="static", duration=0.05)
    result = dda.simulate(dda.load_scene(raw))
    expected = 0.5 * G * 1e-3 * 0.05
    (said,) = [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    assert f"({expected:.3g} m by the run's end)" in said
    fall = result.frames[0].centroids[:, 1].mean() - result.final.centroids[:, 1].mean()
    assert fall == pytest.approx(expected, rel=1e-3)
    # a run given by its steps is told its drift too (it was left out: no duration)
    del raw["analysis"]["duration"]
    raw["analysis"]["steps"] = 50
    by_steps = dda.simulate(dda.load_scene(raw))
    (said,) = [text for text in by_steps.summary["warnings"] if "nothing fixed holds" in text]
    assert f"({expected:.3g} m by the run's end)" in said


def test_a_section_in_water_that_nothing_holds_is_said_without_a_drift():
    """With a water table the net force changes as the section moves (the uplift follows
    its submerged area: it comes to float), so the warning gives the force and the
    acceleration at the start but no ½ a t² drift to the run's end."""
    raw = section(base=False)
    del raw["boundary_stresses"], raw["stages"]
    raw["water"] = {"table": [[-10.0, 2.0], [10.0, 2.0]], "unit_weight": 9810.0}
    result = dda.simulate(dda.load_scene(raw))
    said = [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    assert len(said) == 1 and "at the start" in said[0], result.summary["warnings"]
    assert "the water's uplift changes as it moves" in said[0]
    assert "by the run's end" not in said[0]


def test_a_net_moment_is_said_and_turns_the_model_as_a_rigid_body(caplog):
    """A free unit block whose two sides alone carry a shear traction τ = 0.1 MPa: no net
    force, a couple M = τ · 1 m · 1 m = 1e5 N·m (per metre). The run says so at the start
    (before, only a net force was looked for: nothing was said), and the block turns at
    ω = M t / I, I = ρ / 6 (the forces turn with it, so the couple stays M)."""
    blocks = [{"name": "b", "material": "rock", "vertices": square(0.0, 0.0, 1.0, 1.0)}]
    raw = scene(
        blocks,
        duration=0.05,
        boundary_stresses=[{"stress": [0.0, 0.0, 1.0e5], "box": [-0.5, 0.2, 1.5, 0.8]}],
    )
    raw["analysis"]["save_every"] = 1
    result = dda.simulate(dda.load_scene(raw))
    said = [text for text in result.summary["warnings"] if "nothing fixed holds" in text]
    inertia = RHO / 6.0
    assert len(said) == 1 and "at the start" in said[0]
    assert "a net moment 1e+05 N·m" in said[0] and "net force" not in said[0]
    assert f"turns it at {1.0e5 / inertia:.3g} rad/s²" in said[0]
    assert "nothing fixed holds" in caplog.text
    final = result.final
    spin = 1.0e5 / inertia * final.time
    assert final.velocities[0, 2] == pytest.approx(spin, rel=1e-9)
