"""The contact refresh in one compiled call gives the stages' contacts to the bit.

:func:`dda.contact.pipeline.refresh_contacts` makes, after its broad phase, one call
(:func:`dda.contact.pipeline._refresh`: narrow phase, tests, merge) where the kernels
are used; with it off (``None``) the stages run one by one (their own compiled
kernels, the shapely test and the merge between them). Both must give the same
contacts, field by field, and the same runs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.contact import pipeline
from dda.contact.contact_set import ContactSet
from dda.model import build

needs_numba = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")


def _same_contacts(a: ContactSet, b: ContactSet) -> None:
    for field in dataclasses.fields(ContactSet):
        left, right = getattr(a, field.name), getattr(b, field.name)
        assert left.dtype == right.dtype, field.name
        np.testing.assert_array_equal(left, right, err_msg=field.name, strict=True)


def _both(monkeypatch, blocks, previous, settings, gap=None):
    """(one call, the stages) of the same refresh."""
    fused = pipeline.refresh_contacts(blocks, previous, settings, None, gap)
    with monkeypatch.context() as patched:
        patched.setattr(pipeline, "_refresh_kernel", None)
        staged = pipeline.refresh_contacts(blocks, previous, settings, None, gap)
    return fused, staged


@needs_numba
@pytest.mark.parametrize("case", ["wall", "cases/rock_slope.toml", "cases/tunnel.toml"])
def test_one_call_finds_the_stages_contacts_from_nothing_and_carries_the_last_steps(
    monkeypatch, case
):
    """The first search of a model (nothing carried), then one from a last step's set
    with forces, states and multipliers (every carried field), with a narrowed gap."""
    scene = dda.load_scene(wall_scene(6) if case == "wall" else case)
    model = build(scene)
    fused, staged = _both(monkeypatch, model.blocks, ContactSet.empty(), model.contact)
    assert len(fused) > 10
    _same_contacts(fused, staged)
    rng = np.random.default_rng(7)
    last = fused.copy()
    m = len(last)
    last.state = rng.integers(0, 3, m).astype(np.int8)
    for name in ("normal_multiplier", "shear_multiplier", "normal_force", "shear_force"):
        setattr(last, name, rng.normal(size=m))
    last.penalty = rng.uniform(1e9, 1e10, m)
    last.intact = rng.random(m) < 0.5
    keep = rng.random(m) < 0.7  # some contacts of the last step are gone, the rest new
    last = last.subset(np.flatnonzero(keep))
    blocks = model.blocks.copy()
    blocks.vertices = blocks.vertices + rng.normal(size=blocks.vertices.shape) * 1e-5
    gap = 0.5 * model.contact.search_distance
    fused, staged = _both(monkeypatch, blocks, last, model.contact, gap)
    assert np.count_nonzero(~fused.fresh) > 0 and np.count_nonzero(fused.fresh) > 0
    _same_contacts(fused, staged)


@needs_numba
def test_a_pairing_that_asks_for_the_shapely_test_goes_on_in_python(monkeypatch):
    """With a touch tolerance below zero every new pairing that penetrates asks for
    the shapely test (:func:`dda.contact.pipeline._blocks_touch`): the one call stops
    after its tests and the stages' shapely test and merge finish, as without it."""
    model = build(dda.load_scene(wall_scene(4)))
    settings = dataclasses.replace(model.contact, touch_tolerance=-1.0)
    calls = []
    touch = pipeline._blocks_touch
    monkeypatch.setattr(pipeline, "_blocks_touch", lambda *args: calls.append(1) or touch(*args))
    fused, staged = _both(monkeypatch, model.blocks, ContactSet.empty(), settings)
    assert len(calls) == 2  # once after the one call, once in the stages
    _same_contacts(fused, staged)


@needs_numba
def test_runs_with_and_without_the_one_call_are_the_same(monkeypatch):
    """120 steps of a 5 x 5 wall and of the rock slope: the same vertices and contacts."""
    for scene in (wall_scene(5, steps=120), "cases/rock_slope.toml"):
        results = []
        for fused in (True, False):
            with monkeypatch.context() as patched:
                if not fused:
                    patched.setattr(pipeline, "_refresh_kernel", None)
                loaded = dda.load_scene(scene)
                loaded = dataclasses.replace(
                    loaded, analysis=dataclasses.replace(loaded.analysis, steps=120)
                )
                with jit.run_work(1000, 10_000):
                    results.append(dda.simulate(loaded))
        fused_run, staged_run = results
        got = np.concatenate(fused_run.final.vertices)
        want = np.concatenate(staged_run.final.vertices)
        np.testing.assert_array_equal(got, want, strict=True)
        np.testing.assert_array_equal(
            fused_run.history["max_penetration"], staged_run.history["max_penetration"], strict=True
        )
        assert fused_run.summary["iterations"] == staged_run.summary["iterations"]
