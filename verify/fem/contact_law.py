"""The FEM's own contact law: open or closed, sticking or slipping (Coulomb), found by itself.

Every slave point of every interface (:mod:`verify.fem.contact`) carries a
normal spring ``k_n`` and a shear spring ``k_t`` and the joint's strengths:
friction ``tan φ``, a cohesion force ``c w`` and a tensile force ``T w``.
With ``g`` the gap (negative: penetration) and ``s`` the slip of the point,
its forces (tension and the direction of ``t`` positive, as the energy
``½ k_n g² + λ_n g`` and ``½ k_t (s − s_p)² + λ_t s`` has them) are::

    normal  f_n = λ_n + k_n g               closed while  −f_n > −T w   (intact)
                                                           −f_n > 0      (broken)
    shear   f_t = λ_t + k_t (s − s_p)        sticking while |f_t| ≤ b
            f_t = ± b                        slipping, against the trial force
    b = tan φ · N + c w,  N = max(−f_n, 0)   (c w only while intact)

A point that opens or slips loses its cohesion and tensile strength for
good (``intact``), as the engine's joints do (docs/contact.md). ``s_p`` is
the slip a point has accumulated while slipping (zero in a static solve;
carried from step to step in :mod:`verify.fem.dynamics`).

The solve is an active-set iteration: solve with the current states (the
friction force ``± b`` of slipping points held fixed as a load), recompute
every point's trial forces, change the states that are violated, and repeat
until no state changes and the friction forces no longer move (a fixed point
on ``b``). The first guess is every point that touches at the start closed
and sticking. With the augmented-Lagrangian method the multipliers λ are
raised (``λ_n ← λ_n + k_n g``, ``λ_t ← λ_t + k_t (s − s_p)``, one factorisation)
until no closed point penetrates and no sticking point slips more than the
scene's tolerance (docs/theory.md §5 as the scene describes it).

Nothing here is read from a DDA run: the scene's joints, penalty and method
decide everything.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from verify.fem.contact import ContactPoints

log = logging.getLogger(__name__)

CAPACITY_TOLERANCE = 1e-10  # relative change of the friction forces that ends the iteration


@dataclass(frozen=True)
class ContactState:
    """State of every contact point (struct of arrays)."""

    closed: np.ndarray  # (m,) bool
    stick: np.ndarray  # (m,) bool, closed and sticking
    intact: np.ndarray  # (m,) bool, cohesion and tensile strength still there
    plastic_slip: np.ndarray  # (m,) s_p
    direction: np.ndarray  # (m,) sign of the friction force of slipping points
    capacity: np.ndarray  # (m,) b of slipping points, held fixed in a solve
    lam_n: np.ndarray  # (m,) augmented-Lagrangian multipliers (0: pure penalty)
    lam_t: np.ndarray  # (m,)

    @classmethod
    def initial(cls, contact: ContactPoints, touch: float) -> ContactState:
        """Points within ``touch`` of their master closed, sticking and intact."""
        closed = contact.gap0 <= touch
        z = np.zeros(len(contact))
        return cls(closed, closed.copy(), closed.copy(), z, z, z, z, z)

    @property
    def slip(self) -> np.ndarray:
        """Closed points that slip."""
        return self.closed & ~self.stick


@dataclass(frozen=True)
class ContactForces:
    """Forces of every point after a solve (compression and the direction of t positive)."""

    normal: np.ndarray  # (m,) compressive normal force N ≥ −T w
    shear: np.ndarray  # (m,) f_t


def forces(contact: ContactPoints, state: ContactState, u: np.ndarray) -> ContactForces:
    """Normal (compression positive) and shear force of every point in ``state``."""
    normal = -(state.lam_n + contact.k_normal * contact.gaps(u))
    stick_force = state.lam_t + contact.k_shear * (contact.slips(u) - state.plastic_slip)
    shear = np.where(state.stick, stick_force, state.direction * state.capacity)
    return ContactForces(np.where(state.closed, normal, 0.0), np.where(state.closed, shear, 0.0))


def system(contact: ContactPoints, state: ContactState) -> tuple[sp.csr_matrix, np.ndarray]:
    """Contact stiffness and load of the points in their current states."""
    slipping = state.slip
    normal0 = state.closed * (contact.k_normal * contact.gap0 + state.lam_n)
    shear0 = state.stick * (state.lam_t - contact.k_shear * state.plastic_slip)
    shear0 = shear0 + slipping * state.direction * state.capacity
    return contact.stiffness(state.closed, state.stick), contact.load(normal0, shear0)


def decide(contact: ContactPoints, state: ContactState, u: np.ndarray) -> ContactState:
    """New states from the trial forces of the displacement ``u`` (see the module notes)."""
    normal = -(state.lam_n * state.closed + contact.k_normal * contact.gaps(u))
    closed = normal > -contact.tensile * state.intact
    trial = state.lam_t * state.stick + contact.k_shear * (contact.slips(u) - state.plastic_slip)
    pressed = np.where(closed, np.maximum(normal, 0.0), 0.0)
    capacity = contact.friction * pressed + contact.cohesion * state.intact
    stick = closed & (np.abs(trial) <= capacity)
    intact = state.intact & closed & ~(state.stick & ~stick)
    capacity = contact.friction * pressed + contact.cohesion * intact
    keep_n = closed & state.closed
    keep_t = stick & state.stick
    return replace(
        state,
        closed=closed,
        stick=stick,
        intact=intact,
        direction=np.where(closed & ~stick, np.sign(trial), 0.0),
        capacity=np.where(closed & ~stick, capacity, 0.0),
        lam_n=np.where(keep_n, state.lam_n, 0.0),
        lam_t=np.where(keep_t, state.lam_t, 0.0),
    )


def settled(old: ContactState, new: ContactState) -> bool:
    """No state changed and the friction forces stayed put."""
    if not (
        np.array_equal(old.closed, new.closed)
        and np.array_equal(old.stick, new.stick)
        and np.array_equal(old.direction, new.direction)
    ):
        return False
    scale = max(float(np.abs(new.capacity).max(initial=0.0)), np.finfo(float).tiny)
    return float(np.abs(new.capacity - old.capacity).max(initial=0.0)) <= CAPACITY_TOLERANCE * scale


def augment(
    contact: ContactPoints, state: ContactState, u: np.ndarray, tolerance: float
) -> ContactState | None:
    """Raised multipliers, or None when every closed point is within ``tolerance``."""
    gaps = contact.gaps(u)
    slips = contact.slips(u) - state.plastic_slip
    deep = state.closed & (-gaps > tolerance)
    sliding = state.stick & (np.abs(slips) > tolerance)
    if not (deep.any() or sliding.any()):
        return None
    return replace(
        state,
        lam_n=np.where(state.closed, state.lam_n + contact.k_normal * gaps, 0.0),
        lam_t=np.where(state.stick, state.lam_t + contact.k_shear * slips, 0.0),
    )


def solve_with_contact(
    stiffness: sp.csr_matrix,
    load: np.ndarray,
    contact: ContactPoints,
    state: ContactState,
    max_iterations: int = 50,
    tolerance: float | None = None,
    factorisations: dict | None = None,
) -> tuple[np.ndarray, ContactState, int]:
    """Displacement, final contact state and number of linear solves (module notes).

    ``tolerance``: the augmented-Lagrangian tolerance (None: pure penalty).
    ``factorisations``: a dict that keeps the factorisation of every set of
    states seen, for calls with the same ``stiffness`` (time steps of one length).
    """
    solves = 0
    factorisations = {} if factorisations is None else factorisations
    for _ in range(max_iterations):
        k_contact, f_contact = system(contact, state)
        key = (state.closed.tobytes(), state.stick.tobytes())
        if key not in factorisations:
            factorisations[key] = spla.factorized((stiffness + k_contact).tocsc())
        solve = factorisations[key]
        u = solve(load + f_contact)
        solves += 1
        for _ in range(200 if tolerance is not None else 0):
            raised = augment(contact, state, u, tolerance)
            if raised is None:
                break
            state = raised
            u = solve(load + system(contact, state)[1])
            solves += 1
        new = decide(contact, state, u)
        if settled(state, new):
            return u, state, solves
        log.debug(
            "contact states: %d -> %d closed, %d -> %d sticking",
            state.closed.sum(),
            new.closed.sum(),
            state.stick.sum(),
            new.stick.sum(),
        )
        state = new
    log.warning("the contact states did not settle in %d iterations", max_iterations)
    return u, state, solves


def after_step(contact: ContactPoints, state: ContactState, u: np.ndarray) -> ContactState:
    """State carried to the next time step: slipping points keep the slip they made.

    ``s_p`` of a slipping point becomes ``s − f_t / k_t``, so that its spring
    holds exactly its friction force if the point sticks from there.
    """
    slipping = state.slip
    elastic = np.where(slipping, state.direction * state.capacity, 0.0) / np.where(
        contact.k_shear > 0, contact.k_shear, 1.0
    )
    plastic = np.where(slipping, contact.slips(u) - elastic, state.plastic_slip)
    return replace(state, plastic_slip=plastic)
