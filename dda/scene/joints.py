"""``[joints.NAME]``: the strength of the joints, peak and residual, Coulomb or Barton–Bandis.

A joint is *intact* (bonded) until it first slips or opens; from then on it has its
residual strength for good (docs/contact.md, "Joints"):

* ``model = "coulomb"`` (default): peak τ = c + σn tan φ and tension T while intact;
  residual τ = c_r + σn tan φ_r and tension T_r after. The defaults (c_r = 0, T_r = 0,
  φ_r = φ) are the brittle joint; residual equal to peak makes it ductile.
* ``model = "barton-bandis"``: τ = σn tan(φ_r + JRC log10(JCS / σn)) (the mobilised
  angle bounded as docs/contact.md says), plus the bond (c, T) while intact.

``restitution`` (e in [0, 1]) gives an impact on the joint a normal rebound of e times
its speed (a dashpot beside the contact's spring); without it the contact has none.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from dda.scene.checks import (
    ANGLE,
    NON_NEGATIVE,
    POSITIVE,
    Checker,
    Interval,
    Spec,
    checked_fields,
    choice,
    join_key,
    real,
)

log = logging.getLogger(__name__)

MODELS = ("coulomb", "barton-bandis")
JRC = Interval(0.0, 20.0, low_closed=True, high_closed=True)  # Barton's roughness profiles
RESTITUTION = Interval(0.0, 1.0, low_closed=True, high_closed=True)
# the largest friction angle the Barton–Bandis law mobilises, degrees (Barton's cap of
# φr + JRC log10(JCS/σn); dda.contact.formulas.barton_bandis_tangent)
MOBILISED_CAP_DEGREES = 70.0


@dataclass(frozen=True)
class Joint:
    """``[joints.NAME]``: a joint's strength (angles in degrees) and restitution."""

    name: str
    friction_angle: float = 0.0
    cohesion: float = 0.0
    tensile_strength: float = 0.0
    model: str = "coulomb"
    residual_friction_angle: float | None = None  # None: friction_angle (Coulomb)
    residual_cohesion: float = 0.0
    residual_tensile_strength: float = 0.0
    jrc: float = 0.0  # Barton–Bandis joint roughness coefficient
    jcs: float = 0.0  # Barton–Bandis joint wall compressive strength (a stress)
    restitution: float | None = None  # None: no contact damping
    # the factor of safety's trial divides a Barton–Bandis joint's shear strength by this
    # (dda.stability.strength_reduction); not a scene key
    strength_divisor: float = 1.0

    @property
    def residual_angle(self) -> float:
        """φ_r: the residual friction angle (the peak one unless given)."""
        return (
            self.friction_angle
            if self.residual_friction_angle is None
            else (self.residual_friction_angle)
        )

    @property
    def barton_bandis(self) -> bool:
        return self.model == "barton-bandis"


_KEYS: dict[str, Spec] = {
    "friction_angle": real(ANGLE),
    "cohesion": real(NON_NEGATIVE),
    "tensile_strength": real(NON_NEGATIVE),
    "model": choice(*MODELS),
    "residual_friction_angle": real(ANGLE),
    "residual_cohesion": real(NON_NEGATIVE),
    "residual_tensile_strength": real(NON_NEGATIVE),
    "jrc": real(JRC),
    "jcs": real(POSITIVE),
    "restitution": real(RESTITUTION),
}
_ONLY_COULOMB = ("friction_angle", "residual_cohesion", "residual_tensile_strength")
_ONLY_BARTON_BANDIS = ("jrc", "jcs")
_BARTON_BANDIS = ("jrc", "jcs", "residual_friction_angle")
_PEAK_OF = {
    "residual_friction_angle": "friction_angle",
    "residual_cohesion": "cohesion",
    "residual_tensile_strength": "tensile_strength",
}


def other_model(key: str, model: str) -> str | None:
    """The joint model that ``key`` belongs to when a joint of ``model`` cannot take it
    (jrc and jcs are Barton–Bandis keys, friction_angle and the residual cohesion and
    tension Coulomb ones), else None."""
    if model == "barton-bandis" and key in _ONLY_COULOMB:
        return "coulomb"
    if model != "barton-bandis" and key in _ONLY_BARTON_BANDIS:
        return "barton-bandis"
    return None


def joint(chk: Checker, name: str, value: object) -> Joint:
    """One ``[joints.NAME]`` table, checked: the keys of its model, residual strengths
    no higher than the peak ones."""
    key = join_key("joints", name)
    values = checked_fields(chk, value, key, _KEYS)
    if values.get("model", "coulomb") == "barton-bandis":
        for needed in _BARTON_BANDIS:
            if needed not in values:
                chk.fail(join_key(key, needed), "is required by model = 'barton-bandis'")
        if values["residual_friction_angle"] >= MOBILISED_CAP_DEGREES:
            chk.fail(join_key(key, "residual_friction_angle"),
                     f"{values['residual_friction_angle']:g} is not below "
                     f"{MOBILISED_CAP_DEGREES:g}°, the largest angle the Barton–Bandis law "
                     "mobilises (φr + JRC log10(JCS/σn) is capped there)")  # fmt: skip
        for other in _ONLY_COULOMB:
            if other in values:
                why = "a barton-bandis joint takes jrc, jcs and residual_friction_angle"
                chk.fail(join_key(key, other), f"is a key of model = 'coulomb'; {why}")
    else:
        for other in _ONLY_BARTON_BANDIS:
            if other in values:
                chk.fail(join_key(key, other), "is a key of model = 'barton-bandis'")
        for residual, peak in _PEAK_OF.items():
            if residual in values and values[residual] > values.get(peak, 0.0):
                chk.fail(join_key(key, residual), f"{values[residual]:g} is above the peak "
                         f"{peak} ({values.get(peak, 0.0):g}): a joint loses strength as it "
                         "slips")  # fmt: skip
        tension = values.get("tensile_strength", 0.0)
        brittle = values.get("residual_tensile_strength", 0.0) < tension
        if tension > 0.0 and brittle and values.get("cohesion", 0.0) == 0.0:
            log.warning(
                "%s: %s: a joint without cohesion has no shear strength in tension, so the "
                "least shear there slips it and breaks its bond, its tension with it "
                "(give it a cohesion, or residual_tensile_strength to keep the tension)",
                chk.source, join_key(key, "tensile_strength"),
            )  # fmt: skip
    return Joint(name=name, **values)


def parse_joints(chk: Checker, raw: Mapping[str, Any]) -> Mapping[str, Joint]:
    """Declared joints plus a frictionless ``default`` unless one is declared."""
    table = chk.named_tables(raw.get("joints", {}), "joints")
    joints = {name: joint(chk, name, value) for name, value in table.items()}
    joints.setdefault("default", Joint("default"))
    return MappingProxyType(joints)
