"""The shipped rock masses run their full duration with every check of checks.py.

tests/test_cases.py runs them for a few steps; here the whole run (slow, ~10-50 s each):
finite values, no cut step, penetrations within the AL tolerance, no energy above E₀ + W, areas
changed only by the elastic strain. The first 40 steps of the slope run in the
default suite and must not cut the time step.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import dda
from tests.standing.checks import run_checked

CASES = Path(__file__).resolve().parents[2] / "cases"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tunnel", "tunnel_staged", "rock_slope"])
def test_rock_mass_runs_to_the_end_within_every_check(name):
    """... and without cutting a step (measured on the tunnel at penalties 4.99e10 to
    5.02e10: 0 cut steps in each, 9.85-14.55 solves a step; with Shi's velocity update,
    γ = 1, 14.34-18.76 solves, no cut step either)."""
    scene = dda.load_scene(CASES / f"{name}.toml")
    result = run_checked(scene)
    assert result.summary["status"] == "finished"
    assert result.summary["cut_steps"] == 0
    if name == "tunnel":  # measured 4.73 (1 solver thread) and 3.75 (2)
        assert result.summary["newton_iterations_per_step"] <= 6.0


def test_the_rock_slope_starts_without_cutting_the_time_step():
    """40 steps of the jointed slope from zero stress: every step settles at the full Δt."""
    raw = tomllib.loads((CASES / "rock_slope.toml").read_text())
    raw["analysis"].pop("duration")
    raw["analysis"]["steps"] = 40
    result = run_checked(raw)
    assert result.summary["cut_steps"] == 0
    assert result.final.time == pytest.approx(40 * raw["analysis"]["time_step"], rel=1e-12)
