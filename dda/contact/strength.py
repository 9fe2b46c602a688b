"""The strength of each contact's joint, as the formulas of :mod:`dda.contact.formulas` read it."""

from __future__ import annotations

from dataclasses import dataclass, fields
from functools import cached_property
from typing import NamedTuple

import numpy as np

from dda.jit import formula


class Strength(NamedTuple):
    """:class:`JointProperties` as the compiled loops take it (contiguous arrays)."""

    friction: np.ndarray
    cohesion: np.ndarray
    tensile: np.ndarray
    residual_friction: np.ndarray
    residual_cohesion: np.ndarray
    residual_tensile: np.ndarray
    barton: np.ndarray
    jrc: np.ndarray
    jcs_length: np.ndarray
    residual_angle: np.ndarray
    divisor: np.ndarray
    any_barton: bool  # some contact is on a Barton–Bandis joint


@formula
def joint_of(strength: Strength, contact: int) -> Strength:
    """Contact ``contact``'s strengths as numbers, for the formulas in a compiled loop.

    A kernel's formula reads a row of numbers, never the tuple of arrays: with the
    tuple of eleven arrays handed to the formula in its loop, the contact law's forces
    and bounds of 3,600 contacts took 290 µs a pass against 29 µs this way (the loop's
    machine code then kept reference counts of the arrays)."""
    s, c = strength, contact
    return Strength(
        s.friction[c], s.cohesion[c], s.tensile[c], s.residual_friction[c],
        s.residual_cohesion[c], s.residual_tensile[c], s.barton[c], s.jrc[c],
        s.jcs_length[c], s.residual_angle[c], s.divisor[c], s.any_barton,
    )  # fmt: skip


@dataclass
class JointProperties:
    """Per contact: the strengths of its joint, peak (while intact) and residual.

    friction, cohesion, tensile : tan φ, c l, T l of the intact joint
    residual_* : tan φ_r, c_r l, T_r l once it has slipped or opened (defaults: tan φ,
        0, 0, the brittle joint)
    barton : Barton–Bandis joints; for them jrc, jcs_length (JCS l: σn = N / l),
        residual_angle (φr, radians) and divisor (the shear strength's divisor, F of
        a strength-reduction trial or a stage)
    """

    friction: np.ndarray
    cohesion: np.ndarray
    tensile: np.ndarray
    residual_friction: np.ndarray | None = None
    residual_cohesion: np.ndarray | None = None
    residual_tensile: np.ndarray | None = None
    barton: np.ndarray | None = None
    jrc: np.ndarray | None = None
    jcs_length: np.ndarray | None = None
    residual_angle: np.ndarray | None = None
    divisor: np.ndarray | None = None

    def __post_init__(self) -> None:
        m = len(self.friction)
        defaults = {
            "residual_friction": self.friction,
            "residual_cohesion": np.zeros(m),
            "residual_tensile": np.zeros(m),
            "barton": np.zeros(m, bool),
            "jrc": np.zeros(m),
            "jcs_length": np.zeros(m),
            "residual_angle": np.zeros(m),
            "divisor": np.ones(m),
        }
        for name, value in defaults.items():
            if getattr(self, name) is None:
                setattr(self, name, value)

    @cached_property
    def any_barton(self) -> bool:
        """Some contact is on a Barton–Bandis joint (else the bounds skip that formula)."""
        return bool(np.any(self.barton))

    @property
    def breakable(self) -> np.ndarray:
        """Contacts whose strength changes when they slip or open: the bond to lose."""
        return (
            (self.tensile != self.residual_tensile)
            | (self.cohesion != self.residual_cohesion)
            | (self.friction != self.residual_friction)
        )

    def kernel_strength(self) -> Strength:
        """The arrays as the compiled loops take them."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            kind = np.bool_ if f.name == "barton" else np.float64
            out[f.name] = np.ascontiguousarray(value, kind)
        return Strength(**out, any_barton=self.any_barton)
