"""A strength-reduction trial of a scene with [seismic] judges the blocks' motion
relative to the ground (dda/stability/criterion.py): the ground keeps the last velocity
of its record (cases/seismic_slope.toml: 0.5 g for 0.2 s, then 0.981 m/s), which is no
block's failure."""

from __future__ import annotations

import tomllib

import pytest

import dda.cases
from dda.stability.trial import Trial, run_trial

CASE = dda.cases.folder().joinpath("seismic_slope.toml")


def trial(factor: float) -> dict:
    raw = tomllib.loads(CASE.read_text())
    return run_trial(Trial(raw, factor, str(CASE), keep_frame=False))


def test_a_block_that_rides_the_ground_stands():
    """F = 0.25: friction atan(4 tan 35°) = 70°, the block rides the slab through the
    pulse and moves with it at 0.981 m/s after it; relative to the ground it is at rest."""
    row = trial(0.25)
    assert not row["failed"], row
    assert row["speed"] < 1e-3 * row["limit"]


@pytest.mark.parametrize("factor", [2.0])
def test_a_block_that_slides_on_the_ground_fails(factor):
    """F = 2: tan φ / F = tan 19.3° < tan 20°, the block slides down the slab without the
    earthquake (the static factor of safety tan 35° / tan 20° = 1.92)."""
    row = trial(factor)
    assert row["failed"], row
    assert row["speed"] > 10 * row["limit"]
