"""A finished run says what its user should know although nothing failed
(dda.run.run_warnings), and shows its time without the steps' round-off."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import dda
from dda.run.run_warnings import (
    CUT_STEPS_WARNING,
    PENETRATION_WARNING,
    STATIC_MOTION_WARNING,
    cut_steps_warning,
    penetration_warning,
    static_motion_warning,
)
from dda.run.simulation import shown_time

CASES = Path(__file__).resolve().parents[2] / "cases"


def _analysis(scene, **changes):
    return dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, **changes))


def test_penetration_is_measured_against_the_smallest_free_block():
    areas, fixed = np.array([100.0, 4.0, 1.0]), np.array([False, False, True])  # sizes 10, 2
    at_limit = PENETRATION_WARNING * 2.0
    assert penetration_warning(at_limit, areas, fixed, "m") is None
    text = penetration_warning(1.01 * at_limit, areas, fixed, "m")
    assert text is not None and "1.01 %" in text and "(2 m)" in text
    assert penetration_warning(1.0, areas, np.ones(3, bool), "m") is None  # nothing free


def test_cut_steps_warn_beyond_their_share():
    steps = 100
    assert cut_steps_warning(int(CUT_STEPS_WARNING * steps), steps, 0.01, 0.1) is None
    text = cut_steps_warning(int(CUT_STEPS_WARNING * steps) + 1, steps, 0.01, 0.1)
    assert text is not None and "51 of 100 steps" in text and "0.01 s" in text


def test_static_motion_warns_beyond_its_fraction_of_the_allowed_step():
    assert static_motion_warning(STATIC_MOTION_WARNING * 0.02, 0.02, "a", "m") is None
    text = static_motion_warning(1.1 * STATIC_MOTION_WARNING * 0.02, 0.02, "a", "m")
    assert text is not None and "'a'" in text


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
