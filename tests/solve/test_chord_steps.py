"""Chord steps (dda.solve.newton.minimise): after a Newton iteration, directions −K_f⁻¹∇Π with
the factorisation just made. On a wall whose side joints carry next to no force they
save factorisations, and the run ends where Newton alone ends it."""

from __future__ import annotations

import numpy as np

import dda
import dda.solve.step
from dda.bench.scenes import wall_scene
from tests.helpers import use_policy


def test_chord_steps_save_factorisations_and_change_no_answer(monkeypatch):
    """10 x 10 wall, 30 steps (measured: 149 factorisations against 190; the final
    displacements, up to 2.4 mm, agree to 1.7e-7 m). Bound: ≥ 15 % fewer, and agreement
    within 1e-6 m, i.e. within what the Newton tolerance (‖∇Π‖ ≤ 1e-4 of the forces) leaves
    in 30 steps."""
    scene = dda.load_scene(wall_scene(10, steps=30))
    chords = dda.simulate(scene)
    monkeypatch.setattr(dda.solve.step._PieceSystem, "chord", lambda self, residual: None)
    newton = dda.simulate(scene)
    assert chords.summary["cut_steps"] == newton.summary["cut_steps"] == 0
    assert chords.summary["factorisations"] <= 0.85 * newton.summary["factorisations"]
    np.testing.assert_allclose(
        chords.final.displacements, newton.final.displacements, rtol=0, atol=1e-6
    )


def test_passes_that_start_with_a_chord_step_still_end(monkeypatch):
    """In large systems a pass on new friction bounds starts with a chord step; chord steps
    do not count against ``max_iterations``, so once a step's chord steps reach that
    budget every pass starts with a Newton iteration again, and a step that never
    settles still ends (and is cut). A stand-in for the minimiser that never converges:
    a chord step when asked to start with one, else one Newton iteration."""
    import dda.solve.newton

    use_policy(monkeypatch, large_rows=0)  # every system counts as large
    passes = []

    def never_settles(*args, **kwargs):
        passes.append(kwargs["chord_first"])
        assert len(passes) < 10_000, "the step does not end"
        first = kwargs["chord_first"]
        geometry, start = args[1], args[5]
        gaps = geometry.at(start)
        return dda.solve.newton.NewtonResult(
            start, int(not first), False, int(first) + 2, True, gaps
        )

    monkeypatch.setattr(dda.solve.step, "minimise", never_settles)
    raw = wall_scene(2, steps=1)
    raw["contact"]["max_iterations"] = 5
    with np.testing.assert_raises(dda.SimulationError):
        dda.simulate(dda.load_scene(raw))
    assert any(passes) and not all(passes)


def test_in_large_systems_a_pass_after_a_converged_one_starts_with_a_chord_step(monkeypatch):
    """The law's update (new friction bounds, multipliers) after a converged pass moves few
    contacts to another piece: the next pass starts from there with a chord step on the
    kept factorisation. Small systems start it with a Newton iteration."""
    import dda.solve.newton

    def passes_after_converged(large: bool) -> list[bool]:
        if large:
            use_policy(monkeypatch, large_rows=0)  # every system counts as large
        after, minimise, last = [], dda.solve.step.minimise, {"converged": False}

        def recording(*args, **kwargs):
            first_pass = args[7] is not None  # the step's first pass gets remembered pieces
            if not first_pass and last["converged"]:
                after.append(kwargs["chord_first"])
            result = minimise(*args, **kwargs)
            last["converged"] = result.converged
            return result

        monkeypatch.setattr(dda.solve.step, "minimise", recording)
        dda.simulate(dda.load_scene(wall_scene(6, steps=30)))
        monkeypatch.undo()
        return after

    large, small = passes_after_converged(True), passes_after_converged(False)
    assert len(large) > 5 and all(large)
    assert len(small) > 5 and not any(small)
