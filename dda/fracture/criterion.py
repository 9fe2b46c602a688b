"""Three-parameter Mohr–Coulomb fracture criterion (paper §4, eqs. 22–25).

Tension is positive. ``sigma1 <= sigma3`` are the principal stresses at the
block centroid, ``sigma1`` the most compressive one. Every function works on
all blocks at once (arrays of shape ``(n,)`` or ``(n, 3)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NONE, SHEAR, TENSION = 0, 1, 2
MODE_NAMES = {NONE: "none", SHEAR: "shear", TENSION: "tension"}


@dataclass(frozen=True)
class PrincipalStresses:
    """Principal stresses (tension positive) and the direction of ``sigma1``.

    Attributes
    ----------
    sigma1 : (n,) most compressive principal stress (the smaller one)
    sigma3 : (n,) most tensile principal stress (the larger one)
    angle1 : (n,) angle of the ``sigma1`` direction from the x axis, rad, in (-π/2, π/2]
    """

    sigma1: np.ndarray
    sigma3: np.ndarray
    angle1: np.ndarray


@dataclass(frozen=True)
class FailureState:
    """What the criterion says about each block.

    Attributes
    ----------
    mode : (n,) int, ``NONE`` (0), ``SHEAR`` (1) or ``TENSION`` (2)
    principal : the principal stresses the decision was made on
    planes : (n, 2) directions (rad from the x axis) of the cutting planes
        through the centroid: two for shear, ``planes[:, 0]`` alone for
        tension (``planes[:, 1]`` is NaN), NaN for intact blocks
    """

    mode: np.ndarray
    principal: PrincipalStresses
    planes: np.ndarray

    @property
    def failing(self) -> np.ndarray:
        """Rows of the blocks that fail."""
        return np.flatnonzero(self.mode != NONE)


def principal_stresses(stress: np.ndarray) -> PrincipalStresses:
    """Principal stresses of plane stress states ``(sxx, syy, sxy)``.

    σ = (sxx + syy)/2 ∓ sqrt(((sxx − syy)/2)² + sxy²); the most tensile
    direction is θ3 = ½ atan2(2 sxy, sxx − syy) and the most compressive one
    θ1 = θ3 + π/2 (wrapped to (−π/2, π/2]).

    Parameters
    ----------
    stress : (n, 3) or (3,) array of sxx, syy, sxy (tension positive)
    """
    s = np.atleast_2d(np.asarray(stress, dtype=float))
    sxx, syy, sxy = s[:, 0], s[:, 1], s[:, 2]
    centre = 0.5 * (sxx + syy)
    radius = np.hypot(0.5 * (sxx - syy), sxy)
    theta3 = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    angle1 = _wrap_half_turn(theta3 + 0.5 * np.pi)
    return PrincipalStresses(centre - radius, centre + radius, angle1)


def strength_numbers(
    cohesion: np.ndarray | float,
    friction_angle: np.ndarray | float,
    tensile_strength: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The constants of the criterion: ``(N, C0, sigma1c)``.

    N = tan²(π/4 + φ/2); C0 = 2 s0 tan(π/4 + φ/2) (24), the unconfined
    compressive strength; σ1c = −C0 + T0 N (25), the transition between the
    shear and the tensile branch.

    Parameters
    ----------
    cohesion : s0
    friction_angle : φ in radians
    tensile_strength : T0 (``inf`` for no tension cut-off)
    """
    root = np.tan(0.25 * np.pi + 0.5 * np.asarray(friction_angle, dtype=float))
    n_phi = root * root
    c0 = 2.0 * np.asarray(cohesion, dtype=float) * root
    with np.errstate(invalid="ignore"):
        sigma1c = -c0 + np.asarray(tensile_strength, dtype=float) * n_phi
    return n_phi, c0, sigma1c


def failure_mode(
    principal: PrincipalStresses,
    cohesion: np.ndarray | float,
    friction_angle: np.ndarray | float,
    tensile_strength: np.ndarray | float,
) -> np.ndarray:
    """Mode of failure of each block: ``NONE``, ``SHEAR`` or ``TENSION``.

    Shear (22): σ1 < −C0 + σ3 N while σ1 < σ1c.
    Tension (23): σ3 > T0 while σ1 ≥ σ1c.

    A block fails once its stress is beyond the criterion, not on it: with no
    tensile strength (T0 = 0, or s0 = 0), an unstressed block is on it, and was
    split at every step (1 block into 64 in 6 steps, with no load).
    """
    n_phi, c0, sigma1c = strength_numbers(cohesion, friction_angle, tensile_strength)
    s1, s3 = principal.sigma1, principal.sigma3
    shear = (s1 < -c0 + s3 * n_phi) & (s1 < sigma1c)
    tension = (s3 > tensile_strength) & (s1 >= sigma1c)
    mode = np.full(s1.shape, NONE, dtype=np.int8)
    mode[shear] = SHEAR
    mode[tension] = TENSION
    return mode


def plane_directions(
    mode: np.ndarray, angle1: np.ndarray, friction_angle: np.ndarray | float
) -> np.ndarray:
    """Directions of the cutting planes through the centroid, shape (n, 2).

    Shear: θ1 ± (π/4 − φ/2), two planes inclined to σ1 (paper §4, after (25)).
    Tension: θ1, one plane at right angle to σ3 (it contains σ1).
    Intact blocks: NaN.
    """
    half = 0.25 * np.pi - 0.5 * np.broadcast_to(np.asarray(friction_angle, float), angle1.shape)
    planes = np.full((len(angle1), 2), np.nan)
    shear = mode == SHEAR
    planes[shear, 0] = _wrap_half_turn(angle1[shear] + half[shear])
    planes[shear, 1] = _wrap_half_turn(angle1[shear] - half[shear])
    tension = mode == TENSION
    planes[tension, 0] = angle1[tension]
    return planes


def evaluate(
    stress: np.ndarray,
    cohesion: np.ndarray | float,
    friction_angle: np.ndarray | float,
    tensile_strength: np.ndarray | float,
) -> FailureState:
    """Apply the three-parameter Mohr–Coulomb criterion (22)–(25) to every block.

    Parameters
    ----------
    stress : (n, 3) sxx, syy, sxy at the block centroids, tension positive
    cohesion : s0, scalar or (n,)
    friction_angle : φ in radians, scalar or (n,)
    tensile_strength : T0, scalar or (n,); ``inf`` means no tension cut-off

    Returns
    -------
    FailureState
        mode per block and the directions of the cutting planes.
    """
    principal = principal_stresses(stress)
    mode = failure_mode(principal, cohesion, friction_angle, tensile_strength)
    planes = plane_directions(mode, principal.angle1, friction_angle)
    return FailureState(mode, principal, planes)


def _wrap_half_turn(angle: np.ndarray) -> np.ndarray:
    """Map line directions (defined modulo π) to (−π/2, π/2]."""
    wrapped = np.mod(angle + 0.5 * np.pi, np.pi) - 0.5 * np.pi
    return np.where(wrapped <= -0.5 * np.pi, wrapped + np.pi, wrapped)
