"""A finished run says what its user should know although nothing failed
(dda.run.run_warnings), and shows its time without the steps' round-off."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

import dda
from dda.geometry import block_sizes
from dda.run.run_warnings import (
    CUT_STEPS_WARNING,
    ENERGY_WARNING,
    PENETRATION_WARNING,
    STATIC_MOTION_WARNING,
    cut_steps_warning,
    energy_excess,
    energy_warning,
    penetration_warning,
    smallest_free_size,
    static_motion_warning,
)
from dda.run.simulation import shown_time
from dda.solve import update
from tests.helpers import rectangle

CASES = Path(__file__).resolve().parents[2] / "cases"


def _analysis(scene, **changes):
    return dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, **changes))


def test_penetration_is_measured_against_the_smallest_free_block():
    sizes, fixed = np.array([10.0, 2.0, 1.0]), np.array([False, False, True])
    size = smallest_free_size(sizes, fixed)
    assert size == 2.0 and smallest_free_size(sizes, np.ones(3, bool)) is None
    at_limit = PENETRATION_WARNING * 2.0
    assert penetration_warning(at_limit, size, "m", False) is None
    text = penetration_warning(1.01 * at_limit, size, "m", False)
    assert text is not None and "1.01 %" in text and "(2 m," in text and "penalty" in text
    text = penetration_warning(1.01 * at_limit, size, "m", True)
    assert "lower [contact] tolerance" in text and "augmented-lagrangian" not in text
    assert penetration_warning(1.0, None, "m", False) is None  # nothing free


def test_a_block_size_is_four_times_its_area_over_its_perimeter():
    """A square's side; twice a sliver's thickness (1 m × 1 mm: 2.0e-3 m, where √A says
    3.2e-2 m and hid a sliver penetrated through a third of its thickness)."""
    square, sliver = rectangle(0.0, 0.0, 2.0, 2.0), rectangle(0.0, 0.0, 1.0, 1e-3)
    vertices = np.array(square + sliver, float)
    sizes = block_sizes(vertices, np.array([0, 4, 8]), np.array([4.0, 1e-3]))
    np.testing.assert_allclose(sizes, [2.0, 4e-3 / 2.002], rtol=1e-12)


def test_cut_steps_warn_beyond_their_share():
    steps = 100
    assert cut_steps_warning(int(CUT_STEPS_WARNING * steps), steps, 0.01, 0.1) is None
    text = cut_steps_warning(int(CUT_STEPS_WARNING * steps) + 1, steps, 0.01, 0.1)
    assert text is not None and "51 of 100 steps" in text and "0.01 s" in text


def test_static_motion_warns_beyond_its_fraction_of_the_allowed_step():
    assert static_motion_warning(STATIC_MOTION_WARNING * 0.02, 0.0, 0.02, "a", "m") is None
    text = static_motion_warning(1.1 * STATIC_MOTION_WARNING * 0.02, 0.0, 0.02, "a", "m")
    assert text is not None and "'a'" in text
    # moves that fall slowly: little a step, much still to go (ρ / (1 − ρ) of the last)
    creep = 1e-8
    assert static_motion_warning(creep, creep / 0.5, 0.02, "a", "m") is None
    text = static_motion_warning(creep, creep / (1 - 2e-5), 0.02, "a", "m")
    assert text is not None and "about 0.0005 m more" in text
    assert static_motion_warning(1e-15, 1e-15, 0.02, "a", "m") is None  # round-off


def test_a_static_run_that_moves_to_and_fro_is_said_so_not_extrapolated():
    """An audit: a bonded mass round an opening moved 4.51e-7 m at every step, back and
    forth, said as "about 0.0143 m more at that rate" (ten times its whole convergence).
    A last move back against the one before is said as the two states it alternates
    between."""
    from types import SimpleNamespace

    from dda.run.simulation import _last_motion_warning

    moved = 4.51e-7
    text = static_motion_warning(moved, moved / 0.99968, 0.02, "s1_12", "m", back=True)
    assert text.startswith(
        "the static analysis ended moving to and fro: block 's1_12' moved 4.51e-07 m in "
        "the last step, back against the step before"
    )
    assert "at that rate" not in text
    last = np.array([[0.0, 0.0], [moved, 0.0]])

    def state(before):
        blocks = SimpleNamespace(names=("a", "b"), count=2)
        return SimpleNamespace(
            last_moves=(last, np.array([0, 1]), ("a", "b")), moves_before=before,
            move_before=float(np.abs(before).max()), static_held=(0.0, -1), blocks=blocks,
            model=SimpleNamespace(allowed_displacement=0.02),
            energy=SimpleNamespace(gravity=None),
        )  # fmt: skip

    assert "to and fro" in _last_motion_warning(state(-last / 0.99968), "m")
    onward = _last_motion_warning(state(last / 0.99968), "m")  # the same way: settling
    assert "to and fro" not in onward and "more at that rate" in onward


def test_a_block_without_support_in_a_static_analysis_is_said_to_move():
    """Static, gravity, a free block 2 m above a fixed one: each step moves it by its
    free fall over Δt (g Δt² / 2 = 4.9e-4 m), against 0 for a model that settles."""
    scene = dda.load_scene(CASES / "self_weight.toml")
    base = scene.blocks[0]
    assert base.fixed
    low = min(y for _, y in base.vertices)
    lone = dataclasses.replace(
        scene.blocks[-1],
        name="lone",
        fixed=False,
        vertices=[(0.0, low - 10.0), (1.0, low - 10.0), (1.0, low - 9.0), (0.0, low - 9.0)],
    )
    alone = dataclasses.replace(scene, blocks=[*scene.blocks, lone])
    warnings = dda.simulate(_analysis(alone, steps=5), keep_frames=False).summary["warnings"]
    assert len(warnings) == 1 and "block 'lone' moved" in warnings[0]
    assert dda.simulate(scene, keep_frames=False).summary["warnings"] == []


def test_the_pure_penalty_case_warns_of_its_penetration():
    """The paper's Fig. 2a: the penalty method lets the blocks sink 0.62 ft into each
    other (11 % of the top block's 5.66 ft), what its augmented-Lagrangian twin
    removes (9.5e-5 ft)."""
    penalty = dda.simulate(
        dda.load_scene(CASES / "paper_two_blocks_penalty.toml"), keep_frames=False
    )
    assert len(penalty.summary["warnings"]) == 1
    assert "penetrated by up to 0.622 ft" in penalty.summary["warnings"][0]
    augmented = dda.load_scene(CASES / "paper_two_blocks.toml")
    assert dda.simulate(augmented, keep_frames=False).summary["warnings"] == []


def test_a_time_step_cut_at_most_steps_is_said():
    """The sliding block at Δt = 1 s: the block slides off its slab and falls, every
    attempt moves it beyond the allowed displacement, and the steps are cut."""
    scene = _analysis(dda.load_scene(CASES / "sliding_block.toml"), time_step=1.0, duration=2.0)
    summary = dda.simulate(scene, keep_frames=False).summary
    assert summary["cut_steps"] > CUT_STEPS_WARNING * summary["steps"]
    assert summary["smallest_cut_time_step"] < 1.0
    assert len(summary["warnings"]) == 1 and "the time step was cut at" in summary["warnings"][0]


def test_the_cut_steps_are_steps_not_attempts():
    """The rock between platens at 1.02 C0 (8 static steps, some cut twice): "cut at 10 of
    8 steps" counted the attempts."""
    from tests.fracture.test_run import platen_scene

    summary = dda.simulate(platen_scene(1.02, 8), keep_frames=False).summary
    assert 0 < summary["cut_steps"] <= summary["steps"]


@pytest.mark.parametrize(
    ("summed", "shown"), [(3.149999999999977, 3.15), (6.2799999999999105, 6.28), (0.0, 0.0)]
)
def test_the_shown_time_drops_the_round_off_of_the_sum(summed, shown):
    assert shown_time(summed) == shown


def test_outputs_show_the_time_of_the_steps():
    """315 steps of 0.01 s: the sum is 3.149999999999977; history, frames and summary
    show 3.15, and 0.1 (not 0.09999999999999999) after 10 steps."""
    result = dda.simulate(dda.load_scene(CASES / "paper_two_blocks.toml"))
    assert result.summary["time"] == 3.15
    assert result.history["time"][9] == 0.1
    assert result.frames[-1].time == 3.15
    assert [f.time for f in result.frames[:3]] == [0.0, 0.05, 0.1]


def _history(kinetic, contact, work=None):
    """An energy history of the given kinetic and contact energies (nothing else)."""
    kinetic, contact = np.asarray(kinetic, float), np.asarray(contact, float)
    zero = np.zeros_like(kinetic)
    return {
        "kinetic_energy": kinetic,
        "potential_energy": zero,
        "elastic_energy": zero,
        "contact_energy": contact,
        "total_energy": kinetic + contact,
        "external_work": zero if work is None else np.asarray(work, float),
    }


def test_energy_the_blocks_gain_from_nowhere_is_said():
    """E0 = 100 of kinetic energy: the blocks back at 101.5 is 1.5 % of what moved."""
    assert energy_warning(_history([100.0, 50.0, 100.5], [0.0, 50.0, 0.0]), 100.0) is None
    text = energy_warning(_history([100.0, 50.0, 101.5], [0.0, 50.0, 0.0]), 100.0)
    assert text is not None and "rose 1.5 above" in text and "1.5 %" in text
    loaded = _history([100.0, 120.0], [0.0, 0.0], work=[0.0, 20.0])  # the loads' work
    assert energy_warning(loaded, 100.0) is None


def test_round_off_of_a_large_energy_at_rest_is_no_creation():
    """An audit: a 400-block mass held in its field by boundary stresses, nothing moving
    beyond 1e-14 m, E0 = 3.6e5 J of strain energy, "created energy: rose 1.21e-06"
    (3.4e-12 of E0, 100 % of the energy that moved). The allowance is 1e-10 of the
    energies; 1e-4 J (2.8e-10 of E0) is still said."""
    at_rest = _history([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    at_rest["elastic_energy"] = np.full(3, 3.6e5)
    at_rest["total_energy"] = np.array([3.6e5, 3.6e5 + 1.21e-6, 3.6e5])
    assert energy_warning(at_rest, 3.6e5, start={"elastic": 3.6e5}) is None
    at_rest["total_energy"] = np.array([3.6e5, 3.6e5 + 1e-4, 3.6e5])
    assert energy_warning(at_rest, 3.6e5, start={"elastic": 3.6e5}) is not None


def test_energy_made_after_a_stage_removed_blocks_is_said():
    """A stage removes blocks holding 1,000 (X): the total falls by that, and energy the
    blocks gain after it is judged against E0 + W − X, not hidden below E0 (2 above
    E0 + W − X is 2 % of the 102 that moved; the removed blocks' fall of V is no motion)."""
    history = _history([100.0, 50.0, 102.0], [0.0, 50.0, 0.0])
    history["potential_energy"] = np.array([1000.0, 1000.0, 0.0])
    history["total_energy"] = history["total_energy"] + history["potential_energy"]
    history["excavated_energy"] = np.array([0.0, 0.0, 1000.0])
    excess, moved, _ = energy_excess(history, 1100.0)
    assert (excess, moved) == (pytest.approx(2.0), pytest.approx(102.0))
    text = energy_warning(history, 1100.0)
    assert text is not None and "rose 2 above" in text and "2 %" in text


def test_energy_made_beside_contacts_loaded_at_the_start_is_said():
    """An audit: two bonded blocks spun at 4 rad/s gained 352 J, said alone and unsaid
    beside a block pressed on a floor (C0 = 1,348 J at the start: the blocks' energy was
    judged against E0 with C0 in it, and the springs' 1,348 J counted as energy that
    moved). Here C0 = 1,000 stays in the springs while the blocks gain 2 (2 % of the 102
    that moved): said. Springs that give C0 back to the blocks, or whose energy rises
    above C0 as a block settles, are no source."""
    start = {"contact": 1000.0}
    kept = _history([100.0, 50.0, 102.0], [1000.0, 1050.0, 1000.0])
    assert energy_excess(kept, 1100.0, False)[0] < 0.0  # C0 not told: the gain hidden
    excess, moved, _ = energy_excess(kept, 1100.0, False, start)
    assert (excess, moved) == (pytest.approx(2.0), pytest.approx(102.0))
    text = energy_warning(kept, 1100.0, start=start)
    assert text is not None and "rose 2 above" in text and "2 %" in text
    given_back = _history([100.0, 600.0, 1100.0], [1000.0, 500.0, 0.0])
    assert energy_warning(given_back, 1100.0, start=start) is None
    settling = _history([100.0, 50.0, 100.0], [1000.0, 1200.0, 1300.0])
    assert energy_warning(settling, 1100.0, start=start) is None


def test_the_energy_warning_gives_the_evidence_for_its_cause():
    """The steps the push-out acted at, when it did; the fastest block at the end, a
    sliver called one; the advice of a smaller time step."""
    created = _history([100.0, 50.0, 101.5], [0.0, 50.0, 0.0])
    rattled = energy_warning(created, 100.0, 0, ("b6", 7.43, 34.0))
    assert "push-out" not in rattled
    assert "'b6' (7.43 m/s, a sliver 34 times as long as thick)" in rattled
    assert "smaller analysis.time_step" in rattled
    pushed = energy_warning(created, 100.0, 3, ("b1", 0.2, 4.0), ("ft", "s"))
    assert "The push-out removed overlaps at 3 step(s)" in pushed
    assert "'b1' (0.2 ft/s):" in pushed and "as long as thick" not in pushed


def test_the_energy_warning_names_a_turning_block_that_is_no_sliver():
    """An audit: two bonded 1 m blocks spun at 4 rad/s gained 1.9 % in 2 s (the gaps are
    linearised within a step) and the warning blamed a small or thin block's contacts.
    A block turning 1e-3 rad a step or more, no sliver, is named instead; a slower one,
    or a sliver, leaves the rattle as the cause."""
    created = _history([100.0, 50.0, 101.5], [0.0, 50.0, 0.0])
    turned = energy_warning(created, 100.0, 0, ("a", 2.0, 4.0), ("m", "s"), ("b", 4.0, 4e-3))
    assert "The fastest-turning block is 'b' (4 rad/s, 0.004 rad a step)" in turned
    assert "linearised within a step" in turned and "thin block" not in turned
    slow = energy_warning(created, 100.0, 0, ("a", 2.0, 4.0), ("m", "s"), ("b", 0.5, 5e-4))
    assert "turning" not in slow and "small or thin block" in slow
    sliver = energy_warning(created, 100.0, 0, ("a", 2.0, 40.0), ("m", "s"), ("a", 9.0, 9e-3))
    assert "turning" not in sliver and "a sliver 40 times" in sliver


def test_the_energy_warning_blames_no_contact_where_none_carried_a_force():
    """A run whose contacts never held energy (a block swinging on a bolt alone): the
    advice of a smaller time step without the contacts of a thin block as the cause."""
    alone = _history([100.0, 50.0, 101.5], [0.0, 0.0, 0.0])
    text = energy_warning(alone, 100.0, 0, ("b1", 2.0, 4.0))
    assert "No contact carried a force" in text and "smaller analysis.time_step" in text
    assert "for the contacts of a small or thin block" not in text
    touched = energy_warning(_history([100.0, 50.0, 101.5], [0.0, 1.0, 0.0]), 100.0, 0,
                             ("b1", 2.0, 4.0))  # fmt: skip
    assert "for the contacts of a small or thin block" in touched


def test_the_contact_springs_share_is_left_out_of_the_energy_warning():
    """The history counts a contact's Σ N²/(2p), more than an augmented-Lagrangian
    contact holds: the paper's two blocks settle with 1.12 ft·lb there against 0.27 of
    work, while their own energy stays below E0 + W."""
    settling = _history([0.0, 0.0], [0.0, 1.12], work=[0.0, 0.27])
    assert energy_excess(settling, 0.0)[0] == pytest.approx(0.85)
    assert energy_warning(settling, 0.0) is None
    paper = dda.simulate(dda.load_scene(CASES / "paper_two_blocks.toml"), keep_frames=False)
    assert not any("created energy" in text for text in paper.summary["warnings"])


def test_a_run_that_creates_energy_says_so(monkeypatch):
    """A fault that makes energy: the velocity update given 2 % more of the step's
    displacement (cases/sliding_block.toml). The run's blocks end with more energy than
    they started with plus the work done on them, and it says so; the same warning is
    said exactly when the excess passes its threshold. (A scene drawn overlapping made
    energy by its contact's spring before overlaps found at a contact went by position,
    dda.contact.push_out.)"""
    new_velocity = update.new_velocity

    def faster(d, velocity, acceleration, dt, gamma):
        return new_velocity(1.02 * d, velocity, acceleration, dt, gamma)

    monkeypatch.setattr(update, "new_velocity", faster)
    monkeypatch.setattr(update, "apply_kernel", None)  # its compiled twin has no fault
    raw = tomllib.loads((CASES / "sliding_block.toml").read_text())
    raw["analysis"].pop("duration", None)
    raw["analysis"]["steps"] = 50
    result = dda.simulate(dda.load_scene(raw), keep_frames=False)
    excess, moved, _ = energy_excess(result.history, result.summary["initial_energy"], False)
    assert excess > ENERGY_WARNING * moved
    assert any("created energy" in text for text in result.summary["warnings"])


def test_a_static_analysis_is_not_held_to_an_energy_balance():
    """cases/verify/swing.toml: a block hung from a fixed point, drawn turned by 0.6 rad,
    in a static run: its first pseudo-step stores 2.3e5 J in the point's spring (29 times
    the fall of its potential energy), which a static run, resetting the velocities at
    every step, does not balance; no energy warning there."""
    result = dda.simulate(dda.load_scene(CASES / "verify" / "swing.toml"), keep_frames=False)
    excess, moved, _ = energy_excess(result.history, result.summary["initial_energy"], False)
    assert excess > 10 * moved
    assert not any("created energy" in text for text in result.summary["warnings"])


@pytest.mark.parametrize(
    "materials, min_area, said",
    [
        ({"rock": {"cohesion": 1e5, "friction_angle": 30.0, "tensile_strength": 1e4}}, 0.5, None),
        ({"rock": {"cohesion": 1e5, "friction_angle": 30.0, "tensile_strength": 1e4}}, 0.6,
         "min_area 0.6 m² is more than half of every breakable block's area"),
        ({}, 0.01, "no free block's material has the strength keys"),
    ],
    ids=["can-break", "min-area-too-large", "no-breakable-material"],
)  # fmt: skip
def test_a_fracture_that_can_break_nothing_is_said(materials, min_area, said):
    """[fracture] on a 1 m² block with strength keys and min_area 0.5 m² can split it
    (two pieces of 0.5); with 0.6 m², or without strength keys, nothing can break, and
    the run says so (it was silent). The block is unloaded: nothing breaks either way."""
    rock = {"density": 2500.0, "young": 1e9, "poisson": 0.25, **materials.get("rock", {})}
    raw = {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 2},
        "materials": {"rock": rock},
        "joints": {"crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack", "min_area": min_area},
        "blocks": [{"name": "a", "material": "rock",
                    "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]}],
    }  # fmt: skip
    warnings = dda.simulate(dda.load_scene(raw)).summary["warnings"]
    if said is None:
        assert warnings == []
    else:
        assert len(warnings) == 1 and said in warnings[0]


@pytest.mark.parametrize(("dt", "said"), [(1e-2, False), (1e-3, True)])
def test_a_static_bolt_short_of_its_force_is_said(dt, said):
    """cases/bolted_block.toml (static) holds the closed form T = W (sin 30° − cos 30°
    tan 20°) = 2447.30 N to 2e-8 at its Δt = 1e-2. At Δt = 1e-3 a static step goes a
    hundredth as far: after its 1,000 steps the bolt carries 2386.2 N (2.5 % short) while
    the block creeps by 2.3e-8 m a step, 6e-6 m from rest, and the last step's damping
    holds 0.46 % of its weight: said (before, no warning)."""
    scene = tomllib.loads((CASES / "bolted_block.toml").read_text())
    scene["analysis"]["time_step"] = dt
    result = dda.simulate(scene)
    tension = result.final.bolt_tensions[0]
    text = " ".join(result.summary["warnings"])
    assert ("still moving" in text) == said
    if said:
        assert "held 0.0046 of block 'slider''s weight" in text
        assert tension == pytest.approx(2386.23, rel=1e-4)
    else:
        assert tension == pytest.approx(2447.30, rel=1e-5)


def test_the_relaxed_in_situ_field_is_said_with_its_likely_cause():
    """Boundary stresses given, a field relaxed: the advice to give boundary stresses was
    wrong (a strength-reduction trial whose joints opened in tension got it); joints that
    slip under the field's shear are named as the cause."""
    from dda.run.run_warnings import in_situ_warning

    assert in_situ_warning(0.5, "b1") is not None
    assert "give its free outer blocks [[boundary_stresses]]" in in_situ_warning(0.5, "b1")
    bounded = in_situ_warning(0.5, "b1", "bounded")
    assert "[[boundary_stresses]]" not in bounded and "joints give way under it" in bounded
    slipped = in_situ_warning(0.5, "b1", "slipped")
    assert "joints slip under the field's shear" in slipped
    assert in_situ_warning(1e-9, "b1", "slipped") is None


def test_a_static_slide_is_not_given_a_way_still_to_go():
    """A block sliding beyond its friction moves alike each static step: the way "still to
    go" was round-off's ("about 3.73e+06 m more"); it is said to move, without a number,
    and sliding is named among the causes."""
    moved = 8e-5
    text = static_motion_warning(moved, moved * (1 + 2e-11), 0.02, "a", "m")
    assert text is not None and "more at that rate" not in text
    assert "sliding beyond its joints' friction" in text
    creep = 1e-8  # a creep that falls is still given its way to go
    assert "about 0.0005 m more" in static_motion_warning(creep, creep / (1 - 2e-5), 0.02, "a", "m")


def test_a_static_model_loaded_without_gravity_is_said_not_at_rest():
    """A block pressed on a base by a point load of 1e4 N, no gravity, static: 5 steps at
    Δt = 1e-3 left 19 % of the load held by the damping (N carried 81 %) and said nothing
    (the check measured the held force against the weight, and there was none)."""
    scene = {
        "analysis": {"mode": "static", "time_step": 1e-3, "steps": 5},
        "materials": {"rock": {"density": 2700.0, "young": 1e9, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True,
             "vertices": [[-1, -1], [2, -1], [2, 0], [-1, 0]]},
            {"name": "b", "material": "rock", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]},
        ],
        "loads": [{"block": "b", "point": [0.5, 1.0], "force": [0.0, -1e4]}],
    }  # fmt: skip
    result = dda.simulate(scene, keep_frames=False)
    carried = result.final.contacts.normal_force.sum()
    assert carried < 0.9e4  # not at rest
    (said,) = [w for w in result.summary["warnings"] if "still moving" in w]
    assert "damping held" in said and "of the largest load on a block" in said
    scene["analysis"]["steps"] = 400  # at rest: nothing said
    rested = dda.simulate(scene, keep_frames=False)
    assert rested.final.contacts.normal_force.sum() == pytest.approx(1e4, rel=1e-3)
    assert not any("still moving" in w for w in rested.summary["warnings"])
