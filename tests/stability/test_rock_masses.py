"""The shipped rock masses run their full duration with every stability check.

tests/test_cases.py runs them for 3 steps; here the whole run (slow, ~10-50 s each):
finite values, penetrations within the AL tolerance, no energy above E₀ + W, areas
changed only by the elastic strain. The first 40 steps of the slope run in the
default suite and must not cut the time step.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import dda
from tests.stability.checks import run_checked

CASES = Path(__file__).resolve().parents[2] / "cases"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tunnel", "rock_slope"])
def test_rock_mass_runs_to_the_end_within_every_check(name):
    scene = dda.load_scene(CASES / f"{name}.toml")
    result = run_checked(scene)
    assert result.summary["status"] == "finished"


def test_the_rock_slope_starts_without_cutting_the_time_step():
    """40 steps of the jointed slope from zero stress: every step settles at the full Δt."""
    raw = tomllib.loads((CASES / "rock_slope.toml").read_text())
    raw["analysis"].pop("duration")
    raw["analysis"]["steps"] = 40
    result = run_checked(raw)
    assert result.summary["cut_steps"] == 0
    assert result.final.time == pytest.approx(40 * raw["analysis"]["time_step"], rel=1e-12)
