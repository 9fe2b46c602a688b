"""Many blocks carrying each other: a settling column and a voussoir arch."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import ROCK, G
from tests.standing.checks import run_checked
from tests.standing.scenes import arch, column, scene


def test_column_of_twenty_blocks_settles():
    """20 blocks stacked without gaps settle elastically and stay in line."""
    result = run_checked(scene(column(20, gap=0.0), {"duration": 0.2}))
    final = result.final
    assert np.abs(final.displacements[1:, 0]).max() < 1e-4  # as the stack of five
    assert np.abs(final.rotations[1:]).max() < 1e-4
    # the column shortens by its elastic strain only: Σ ρ g (20 - k - 1/2) / E over the blocks
    shortening = ROCK["density"] * G * sum(20 - k - 0.5 for k in range(20)) / ROCK["young"]
    assert -final.displacements[-1, 1] < 2.5 * shortening


def test_column_of_twenty_blocks_dropped_onto_each_other_stays_a_column():
    """20 blocks with a 1 mm gap under each: they land on each other and stay stacked."""
    result = run_checked(scene(column(20), {"duration": 0.2}))
    final = result.final
    assert np.abs(final.displacements[1:, 0]).max() < 1e-2
    assert np.abs(final.rotations[1:]).max() < 1e-2
    assert final.displacements[-1, 1] < -0.015  # the gaps have closed


@pytest.mark.slow
def test_column_of_twenty_blocks_comes_to_rest_with_the_weight_on_the_base():
    result = run_checked(scene(column(20, gap=0.0), {"duration": 2.0, "save_every": 100}))
    final = result.final
    assert np.abs(final.velocities[1:, :2]).max() < 0.05
    bottom = -ROCK["density"] * G * 19.5  # mean σyy of the bottom block: 19.5 blocks above
    assert final.stresses[1, 1] == pytest.approx(bottom, rel=0.05)


def crown_drop(result) -> float:
    crown = result.final.names.index("v18")
    return float(-result.final.displacements[crown, 1])


def test_semicircular_arch_stands_under_self_weight():
    """36 voussoirs, t/R = 0.15 (Heyman's limit is about 0.107), φ = 35°."""
    result = run_checked(scene(arch(), {"duration": 0.1}, friction=35.0))
    assert crown_drop(result) < 1e-3
    state = result.final.contacts.state
    assert np.count_nonzero(state > 0) >= 0.9 * len(state)  # the joints stay shut


@pytest.mark.slow
def test_semicircular_arch_still_stands_after_two_seconds():
    result = run_checked(scene(arch(), {"duration": 2.0, "save_every": 100}, friction=35.0))
    assert crown_drop(result) < 1e-3
    assert np.abs(result.final.velocities[1:, :2]).max() < 0.01
