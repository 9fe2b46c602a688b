"""Accuracy presets: defaults only where the scene gives nothing."""

from __future__ import annotations

import pytest

import dda
from dda.model import build
from dda.scene.presets import PRESETS, apply_preset
from tests.helpers import ROCK, slope_scene

SLAB_EXTENT = 10 * 0.8660254037844 + 0.5  # slope_scene's slab, 10 m rotated by 30°


def scene_with(accuracy, contact=None, **analysis):
    raw = slope_scene(20.0)
    raw["contact"] = dict(contact or {})
    raw["analysis"].update(analysis)
    if accuracy is not None:
        raw["analysis"]["accuracy"] = accuracy
    return dda.load_scene(raw)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_fills_in_the_defaults(name):
    preset = PRESETS[name]
    model = build(scene_with(name))
    assert model.contact.law.augmented == (preset.method == "augmented-lagrangian")
    assert model.contact.initial_penalty == pytest.approx(preset.penalty_factor * ROCK["young"])
    assert model.scene.analysis.max_displacement_ratio == preset.max_displacement_ratio
    if preset.tolerance_fraction is not None:
        expected = preset.tolerance_fraction * SLAB_EXTENT
        assert model.contact.law.tolerance == pytest.approx(expected, rel=1e-6)


def test_explicit_scene_values_win_over_the_preset():
    contact = {"method": "augmented-lagrangian", "penalty": 1e9, "tolerance": 1e-3}
    scene = scene_with("fast", contact, max_displacement_ratio=0.05, time_step=0.02)
    out = apply_preset(scene)
    assert out.contact.penalty == 1e9 and out.contact.tolerance == 1e-3
    assert out.analysis.max_displacement_ratio == 0.05
    assert out.analysis.time_step == 0.02  # a preset never sets the time step


def test_no_preset_leaves_the_scene_alone():
    scene = scene_with(None)
    assert apply_preset(scene) is scene


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_slides_the_block_as_the_closed_form(name):
    result = dda.simulate(scene_with(name))
    moved = float((result.final.displacements[1] ** 2).sum() ** 0.5)
    assert moved == pytest.approx(0.906407, rel=0.01)
