"""Fracture onset from the FEM: the load at which a block's average stress meets its criterion.

The criterion is the three-parameter Mohr–Coulomb criterion of Lin, Amadei,
Sture & Jung (1994), eqs. (22)–(25), written here from the paper (tension
positive, σ1 ≤ σ3 the principal stresses, s0 the cohesion, φ the friction
angle, T0 the tensile strength)::

    N   = tan²(π/4 + φ/2)
    C0  = 2 s0 tan(π/4 + φ/2)                      (24)
    σ1c = −C0 + T0 N                               (25)
    shear:   σ1 ≤ −C0 + σ3 N    where σ1 < σ1c     (22)
    tension: σ3 ≥ T0            where σ1 ≥ σ1c     (23)

The DDA applies it to each block's one stress after every step. The FEM
side applies it to the block's area-averaged stress. Under loads scaled by
a factor λ (gravity fixed), a linear model with an unchanged contact state
has σ(λ) = σ(0) + λ (σ(1) − σ(0)); the onset factor λ* is the smallest λ at
which the criterion holds, found by bisection.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda import Scene
from verify.fem import fields
from verify.fem.statics import FemOptions, FemSolution, solve_fem


@dataclass(frozen=True)
class Strength:
    """Mohr–Coulomb strength of a material (angle in degrees)."""

    cohesion: float
    friction_angle: float
    tensile_strength: float

    @property
    def uniaxial(self) -> float:
        """C0 = 2 s0 tan(π/4 + φ/2), eq. (24)."""
        return 2.0 * self.cohesion * np.tan(np.pi / 4 + np.radians(self.friction_angle) / 2)

    @property
    def slope(self) -> float:
        """N = tan²(π/4 + φ/2)."""
        return np.tan(np.pi / 4 + np.radians(self.friction_angle) / 2) ** 2


def principal(stress: np.ndarray) -> tuple[float, float]:
    """(σ1, σ3), σ1 ≤ σ3, of a plane stress state (sxx, syy, sxy)."""
    sxx, syy, sxy = stress
    centre, radius = (sxx + syy) / 2, np.hypot((sxx - syy) / 2, sxy)
    return centre - radius, centre + radius


def fails(stress: np.ndarray, strength: Strength) -> bool:
    """Whether the three-parameter criterion (22)–(25) holds for this stress."""
    s1, s3 = principal(stress)
    c0, n = strength.uniaxial, strength.slope
    if s1 < -c0 + strength.tensile_strength * n:
        return bool(s1 <= -c0 + s3 * n)
    return bool(s3 >= strength.tensile_strength)


def crack_planes(stress: np.ndarray, strength: Strength) -> list[float]:
    """Directions (degrees from the x axis, in [0, 180)) of the planes the criterion cuts a
    failing block along (paper §4, after eq. 25): in shear two planes at ±(45° − φ/2) to
    the σ1 direction θ1, in tension one plane containing σ1 (normal to σ3); none if the
    stress does not fail. θ1 = ½ atan2(2 sxy, sxx − syy) + 90°, σ1 the most compressive."""
    if not fails(stress, strength):
        return []
    sxx, syy, sxy = stress
    theta1 = np.degrees(0.5 * np.arctan2(2.0 * sxy, sxx - syy)) + 90.0
    s1, _ = principal(stress)
    if s1 >= -strength.uniaxial + strength.tensile_strength * strength.slope:  # eq. 25
        return [float(theta1 % 180.0)]
    half = 45.0 - strength.friction_angle / 2.0
    return sorted(float((theta1 + sign * half) % 180.0) for sign in (1.0, -1.0))


def strength_of(scene: Scene, block: int) -> Strength | None:
    """The block's material strength (None: unbreakable)."""
    material = scene.materials[scene.blocks[block].material]
    if material.cohesion is None or material.friction_angle is None:
        return None
    return Strength(material.cohesion, material.friction_angle, material.tensile_strength or 0.0)


@dataclass(frozen=True)
class Onset:
    """Onset load factor of every breakable free block (NaN: no onset up to the maximum)."""

    factors: dict[int, float]
    base: FemSolution  # the loads at factor 0
    unit: FemSolution  # the loads at factor 1

    def stress_at(self, block: int, factor: float) -> np.ndarray:
        """Block ``block``'s average stress at load factor ``factor``: σ(0) + f (σ(1) − σ(0))."""
        s0 = fields.block_average_stress(self.base)[block]
        return s0 + factor * (fields.block_average_stress(self.unit)[block] - s0)


def onset_factors(scene: Scene, options: FemOptions, largest: float) -> Onset:
    """Smallest load factor in [0, ``largest``] at which each breakable block fails."""
    base = solve_fem(scene, options, load_factor=0.0)
    unit = solve_fem(scene, options, load_factor=1.0)
    s0 = fields.block_average_stress(base)
    ds = fields.block_average_stress(unit) - s0
    factors = {}
    for i in unit.block_mesh.blocks:
        strength = strength_of(scene, i)
        if strength is not None:
            factors[i] = first_failure(lambda f, i=i: s0[i] + f * ds[i], strength, largest)
    return Onset(factors, base, unit)


def first_failure(stress_at, strength: Strength, largest: float, steps: int = 60) -> float:
    """Bisection for the smallest factor in [0, largest] whose stress fails (NaN if none)."""
    if fails(stress_at(0.0), strength):
        return 0.0
    if not fails(stress_at(largest), strength):
        return float("nan")
    low, high = 0.0, largest
    for _ in range(steps):
        middle = (low + high) / 2
        low, high = (low, middle) if fails(stress_at(middle), strength) else (middle, high)
    return high
