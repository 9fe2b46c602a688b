"""The compiled block update gives numpy's numbers to the bit.

:func:`dda.solve.update.apply_step` and :func:`vertex_displacements` have compiled twins
(one call each); with them off (``None``) the numpy code runs. Both are applied here to
the same blocks and steps: every field of the blocks must come out equal.
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.model import build
from dda.solve import update

needs_numba = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")

FIELDS = (
    "stress", "vertices", "area", "centroid", "ixx", "iyy", "ixy", "displacement",
    "rotation", "velocity", "acceleration",
)  # fmt: skip


def _model_and_step(seed: int, unknown_acceleration: bool):
    """A 4 x 3 wall with stress, velocities and a random step D (rotations up to 0.3)."""
    model = build(dda.load_scene(wall_scene(4, 3)))
    blocks = model.blocks.copy()
    rng = np.random.default_rng(seed)
    n = blocks.count
    blocks.stress = rng.normal(size=(n, 3)) * 1e6
    blocks.velocity = rng.normal(size=(n, 6)) * 0.1
    blocks.acceleration = rng.normal(size=(n, 6))
    if unknown_acceleration:
        blocks.acceleration[::2] = np.nan
    d = rng.normal(size=(n, 6)) * np.array([1e-3, 1e-3, 0.1, 1e-4, 1e-4, 1e-4])
    d[0, 2] = 0.3
    return model, blocks, d, rng


def _updated(monkeypatch, compiled: bool, seed: int, **options):
    model, blocks, d, rng = _model_and_step(seed, options.pop("unknown_acceleration"))
    pushed = rng.normal(size=d.shape) * 1e-5 if options.pop("pushed") else None
    with monkeypatch.context() as patch:
        if not compiled:
            patch.setattr(update, "apply_kernel", None)
            patch.setattr(update, "moves_kernel", None)
        moves = update.vertex_displacements(blocks, d, options["exact_rotation"])
        update.apply_step(blocks, d, 1e-3, model.elastic, pushed=pushed, moves=moves, **options)
    return moves, blocks


@needs_numba
@pytest.mark.parametrize("static", [False, True])
@pytest.mark.parametrize("exact_rotation", [True, False])
@pytest.mark.parametrize("pushed", [False, True])
@pytest.mark.parametrize("gamma", [1.0, 0.9])
def test_the_compiled_update_equals_numpy_to_the_bit(
    monkeypatch, static, exact_rotation, pushed, gamma
):
    for seed in range(3):
        options = dict(
            static=static, exact_rotation=exact_rotation, gamma=gamma, pushed=pushed,
            unknown_acceleration=seed == 1,
        )  # fmt: skip
        moves_numpy, numpy_blocks = _updated(monkeypatch, False, seed, **dict(options))
        moves_compiled, compiled_blocks = _updated(monkeypatch, True, seed, **dict(options))
        assert np.array_equal(moves_numpy, moves_compiled)
        for name in FIELDS:
            a, b = getattr(numpy_blocks, name), getattr(compiled_blocks, name)
            assert np.array_equal(a, b, equal_nan=True), name


@needs_numba
def test_the_compiled_update_leaves_fixed_blocks_still_and_moves_the_rest(monkeypatch):
    """Independent of numpy: a fixed block keeps zero velocity and acceleration, a free
    block's acceleration is 2 (D − v₀Δt)/Δt² (Shi's constant acceleration)."""
    model, blocks, d, _ = _model_and_step(5, False)
    v0 = blocks.velocity.copy()
    update.apply_step(blocks, d, 1e-3, model.elastic, False, True)
    fixed = blocks.fixed
    assert fixed.any() and (~fixed).any()
    assert np.all(blocks.velocity[fixed] == 0.0) and np.all(blocks.acceleration[fixed] == 0.0)
    expected = 2.0 * (d[~fixed] - v0[~fixed] * 1e-3) / 1e-6
    assert np.allclose(blocks.acceleration[~fixed], expected, rtol=1e-12)
