"""Chord steps (dda.newton.minimise): after a Newton iteration, directions −K_f⁻¹∇Π with
the factorisation just made. On a wall whose side joints carry next to no force they
save factorisations, and the run ends where Newton alone ends it."""

from __future__ import annotations

import numpy as np

import dda
import dda.step
from dda.bench.scenes import wall_scene


def test_chord_steps_save_factorisations_and_change_no_answer(monkeypatch):
    """10 x 10 wall, 30 steps (measured: 149 factorisations against 190; the final
    displacements, up to 2.4 mm, agree to 1.7e-7 m). Bound: ≥ 15 % fewer, and agreement
    within 1e-6 m, i.e. within what the Newton tolerance (‖∇Π‖ ≤ 1e-4 of the forces) leaves
    in 30 steps."""
    scene = dda.load_scene(wall_scene(10, steps=30))
    chords = dda.simulate(scene)
    monkeypatch.setattr(dda.step._PieceSystem, "chord", lambda self, residual: None)
    newton = dda.simulate(scene)
    assert chords.summary["cut_steps"] == newton.summary["cut_steps"] == 0
    assert chords.summary["factorisations"] <= 0.85 * newton.summary["factorisations"]
    np.testing.assert_allclose(
        chords.final.displacements, newton.final.displacements, rtol=0, atol=1e-6
    )
