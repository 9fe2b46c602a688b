"""The contact search looks as far as the blocks can move in a step (dda.contact.reach).

Shi's distance (2.5 x the largest displacement a step may make) is several blocks
on a large model; the run searches for gaps up to 2.5 r, r four times the last
step's largest vertex displacement, and redoes a step that moves further than r
after a search with Shi's distance. Expectations: the formula; the same motion as
with Shi's distance where the far contacts carry nothing; a step that outruns the
reach is redone with the full search and gives what the full search gives.
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
import dda.contact.reach as reach
from dda.bench.scenes import wall_scene


def test_the_reach_follows_the_last_step_within_its_bounds():
    assert reach.next_reach(0.01, 1.0) == pytest.approx(0.04)  # 4 x the last motion
    assert reach.next_reach(0.0, 1.0) == pytest.approx(1.0 / 64.0)  # never below the floor
    assert reach.next_reach(0.5, 1.0) == 1.0  # never beyond Shi's allowance
    assert reach.beyond(0.05, 0.04, 1.0) and not reach.beyond(0.04, 0.04, 1.0)
    assert not reach.beyond(2.0, 1.0, 1.0)  # at the allowance the step is cut instead


def _wide_wall(steps: int) -> dict:
    scene = wall_scene(6, steps=steps)
    scene["analysis"]["max_displacement_ratio"] = 0.25  # Shi's search distance ≈ 3 blocks
    return scene


def _run(scene: dict, monkeypatch, floor: float | None = None, growth: float | None = None):
    with monkeypatch.context() as patch:
        if floor is not None:
            patch.setattr(reach, "FLOOR", floor)
        if growth is not None:
            patch.setattr(reach, "GROWTH", growth)
        return dda.simulate(dda.load_scene(scene))


def test_the_narrow_search_moves_the_wall_as_the_full_one_does(monkeypatch):
    """6 x 6 wall, Shi's distance ≈ 3 blocks: the contacts a block or more apart that
    the full search adds stay open and carry nothing; 30 steps agree to 1e-9 of the
    largest displacement."""
    narrow = _run(_wide_wall(30), monkeypatch)
    full = _run(_wide_wall(30), monkeypatch, floor=1.0)
    assert narrow.summary["search_redos"] == 0
    d_narrow, d_full = narrow.final.displacements, full.final.displacements
    assert np.abs(d_narrow - d_full).max() <= 1e-9 * np.abs(d_full).max()


def test_a_step_beyond_the_reach_is_redone_with_the_full_search(monkeypatch):
    """With a reach far too short (1e-9 of the last motion, floor 0) every step after
    the first outruns it: each is redone after a full search, and the run is the
    full-search run bit for bit, with no energy gained."""
    short = _run(_wide_wall(10), monkeypatch, floor=0.0, growth=1e-9)
    full = _run(_wide_wall(10), monkeypatch, floor=1.0)
    assert short.summary["search_redos"] == 9
    assert short.summary["cut_steps"] == 0
    np.testing.assert_array_equal(short.final.displacements, full.final.displacements)
    h, e0 = short.history, short.summary["initial_energy"]
    assert np.max(h["total_energy"] - h["external_work"] - e0) <= 1e-3 * e0
