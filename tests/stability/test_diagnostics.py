"""Runs that cannot go on stop with a clear diagnostic; fracture down to the smallest piece."""

from __future__ import annotations

import pytest

import dda
from tests.helpers import ROCK, rectangle
from tests.stability.checks import (
    DIAGNOSTIC,
    check_areas,
    check_energy,
    check_finite,
    run_checked,
)
from tests.stability.scenes import base, block, scene


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


@pytest.mark.slow  # 1200 steps, ~3.5 min
@pytest.mark.xfail(
    reason="engine (open issue): the run finishes (51 breaks, smallest piece 0.0100) and "
    "at this commit passes, but single steps still gain up to 660 J: a vertex-vertex "
    "pairing of the touching vertex hides the other vertex sinking into the fragment "
    "(below the pairing checks' slack, 0.6 mm) until the pairing turns and AL pushes "
    "0.5 mm out in one cut step (2 d/Δt after Shi's update); whether the total stays "
    "below E0 + W depends on round-off-level details (an earlier commit: +1.1e3 J)",
    strict=False,
)
def test_repeated_fracturing_down_to_the_minimum_fragment():
    """A weak block crushed by a heavy one breaks again and again, never below min_area."""
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
