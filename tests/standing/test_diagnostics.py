"""Runs that cannot go on stop with a clear diagnostic; fracture down to the smallest piece."""

from __future__ import annotations

import pytest

import dda
from tests.helpers import ROCK, rectangle
from tests.standing.checks import (
    DIAGNOSTIC,
    check_areas,
    check_energy,
    check_finite,
    run_checked,
)
from tests.standing.scenes import base, block, scene


def test_a_step_that_cannot_settle_stops_with_the_step_time_and_reason():
    """One solve per step allowed, a soft initial penalty: the contacts never settle."""
    raw = scene(
        [base(), block("b", rectangle(0, 0.001, 1, 1.001))],
        {"duration": 0.1},
        contact={"penalty": 1e-4 * ROCK["young"], "max_iterations": 1},
    )
    with pytest.raises(dda.SimulationError) as caught:
        dda.simulate(raw)
    assert DIAGNOSTIC.search(str(caught.value))
    assert "contacts did not settle" in str(caught.value)
    partial = caught.value.result  # what was computed up to the failing step
    assert partial.summary["status"] == "failed"
    check_finite(partial)
    check_energy(partial)
    check_areas(dda.load_scene(raw), partial)


@pytest.mark.slow  # ~1300 steps, ~3 min
def test_repeated_fracturing_down_to_the_minimum_fragment():
    """A weak block crushed by a heavy one breaks again and again, never below min_area.

    51 breaks down to pieces of 0.0100 m². The run dissipates (friction between the
    fragments); single steps may still gain up to ~43 J (of ~7.5e3 J that moves), elastic
    and kinetic together in steps of 17-38 solves. (Overlap found at new contacts is
    pushed out without velocity, dda/contact/push_out.py: that was up to 127 J.)
    """
    weak = {
        "density": 2700.0,
        "young": 5.0e9,
        "poisson": 0.25,
        "cohesion": 1.0e3,
        "friction_angle": 30.0,
        "tensile_strength": 5.0e2,
    }
    raw = scene(
        [
            base(),
            block("w", rectangle(0, 0, 1, 1), "weak"),
            block("load", rectangle(-0.5, 1, 1.5, 3)),
        ],
        {"duration": 0.2},
        materials={"rock": ROCK, "weak": weak},
    )
    raw["joints"]["crack"] = {"friction_angle": 30.0}
    raw["fracture"] = {"joint": "crack", "min_area": 0.01}
    result = run_checked(raw)
    assert len(result.fracture_events) >= 2
    assert result.final.areas.min() >= 0.01 * (1 - 1e-9)
