"""The standard benchmark scene: a wall of unit blocks on a fixed base.

A fixed base block [0, n+4] x [0, 1] carries an n x m grid of 1 x 1 blocks
from x = 2, y = 1 upwards; neighbouring blocks share their edges exactly.
Rock: density 2.6, E = 1e6, ν = 0.25; joints: 30° friction; g = 9.81;
penalty 5e7; Δt = 1e-3 s, dynamic. With ``start="unloaded"`` (Shi's start, no material
damping) the same scene as the C DDA timings quoted in docs/benchmarks.md; with
``start="equilibrium"`` what a user's run of it does (the engine's defaults).
"""

from __future__ import annotations

from typing import Any

METHODS = ("penalty", "augmented-lagrangian")
STARTS = ("equilibrium", "unloaded")  # the engine's default; Shi's, as the C code's


def wall_scene(
    columns: int,
    rows: int | None = None,
    method: str = "penalty",
    steps: int = 100,
    save_every: int | None = None,
    start: str = "unloaded",
) -> dict[str, Any]:
    """Scene dict (for :func:`dda.load_scene`) of a ``columns`` x ``rows`` wall.

    Parameters
    ----------
    columns, rows : blocks across and up (``rows`` defaults to ``columns``)
    method : "penalty" or "augmented-lagrangian"
    steps : time steps to run
    save_every : frames kept every this many steps (default: only the first and last)
    start : "unloaded": Shi's start, as the C code's (every contact spring unloaded at
        t = 0, no material damping: the wall rings); "equilibrium": the engine's default
        start and material damping (dda.run.equilibrium_start, dda.effects.damping),
        what a user's run of the wall does

    Returns
    -------
    dict
        The scene in the scene-file layout; ``columns * rows + 1`` blocks.
    """
    rows = columns if rows is None else rows
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, not {method!r}")
    blocks = [
        {
            "name": "base",
            "material": "rock",
            "fixed": True,
            "vertices": _square(0.0, 0.0, columns + 4.0, 1.0),
        }
    ]
    for j in range(rows):
        for i in range(columns):
            x, y = 2.0 + i, 1.0 + j
            blocks.append(
                {"name": f"b{i}_{j}", "material": "rock", "vertices": _square(x, y, x + 1, y + 1)}
            )
    if start not in STARTS:
        raise ValueError(f"start must be one of {STARTS}, not {start!r}")
    rock = {"density": 2.6, "young": 1e6, "poisson": 0.25}
    analysis = {
        "mode": "dynamic",
        "time_step": 1e-3,
        "steps": int(steps),
        "gravity": [0.0, -9.81],
        "save_every": int(save_every or steps),
    }
    if start == "unloaded":
        analysis["start"] = "unloaded"
        rock["damping"] = 0.0
    return {
        "title": f"wall {columns}x{rows} ({method})",
        "analysis": analysis,
        "contact": {"method": method, "penalty": 5e7},
        "materials": {"rock": rock},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": blocks,
    }


def _square(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    """Counter-clockwise rectangle [x0, x1] x [y0, y1]."""
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
