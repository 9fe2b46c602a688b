"""What every closed form of kind ``motion`` shares: its block and what it returns.

A reference follows the scene's one free block (:func:`free_block`), knows its mass
ρ A (:func:`block_mass`) and gives the block's centroid displacement and rotation at
the times asked for (:class:`Motion`). The other references of this folder (motion.py,
water.py, impact.py, shaking.py, bolt.py, collisions.py, al_rate.py) import them from
here, so that no reference imports another back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda import Scene
from verify.comparison.expect import ExpectationError


@dataclass(frozen=True)
class Motion:
    """The reference of one block at given times."""

    u: np.ndarray  # (t, 2) centroid displacement
    r: np.ndarray  # (t,) rotation
    valid: np.ndarray  # (t,) bool: the reference holds at that time
    events: dict  # named times (impact), for the report
    # the energy rows' scale (rows ``energy``: E − E0 − W at every step); None: no rows
    energy_scale: float | None = None


def free_block(scene: Scene) -> int:
    """The index of the scene's one free block (motion references follow one block)."""
    free = [i for i, b in enumerate(scene.blocks) if not b.fixed]
    if len(free) != 1:
        raise ExpectationError(f"{scene.source}: a motion case needs exactly one free block")
    return free[0]


def block_mass(scene: Scene, block: int) -> float:
    """ρ A of a scene block."""
    b = scene.blocks[block]
    area = abs(float(_shoelace(np.asarray(b.vertices, dtype=float))))
    return scene.materials[b.material].density * area


def _shoelace(v: np.ndarray) -> float:
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
