"""How big a run will be, checked before it starts: steps, frames, bytes on disk.

A scene asks for its duration in simulated time; at the largest time step
that is at least ``duration / time_step`` steps (cut steps add more). A run
whose estimate exceeds ``analysis.max_steps`` (default
``DEFAULT_MAX_STEPS``) is refused before anything is built or written: a
mistyped duration (1e9 s at Δt = 1e-3 s is 1e12 steps) would otherwise
write files until the disk is full. The limit is also a hard stop during the
run.
"""

from __future__ import annotations

import math
from typing import Any

from dda.errors import SceneError

DEFAULT_MAX_STEPS = 10_000_000
# bytes one kept frame costs on disk (two zlib VTU files, the history rows): 0.5 kB per
# block, 60 B per vertex and a file system block (4 kB) per file. On disk the frames of
# cases/ take 9.5 kB (stack: 6 blocks, 24 vertices), 60 kB (rock slope: 81, 328) and
# 195 kB (tunnel: 265, 1122); this gives 12.6, 68 and 208 kB
FRAME_BYTES_PER_BLOCK = 500
FRAME_BYTES_PER_VERTEX = 60
FRAME_BYTES_FIXED = 2 * 4096
# bytes of one checkpoint (dda.run.checkpoint, an uncompressed .npz): 32 kB of names and
# meta data, 1.2 kB a block, 1.8 kB a vertex (the contacts, about one a vertex, and the
# solver's cache of them) and 100 B a step done (the per-step history, 88 B measured).
# Measured: the rock slope (81 blocks, 328 vertices) 670 kB at step 54, estimated 724; the
# tunnel (265, 1122; its solver kept no cache) 267 kB, estimated 2.4 MB; the stack (6, 24)
# 288 kB at step 2999, estimated 382
CHECKPOINT_BYTES_FIXED = 32_000
CHECKPOINT_BYTES_PER_BLOCK = 1_200
CHECKPOINT_BYTES_PER_VERTEX = 1_800
CHECKPOINT_BYTES_PER_STEP = 100


def estimated_steps(scene: Any) -> int:
    """Steps the scene needs at least: ``steps``, or ``ceil(duration / time_step)``."""
    a = scene.analysis
    if a.steps is not None:
        return int(a.steps)
    return math.ceil(a.duration / a.time_step * (1.0 - 1e-12))


def check_run_size(scene: Any) -> None:
    """Refuse a scene whose step estimate exceeds ``analysis.max_steps``.

    Raises
    ------
    SceneError
        Naming ``analysis.duration`` (or ``analysis.steps``) and the estimate.
    """
    a = scene.analysis
    steps = estimated_steps(scene)
    if steps <= a.max_steps:
        return
    if a.steps is not None:
        key, what = "analysis.steps", f"{steps} steps are"
    else:
        key = "analysis.duration"
        what = f"{a.duration:g} s at time_step {a.time_step:g} s is at least {steps:.3g} steps,"
    raise SceneError(
        scene.source,
        key,
        f"{what} more than analysis.max_steps = {a.max_steps}; raise analysis.max_steps "
        "(the scene's key, or dda run --max-steps) to run it",
    )


def estimated_frames(scene: Any) -> int:
    """Frames a run keeps: every ``save_every``-th step, the first and the last."""
    return estimated_steps(scene) // scene.analysis.save_every + 2


def estimated_frame_bytes(scene: Any) -> int:
    """Bytes one kept frame (its files and history rows) takes on disk (a rough, measured
    estimate)."""
    blocks, vertices = _size(scene)
    return FRAME_BYTES_PER_BLOCK * blocks + FRAME_BYTES_PER_VERTEX * vertices + FRAME_BYTES_FIXED


def estimated_output_bytes(scene: Any) -> int:
    """Bytes the frames and history of a run take on disk (a rough, measured estimate)."""
    return estimated_frames(scene) * estimated_frame_bytes(scene)


def estimated_checkpoint_bytes(scene: Any, steps: int | None = None) -> int:
    """Bytes of one checkpoint after ``steps`` steps (default: the run's last), an upper
    estimate: a run keeps one checkpoint, replaced by the next (both are on disk while the
    next is written), and it grows with the steps done."""
    blocks, vertices = _size(scene)
    steps = estimated_steps(scene) if steps is None else steps
    return (
        CHECKPOINT_BYTES_FIXED
        + CHECKPOINT_BYTES_PER_BLOCK * blocks
        + CHECKPOINT_BYTES_PER_VERTEX * vertices
        + CHECKPOINT_BYTES_PER_STEP * steps
    )


def _size(scene: Any) -> tuple[int, int]:
    """The scene's blocks and vertices."""
    return len(scene.blocks), sum(len(b.vertices) for b in scene.blocks)
