"""The velocity update after a step: Newmark with β = ½ and a chosen γ.

Shi's step solves for D with constant acceleration over the step,

    D = v0 Δt + ½ Δt² a1,   so   a1 = 2 (D − v0 Δt) / Δt²

(Newmark's displacement equation with β = ½; the inertia term of the
step's potential, docs/theory.md §3). The new velocity is Newmark's

    v1 = v0 + Δt ((1 − γ) a0 + γ a1)

with a0 the acceleration of the previous step. Shi's update v1 = 2D/Δt − v0
is γ = 1. For a mode much stiffer than 1/Δt² (a corner on a penalty spring)
D → 0 and the (v, Δt a) pair is multiplied each step by a matrix whose
eigenvalues solve λ² − (1 − 2γ) λ + 2 (1 − γ) = 0: at γ = 1 one of them is
−1, so such a mode rings at the period of two steps without decay; at
γ = 0.9 both have |λ| ≤ 0.45. For well-resolved modes the algorithmic
damping ratio is about (γ − ½) ω Δt / 2, so γ = 0.9 damps them less than
γ = 1. With 2β = 1 ≥ γ ≥ ½ the scheme is unconditionally stable for linear
systems and does not create energy. A constant acceleration (a0 = a1) is
followed exactly for every γ.

An acceleration not known yet (the first step, a new fragment) is NaN and
taken equal to a1, i.e. Shi's update for that step.
"""

from __future__ import annotations

import numpy as np

SHI_GAMMA = 1.0  # the default: Shi's update


def step_acceleration(d: np.ndarray, velocity: np.ndarray, dt: float) -> np.ndarray:
    """a1 = 2 (D − v0 Δt) / Δt²: the constant acceleration that moves a block by D."""
    return 2.0 * (d - velocity * dt) / (dt * dt)


def new_velocity(
    d: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, dt: float, gamma: float
) -> tuple[np.ndarray, np.ndarray]:
    """(v1, a1) after a step D from velocity v0 and previous acceleration a0.

    v1 = v0 + Δt ((1 − γ) a0 + γ a1); where a0 is NaN (not known) a0 = a1.
    """
    a1 = step_acceleration(d, velocity, dt)
    a0 = np.where(np.isnan(acceleration), a1, acceleration)
    return newmark_velocity(velocity, a0, a1, dt, gamma), a1


def newmark_velocity(velocity, a0, a1, dt: float, gamma: float):
    """v1 = v0 + Δt ((1 − γ) a0 + γ a1), element by element (arrays or numbers: the
    compiled update, :mod:`dda.solve.update`, calls it on numbers)."""
    return velocity + dt * ((1.0 - gamma) * a0 + gamma * a1)
