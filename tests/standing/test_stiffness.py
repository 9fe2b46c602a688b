"""Stiffness and penalty extremes: a 1e4 contrast, AL penalties from 1e-4 E to 1e4 E."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import ROCK, rectangle
from tests.standing.checks import run_checked
from tests.standing.scenes import base, block, scene

STIFF = {"density": 2700.0, "young": 5.0e10, "poisson": 0.25}
SOFT = {"density": 2700.0, "young": 5.0e6, "poisson": 0.25}


def contrast_stack(**analysis) -> dict:
    blocks = [base(material="stiff")]
    blocks += [
        block(f"b{k}", rectangle(0, k, 1, k + 1), "stiff" if k % 2 else "soft") for k in range(6)
    ]
    return scene(blocks, analysis, materials={"stiff": STIFF, "soft": SOFT})


def test_stiffness_contrast_of_ten_thousand_between_neighbours():
    result = run_checked(contrast_stack(duration=0.2))
    assert np.abs(result.final.displacements[1:, 0]).max() < 1e-3


@pytest.mark.slow
def test_stiffness_contrast_settles_to_the_weight_above():
    """Static analysis: the base carries the weight; the soft bottom block the 5.5 above.

    The soft blocks strain by 3 %; they keep their mass, ρ times their initial area,
    so the base carries ρ g · 6 m². Static relaxation of the soft blocks needs ~1000
    steps.
    """
    result = run_checked(contrast_stack(mode="static", time_step=0.01, steps=1000))
    final = result.final
    weight = 2700.0 * 9.81 * result.frames[0].areas[1:].sum()
    c = final.contacts
    names = np.array(final.names)
    on_base = (c.state > 0) & ((names[c.block_a] == "base") | (names[c.block_b] == "base"))
    assert c.normal_force[on_base].sum() == pytest.approx(weight, rel=1e-3)
    assert final.stresses[1, 1] == pytest.approx(-2700.0 * 9.81 * 5.5, rel=0.01)


def dropped_block(penalty: float, duration: float) -> dict:
    blocks = [base(), block("b", rectangle(0, 0.01, 1, 1.01))]
    return scene(blocks, {"duration": duration}, contact={"penalty": penalty})


@pytest.mark.parametrize("factor", [1e-4, 1e-2, 1.0, 1e2, 1e4])
def test_al_from_any_initial_penalty_lands_and_rests(factor):
    """The block falls 1 cm and lands; the variable penalty finds the stiffness."""
    result = run_checked(dropped_block(factor * ROCK["young"], 0.15))
    final = result.final
    assert final.displacements[1, 1] == pytest.approx(-0.01, abs=2e-5)
    assert np.abs(final.velocities[1]).max() < 1e-2


@pytest.mark.slow
@pytest.mark.parametrize("factor", [1e-4, 1e4])
def test_al_extreme_penalties_hold_a_second(factor):
    """A second on the base, at rest where it landed (1 cm down, to 2e-5 m).

    Shi's update (v1 = 2D/Δt − v0) does not damp the contact's own vibration,
    far faster than Δt with p = 1e4 E: of the 0.44 m/s of the landing, 6e-3
    m/s stays as a velocity flipping sign every step (measured; 1.4 %), so
    the bound is 0.01 m/s.
    """
    result = run_checked(dropped_block(factor * ROCK["young"], 1.0))
    assert result.final.displacements[1, 1] == pytest.approx(-0.01, abs=2e-5)
    assert np.abs(result.final.velocities[1]).max() < 0.01
