"""The equilibrium start's continuation (dda/run/equilibrium_start.py, without its
interior-point solves: the continuation alone, as where those do not settle): where it
starts and where it stops."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.run import equilibrium_start
from tests.standing.incline import incline_scene


def _regularisers(monkeypatch) -> list[float]:
    """The regulariser r of every pseudo-step of the next starts (of the first free
    block, over its E / m), filled in as they run, by the continuation alone."""
    monkeypatch.setattr(equilibrium_start, "INTERIOR_REGULARISERS", ())
    seen: list[float] = []
    solve = equilibrium_start.solve_step

    def recording(model, blocks, contacts, ctx, timer):
        proximal = model.effects[0]
        assert isinstance(proximal, equilibrium_start.Proximal)
        free = int(np.flatnonzero(~blocks.fixed)[0])
        stiffness = model.elastic.material_elasticity[blocks.material[free], 0, 0]
        seen.append(float(proximal.scale[free] * proximal.masses[free, 0, 0] / stiffness))
        return solve(model, blocks, contacts, ctx, timer)

    monkeypatch.setattr(equilibrium_start, "solve_step", recording)
    return seen


def test_a_start_where_every_block_stands_stops_once_a_solve_moves_nothing(monkeypatch):
    """Five blocks stacked on the slope at 0.8 of their friction: the continuation
    starts at 1e-2 E / m and stops before the last regulariser, 1e-8 E / m."""
    seen = _regularisers(monkeypatch)
    result = dda.simulate(incline_scene(0.8, 1e-3, 0.01, stack=5, width=2.0, height=0.5))
    assert result.summary["start"] == "equilibrium"
    assert seen[0] == pytest.approx(equilibrium_start.FIRST_REGULARISER)
    assert seen[-1] > 10.0 * equilibrium_start.RELATIVE_REGULARISER
    assert np.abs(result.final.displacements[1:]).max() < 1e-9


def test_a_block_that_slides_takes_the_continuation_to_the_last_regulariser(monkeypatch):
    """At 1.05 of its friction the block never stops moving by its unbalanced load / r:
    every pseudo-step down to 1e-8 E / m, tenfold each."""
    seen = _regularisers(monkeypatch)
    dda.simulate(incline_scene(1.05, 1e-3, 0.01))
    assert seen[-1] == pytest.approx(equilibrium_start.RELATIVE_REGULARISER)
    assert np.allclose(np.diff(np.log10(seen)), -1.0)


def test_the_start_does_not_depend_on_the_time_step(monkeypatch):
    """The regulariser is the blocks' own (E / m), not the run's 2 / Δt²: the same
    pseudo-steps and the same contact forces at t = 0 at Δt = 1e-3 and 1e-4."""
    seen = _regularisers(monkeypatch)
    coarse = dda.simulate(incline_scene(0.8, 1e-3, 1e-3))
    steps = len(seen)
    fine = dda.simulate(incline_scene(0.8, 1e-4, 1e-4))
    assert seen[steps:] == seen[:steps]
    first = coarse.frames[0].contacts, fine.frames[0].contacts
    np.testing.assert_array_equal(first[0].normal_force, first[1].normal_force)
    np.testing.assert_array_equal(first[0].shear_force, first[1].shear_force)


def _failing(monkeypatch, calls: set[int]) -> list[float]:
    """As :func:`_regularisers`, the pseudo-steps whose number (from 0) is in ``calls``
    reported as not settled."""
    seen = _regularisers(monkeypatch)
    solve = equilibrium_start.solve_step

    def failing(model, blocks, contacts, ctx, timer):
        solution = solve(model, blocks, contacts, ctx, timer)
        if len(seen) - 1 in calls:
            solution.converged = False
        return solution

    monkeypatch.setattr(equilibrium_start, "solve_step", failing)
    return seen


def test_a_pseudo_step_that_does_not_settle_is_tried_again_at_a_larger_regulariser(
    monkeypatch,
):
    """The first, tenfold; a later one, halfway back (geometrically) to the last that
    settled; the start goes on from there."""
    seen = _failing(monkeypatch, {0, 3})
    result = dda.simulate(incline_scene(1.05, 1e-3, 1e-3))
    assert result.summary["start"] == "equilibrium"
    first = equilibrium_start.FIRST_REGULARISER
    assert seen[:4] == pytest.approx([first, 10 * first, first, first / 10])
    assert seen[4] == pytest.approx(first / 10**0.5)
    assert seen[5] == pytest.approx(first / 10**1.5)


def test_a_start_that_never_settles_starts_unloaded_and_says_so(monkeypatch):
    """After ``RETRIES`` tries in a row: the run goes on from the unloaded start, and its
    summary says why."""
    from dda.run.simulation import UNSETTLED_START

    _failing(monkeypatch, set(range(equilibrium_start.RETRIES + 1)))
    seen = []
    result = dda.simulate(incline_scene(0.5, 1e-3, 1e-3), progress=lambda f, i: seen.append(i))
    assert result.summary["status"] == "finished"
    assert result.summary["start"] == UNSETTLED_START
    # what it spent, among the warnings (not only in the log), and shown as it goes
    spent = result.summary["start_newton_iterations"]
    assert spent > 0 and result.summary["start_method"] is not None
    said = [w for w in result.summary["warnings"] if "equilibrium start did not settle" in w]
    assert len(said) == 1 and f"({spent} Newton iterations" in said[0]
    shown = [i["equilibrium_start"] for i in seen if "equilibrium_start" in i]
    assert shown[-2] == f"{spent} Newton iterations" and shown[-1] is None
