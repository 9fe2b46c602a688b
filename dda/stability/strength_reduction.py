"""The scene with its strengths divided by a factor F (strength reduction).

Every Coulomb joint's friction, cohesion and tensile strength are reduced, the peak
and the residual ones alike,

    tan φ_F = tan φ / F,   c_F = c / F,   T_F = T / F,

a Barton–Bandis joint's shear strength τ(σn) (with its bond's cohesion) is divided by
F (:attr:`dda.scene.joints.Joint.strength_divisor`) and its tensile strength too, and,
when ``intact`` is asked, the friction, cohesion and tensile strength of every
breakable material (the Mohr–Coulomb strength of the intact rock). The scene is changed
through its public types (a new, frozen :class:`dda.Scene`); nothing else differs.
"""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType

from dda.scene import Joint, Scene


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


def _reduced_joint(joint: Joint, factor: float) -> Joint:
    """A joint with its peak and residual strengths divided by ``factor``."""
    if joint.barton_bandis:
        return dataclasses.replace(
            joint,
            strength_divisor=joint.strength_divisor * factor,
            tensile_strength=joint.tensile_strength / factor,
        )
    residual = joint.residual_friction_angle
    return dataclasses.replace(
        _reduced(joint, factor),
        residual_friction_angle=None if residual is None else reduced_angle(residual, factor),
        residual_cohesion=joint.residual_cohesion / factor,
        residual_tensile_strength=joint.residual_tensile_strength / factor,
    )


def reduce_strengths(scene: Scene, factor: float, intact: bool = False) -> Scene:
    """``scene`` with its joint strengths (and with ``intact`` its breakable materials'
    strengths) divided by ``factor``."""
    joints = {name: _reduced_joint(j, factor) for name, j in scene.joints.items()}
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
    if any(j.barton_bandis for j in items):
        return True
    if intact:
        items += [m for m in scene.materials.values() if m.breakable]
    return any(i.friction_angle > 0 or i.cohesion > 0 or i.tensile_strength > 0 for i in items)


def brittle_note(scene: Scene) -> str | None:
    """A note naming the Coulomb joints that lose strength when they slip: cohesion above
    ``residual_cohesion`` (the default 0), or a residual friction angle below the peak.
    Strength reduction then weakens them contact by contact, the least loaded first, and
    the factor it finds can fall below limit equilibrium's (a block on a 35° plane,
    c = 3 kPa: 0.965 against 1.061; φ = 40°, φ_r = 30° on a 30° plane: 1.360 against
    1.453, its uphill corner at φ_r already at F = 1) and with the penalty, which sets how
    the contacts share the load (docs/stability.md); a ductile joint (residual equal to
    peak) meets it. None when no joint loses strength."""
    lost = {}
    for joint in scene.joints.values():
        if joint.barton_bandis:
            continue
        what = []
        if joint.cohesion > joint.residual_cohesion:
            what.append("cohesion")
        if joint.residual_angle < joint.friction_angle:
            what.append("friction")
        if what:
            lost[joint.name] = " and ".join(what)
    if not lost:
        return None
    names = ", ".join(f"{name!r} ({what})" for name, what in lost.items())
    return (
        f"note: joint(s) {names} lose strength when they slip (residual below peak): "
        "they weaken one contact at a time, the least loaded first, so F can fall below "
        "limit equilibrium's and follows how the contacts share the load, which the "
        "contact penalty sets (a block on a 30° plane, c = 8,868 Pa: 1.29 at 10 E, 1.17 at "
        "200 E, against 1.30); set the residual equal to the peak for a ductile joint"
    )
