"""The shipped rock masses run their full duration with every stability check.

tests/test_cases.py runs them for 3 steps; here the whole run (slow, ~12 s each):
finite values, penetrations within the AL tolerance, no energy above E₀ + W, areas
changed only by the elastic strain. The tunnel once released 8e7 J in one step at
t = 0.897 s, from a vertex in contact with both faces of a sliver (docs/contact.md,
the narrow phase), with two PARDISO threads only.
"""

from __future__ import annotations

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
