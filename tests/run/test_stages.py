"""Staged excavation (dda/run/stages.py): blocks removed and bolts installed at given times."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.run import simulation
from tests.helpers import ROCK, G, rectangle


def stack(mode: str = "static", steps: int = 40, stages=None) -> dict:
    """Three 1 m blocks stacked on a fixed floor, then excavated from the top."""
    return {
        "analysis": {"mode": mode, "time_step": 0.01, "steps": steps, "gravity": [0.0, -G]},
        "contact": {"penalty": 5e10, "tolerance": 1e-6},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": [
            {"name": "floor", "material": "rock", "fixed": True,
             "vertices": rectangle(-2, -1, 3, 0)},
            *({"name": f"b{k}", "material": "rock", "vertices": rectangle(0, k, 1, k + 1)}
              for k in range(3)),
        ],
        "stages": stages or [{"time": 0.155, "remove": ["b2"]}],
        "measure": [{"name": "floor", "blocks": ["b0", "floor"]}],
    }  # fmt: skip


def test_a_stage_the_steps_never_reach_is_said():
    """An audit: with ``steps``, a stage at 0.003 s cuts a step short and Δt grows back by
    1.5× a step, so ten steps of 0.01 s end at 0.0821 s and the stage at 0.09 s, which
    the scene took (0.09 < 10 × 0.01), never happened, unsaid. The run says so; with
    ``duration`` both stages apply."""
    stages = [{"time": 0.003, "remove": ["b2"]}, {"time": 0.09, "remove": ["b1"]}]
    scene = stack("dynamic", 10, stages)
    result = dda.simulate(scene, keep_frames=False)
    assert result.summary["stages_done"] == 1
    said = [w for w in result.summary["warnings"] if "never applied" in w]
    assert said and "before the stage at t = 0.09 s" in said[0], result.summary["warnings"]
    scene["analysis"] = {**scene["analysis"], "duration": 0.1}
    del scene["analysis"]["steps"]
    timed = dda.simulate(scene, keep_frames=False)
    assert timed.summary["stages_done"] == 2
    assert not [w for w in timed.summary["warnings"] if "never applied" in w]


def test_the_removed_block_is_gone_and_the_rest_carries_on():
    """Before the stage the floor carries three blocks, after it two; the step before the
    stage is cut to end at 0.155 s exactly."""
    result = dda.simulate(stack())
    assert result.final.names == ("floor", "b0", "b1")
    m = result.measurements
    weight = ROCK["density"] * G
    at = int(np.argmin(np.abs(m["time"] - 0.155)))
    assert m["time"][at] == pytest.approx(0.155, abs=1e-12)
    assert m["floor.N"][at - 1] == pytest.approx(3 * weight, rel=1e-4)
    assert m["floor.N"][-1] == pytest.approx(2 * weight, rel=1e-4)
    assert result.summary["stages_done"] == 1 and result.summary["excavated_energy"] > 0.0
    assert "stages" in result.summary["active_effects"]


def test_the_contacts_that_stay_keep_their_history(monkeypatch):
    """The contacts of the blocks that stay come out of the stage with their keys, states,
    multipliers and forces, only their rows and vertex numbers renumbered."""
    seen = {}

    def apply(run):
        seen["before"] = run.contacts.copy()
        real(run)
        seen["after"] = run.contacts

    real = simulation.apply_due_stages
    monkeypatch.setattr(simulation, "apply_due_stages", apply)
    state = simulation._Run(simulation.build(dda.load_scene(stack(steps=20))))
    while state.stages_done == 0:
        simulation._advance(state)
    before, after = seen["before"], seen["after"]
    kept = np.isin(before.key, after.key)
    assert 0 < kept.sum() < len(before) and len(after) == kept.sum()
    order = np.argsort(after.key)
    first = np.argsort(before.key[kept])
    for name in ("state", "normal_multiplier", "shear_multiplier", "penalty", "normal_force"):
        old, new = getattr(before, name)[kept][first], getattr(after, name)[order]
        np.testing.assert_array_equal(old, new, err_msg=name)
    from dda.contact.rows import contact_rows

    geometry = contact_rows(state.blocks, after)  # their vertex and edge numbers hold
    np.testing.assert_allclose(geometry.penetration, after.penetration, atol=1e-9)


def test_a_stage_installs_its_bolts_at_their_pretension():
    stages = [
        {"time": 0.1, "remove": ["b2"]},
        {"time": 0.2, "bolts": [{"name": "tie", "start": [0.5, 0.5], "end": [0.5, -0.5],
                                 "stiffness": 1e8, "pretension": 2e4}]},
    ]  # fmt: skip
    scene = stack(stages=stages)
    scene["measure"].append({"name": "tie", "bolt": "tie"})
    result = dda.simulate(scene)
    m = result.measurements
    installed = int(np.flatnonzero(np.isclose(m["time"], 0.2, atol=1e-12))[0])
    assert np.all(m["tie.force"][:installed] == 0.0)
    assert m["tie.force"][installed] == 2e4
    # the pretension pulls b0 onto the floor: the floor carries two blocks and the bolt
    assert m["floor.N"][-1] == pytest.approx(2 * ROCK["density"] * G + m["tie.force"][-1], rel=1e-4)


def test_a_stage_bolt_whose_end_lies_off_its_block_is_said():
    """A free block falls beside its wall (dynamic, nothing holds it) and a stage at
    0.2 s bolts it to a ledge below where it was drawn: the start of that bolt, drawn
    0.05 m below the block's top, lies ½ g t² − 0.05 = 0.146 m above it by then, and the
    run says so; the bolt into the
    block standing on the floor is not said."""
    stages = [
        {
            "time": 0.2,
            "bolts": [
                {"name": "lost", "start": [3.5, 1.85], "end": [3.5, -0.5], "stiffness": 1e6},
                {"name": "held", "start": [0.5, 0.5], "end": [0.5, -0.5], "stiffness": 1e6},
            ],
        }
    ]
    scene = stack("dynamic", steps=25, stages=stages)  # fmt: skip
    scene["blocks"].append({"name": "faller", "material": "rock",
                            "vertices": rectangle(3, 0.9, 4, 1.9)})  # fmt: skip
    scene["blocks"][0]["vertices"] = rectangle(-2, -1, 2, 0)  # the floor ends before it
    scene["blocks"].append({"name": "ledge", "material": "rock", "fixed": True,
                            "vertices": rectangle(3, -1, 4, -0.6)})  # fmt: skip
    scene["stages"][0]["bolts"][0]["end"] = [3.5, -0.8]
    said = [w for w in dda.simulate(scene).summary["warnings"] if "bolt ends outside" in w]
    assert len(said) == 1 and "'lost' start" in said[0] and "'held'" not in said[0]
    gap = float(said[0].split("'lost' start ")[1].split(" m")[0])
    assert gap == pytest.approx(0.5 * G * 0.2**2 - 0.05, rel=0.02)


def test_energy_stays_within_its_budget_through_the_stages():
    result = dda.simulate(stack("dynamic", 60, [{"time": 0.2, "remove": ["b2"]}]))
    h = result.history
    e0 = result.summary["initial_energy"]
    assert np.all(h["total_energy"] <= e0 + h["external_work"] + 1e-9 * e0)
