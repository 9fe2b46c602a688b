"""A run that cannot go on stops with a clear message, never with NaN output."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from tests.helpers import slope_scene


def test_step_that_never_settles_raises_a_clear_error():
    scene = slope_scene(20.0, "augmented-lagrangian")
    scene["contact"]["max_iterations"] = 1
    scene["contact"]["tolerance"] = 1e-15
    with pytest.raises(dda.SimulationError, match=r"step \d+ .*did not settle") as info:
        dda.simulate(scene)
    partial = info.value.result
    assert partial.summary["status"] == "failed"
    assert all(np.all(np.isfinite(f.centroids)) for f in partial.frames)


def test_cut_steps_are_counted_and_time_is_reached():
    scene = slope_scene(10.0, "penalty", time_step=0.05)
    scene["analysis"]["max_displacement_ratio"] = 0.002
    result = dda.simulate(scene)
    assert result.summary["cut_steps"] > 0
    assert result.final.time == pytest.approx(1.0, abs=1e-12)


def test_the_last_steps_end_the_run_without_a_sliver():
    """Δt 0.3 over 1.0 s: 0.3, 0.3, then the 0.4 left in two steps of 0.2 (not 0.3 + 0.1);
    a duration that is a whole number of steps keeps them all equal despite round-off."""
    from dda.run.simulation import _step_length

    assert _step_length(0.3, 0.4) == pytest.approx(0.2)
    assert _step_length(0.3, 0.2) == pytest.approx(0.2)
    assert _step_length(0.3, 0.7) == 0.3
    assert _step_length(0.1, 0.1 * (1 + 1e-15)) == pytest.approx(0.1, rel=1e-12)
