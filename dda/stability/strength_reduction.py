"""The scene with its strengths divided by a factor F (strength reduction).

Every joint's friction, cohesion and tensile strength are reduced,

    tan φ_F = tan φ / F,   c_F = c / F,   T_F = T / F,

and, when ``intact`` is asked, the same three of every breakable material (the
Mohr–Coulomb strength of the intact rock). The scene is changed through its public
types (a new, frozen :class:`dda.Scene`); nothing else differs.
"""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType

from dda.scene import Scene


def reduced_angle(angle: float, factor: float) -> float:
    """atan(tan φ / F) in degrees, for φ in degrees."""
    return math.degrees(math.atan(math.tan(math.radians(angle)) / factor))


def _reduced(item, factor: float):
    return dataclasses.replace(
        item,
        friction_angle=reduced_angle(item.friction_angle, factor),
        cohesion=item.cohesion / factor,
        tensile_strength=item.tensile_strength / factor,
    )


def reduce_strengths(scene: Scene, factor: float, intact: bool = False) -> Scene:
    """``scene`` with its joint strengths (and with ``intact`` its breakable materials'
    strengths) divided by ``factor``."""
    joints = {name: _reduced(j, factor) for name, j in scene.joints.items()}
    materials = dict(scene.materials)
    if intact:
        materials = {n: _reduced(m, factor) if m.breakable else m for n, m in materials.items()}
    return dataclasses.replace(
        scene, joints=MappingProxyType(joints), materials=MappingProxyType(materials)
    )


def reducible(scene: Scene, intact: bool = False) -> bool:
    """True when some strength would change: a joint (or, with ``intact``, a breakable
    material) with friction, cohesion or tensile strength."""
    items = list(scene.joints.values())
    if intact:
        items += [m for m in scene.materials.values() if m.breakable]
    return any(i.friction_angle > 0 or i.cohesion > 0 or i.tensile_strength > 0 for i in items)
