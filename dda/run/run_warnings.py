"""What a finished run should tell its user although nothing failed: contacts that
sank deep into each other, a time step cut at most steps, a static analysis whose
blocks still move. Each is one sentence in ``summary["warnings"]`` and a warning in the
log, said once at the end of the run."""

from __future__ import annotations

import numpy as np

# the largest penetration, over the size (√area) of the smallest free block, beyond
# which the contacts no longer model touching blocks (the shipped cases: ≤ 2.9e-4; the
# paper's pure penalty case, Fig. 2a, 0.11: the penetration the augmented Lagrangian
# removes)
PENETRATION_WARNING = 0.01
# the share of the steps cut (Δt shortened after a failed attempt) beyond which the
# time step is too large for the model
CUT_STEPS_WARNING = 0.5
# a static analysis's last step moving a vertex by more than this fraction of the
# allowed displacement per step: the blocks have not come to rest (a settled model's
# last step moves them by 0; a block without support by its free fall in one step)
STATIC_MOTION_WARNING = 1e-3


def penetration_warning(
    max_penetration: float, areas: np.ndarray, fixed: np.ndarray, length: str
) -> str | None:
    """The sentence when the largest penetration exceeds :data:`PENETRATION_WARNING` of
    the smallest free block's size, else None."""
    free = ~np.asarray(fixed, bool)
    if not free.any() or max_penetration <= 0.0:
        return None
    size = float(np.sqrt(np.asarray(areas)[free]).min())
    if max_penetration <= PENETRATION_WARNING * size:
        return None
    return (
        f"contacts penetrated by up to {max_penetration:.3g} {length}, "
        f"{100.0 * max_penetration / size:.3g} % of the smallest free block's size "
        f"({size:.3g} {length}): raise [contact] penalty, or use the "
        '"augmented-lagrangian" method'
    )


def cut_steps_warning(
    cut_steps: int, steps: int, smallest_dt: float, time_step: float
) -> str | None:
    """The sentence when more than :data:`CUT_STEPS_WARNING` of the steps were cut."""
    if steps <= 0 or cut_steps <= CUT_STEPS_WARNING * steps:
        return None
    return (
        f"the time step was cut at {cut_steps} of {steps} steps (to {smallest_dt:.3g} s at "
        f"the smallest, from analysis.time_step = {time_step:.3g} s): blocks move further "
        "in one step than the analysis allows; a smaller time_step takes fewer attempts"
    )


def static_motion_warning(moved: float, allowed: float, block: str, length: str) -> str | None:
    """The sentence when a static analysis's last step still moved a vertex by more than
    :data:`STATIC_MOTION_WARNING` of the allowed displacement per step."""
    if moved <= STATIC_MOTION_WARNING * allowed:
        return None
    return (
        f"the static analysis ended with blocks still moving: block {block!r} moved "
        f"{moved:.3g} {length} in the last step. A block without support has no "
        "equilibrium; else the analysis needs more steps"
    )
