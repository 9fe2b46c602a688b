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


def estimated_output_bytes(scene: Any) -> int:
    """Bytes the frames and history of a run take on disk (a rough, measured estimate)."""
    blocks = len(scene.blocks)
    vertices = sum(len(b.vertices) for b in scene.blocks)
    per_frame = (
        FRAME_BYTES_PER_BLOCK * blocks + FRAME_BYTES_PER_VERTEX * vertices + FRAME_BYTES_FIXED
    )
    return estimated_frames(scene) * per_frame
