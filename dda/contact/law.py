"""The contact law between Newton solves: multipliers, friction bounds, broken bonds.

Each Newton solve minimises the step's potential with the contact data
frozen (:mod:`dda.contact.potential`). Between solves (the outer loop of
:func:`dda.solve.step.solve_step`) this module updates that data from the solution:

* **augmented Lagrangian** (paper §3): a contact on its elastic normal piece
  whose |g| exceeds the tolerance is augmented, λn ← max(λn + p g, −T)
  (eq. 7); a stuck contact whose shear motion |s| exceeds it likewise,
  λt ← λt + ps s. A contact within the tolerance keeps its multipliers. An
  open contact's λn is reset to 0 (which does not move the solution: its force
  is 0 either way). Where the penetration did not shrink below
  ``shrink_target`` of its previous value, p ← growth · p (the variable
  penalty; never above ``max_penalty``).
* **Coulomb friction**: the bound of the next solve is b = tan φ ⟨N⟩₊ + c l
  from this solve's normal force N (Tresca within a solve, Coulomb across
  solves); another solve is needed while that changes the shear forces by
  more than ``friction_tolerance`` of the bounds (2-norms over the contacts).
* **bonds**: an intact contact (cohesion and tensile strength still there)
  that reached its tensile strength or slipped loses both for good.

The pure penalty method is the same with λn ≡ 0. λt is, for both methods,
the shear force the contact carries from one step to the next (its elastic
shear spring force); each step measures s from the step start.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dda.contact import formulas, law_kernels
from dda.contact.contact_set import ContactSet
from dda.contact.potential import ContactTerms
from dda.contact.strength import JointProperties
from dda.jit import compiled, floats
from dda.result import OPEN

UNBOUNDED = formulas.UNBOUNDED  # the bound of a contact whose normal force is not known yet


@dataclass(frozen=True)
class ContactLaw:
    """Settings of the contact law.

    augmented : augmented Lagrangian (True) or pure penalty (False)
    tolerance : AL convergence: largest |g| of a closed contact and |s| of a stuck one
    shear_ratio : ps / p
    friction : False when no joint has friction or cohesion (no shear term is built)
    penalty_growth : factor applied to a contact's penalty when its penetration
        did not shrink below ``shrink_target`` of its previous value
    max_penalty : the penalty is never raised above this
    friction_tolerance : the friction bounds are consistent with the normal forces
        when ‖ΔF‖ ≤ this × ‖b‖: ΔF the change the new bounds make to the shear
        forces, b the new bounds, 2-norms over the contacts (a relative residual
        of the friction forces, measured like Newton's force residual; a
        max-norm against the largest bound let one flickering contact of a
        thousand, carrying 1 % of a block's weight, ask for ten more solves)
    persistent : eq. 7 holds a contact at the penetration it started the step with
        (within the tolerance) instead of driving it to 0: a dynamic step's AL
        (:meth:`for_step`; :func:`dda.contact.formulas.rest_target`)
    """

    augmented: bool
    tolerance: float
    shear_ratio: float
    friction: bool
    penalty_growth: float = 10.0
    shrink_target: float = 0.25
    max_penalty: float = np.inf
    friction_tolerance: float = 1e-3
    persistent: bool = False

    def for_step(self, static: bool) -> ContactLaw:
        """The law of one step: persistent in a dynamic step of the AL."""
        persistent = self.augmented and not static
        return self if persistent == self.persistent else replace(self, persistent=persistent)

    @property
    def allowance(self) -> float:
        """How far below −T a multiplier may lie, per unit penalty
        (:func:`dda.contact.formulas.held_multiplier`): the tolerance when persistent."""
        return float(formulas.multiplier_allowance(self.tolerance, self.persistent))


@dataclass
class LawOutcome:
    """What one update between Newton solves decided."""

    settled: bool  # multipliers, bounds and bonds consistent: the step is solved
    bound: np.ndarray  # the friction bounds the solution's normal forces give
    augmented: int  # contacts whose multipliers moved
    broken: int  # bonds lost
    max_violation: float  # largest |g| (closed) or |s| (stuck) beyond which AL augments


def friction_bound(contacts: ContactSet, joint: JointProperties, normal: np.ndarray):
    """b of the normal forces: :func:`dda.contact.formulas.friction_bound` (peak strength
    while a contact is intact, residual after; Coulomb or Barton–Bandis)."""
    return formulas.friction_bound(joint, normal, contacts.intact)


def contact_terms(
    contacts: ContactSet, joint: JointProperties, law: ContactLaw, bound: np.ndarray
) -> ContactTerms:
    """The frozen data of one Newton solve, with the friction bounds ``bound``.

    λn is kept at or above −T and λt within ±b (a bound that fell since the last
    solve clamps the carried shear force: that is slip, it dissipates).
    """
    if compiled(law_kernels.terms_kernel):
        normal_base, tension, shear_base, shear_penalty, bound = law_kernels.terms_kernel(
            contacts.intact, np.ascontiguousarray(contacts.state, np.int8),
            joint.kernel_strength(), floats(contacts.normal_multiplier),
            floats(contacts.shear_multiplier), floats(contacts.penalty), float(law.shear_ratio),
            floats(bound), bool(law.friction), float(law.allowance),
        )  # fmt: skip
        return ContactTerms(
            normal_base, contacts.penalty, tension, shear_base, shear_penalty, bound
        )
    tension = formulas.tension_held(joint, contacts.intact, contacts.state == OPEN)
    lam_n = contacts.normal_multiplier
    if law.friction:
        shear_penalty = law.shear_ratio * contacts.penalty
    else:
        bound = shear_penalty = np.zeros(len(contacts))
    return ContactTerms(
        normal_base=formulas.held_multiplier(lam_n, tension, contacts.penalty, law.allowance),
        penalty=contacts.penalty,
        tension=tension,
        shear_base=formulas.limited_shear(contacts.shear_multiplier, bound),
        shear_penalty=shear_penalty,
        bound=bound,
    )


class BoundIteration:
    """The friction bounds of the successive Newton solves of one step.

    The bound of each solve comes from the normal forces of the last one,
    b_target = G(b) = tan φ ⟨N⟩₊ + c l. Taken as it is, b ← G(b), the
    iteration converges slowly where contacts' friction bears on each other's
    normal forces (in a jointed rock mass, by a few per cent a solve, swinging).
    Anderson acceleration mixes the last ``DEPTH`` iterates: with the residuals
    r_k = G(b_k) − b_k and Δ the differences of successive iterates,

        γ = argmin ‖r_k − Σ_j γ_j Δr_j‖,
        b ← (b_k − Σ_j γ_j Δb_j) + β (r_k − Σ_j γ_j Δr_j),   β = ``MIXING``,

    which converges in a few steps where G is close to linear, clipped at
    b ≥ 0. Any b ≥ 0 gives a convex potential, so this changes how fast the
    bounds settle, not whether a solve can create energy.

    ``by_rows``: the least squares' products over the contacts as dot products row by
    row (:func:`_least_squares_by_rows`), as the compiled step on band systems makes
    them (:mod:`dda.solve.band_step`), whose Python oracle sets it; else numpy's matrix
    products. The two differ in the last bits, and the iteration carries such
    differences far where the bounds settle slowly: the tunnel's start by the Newton
    continuation alone (the equilibrium start's fallback) with SuperLU settles with the
    matrix products and not within its budget by rows.
    """

    DEPTH = 4
    MIXING = 1.0  # 0.5 measured no better (tunnel, 0.2 s: 24.3 solves a step against 23.7)

    def __init__(self, bound: np.ndarray, by_rows: bool = False) -> None:
        self.bound = bound
        self.by_rows = by_rows
        self._history: list[tuple[np.ndarray, np.ndarray]] = []  # (b, r) per solve

    @property
    def guessing(self) -> bool:
        """True while some bound is a first guess (``UNBOUNDED``), not an iterate."""
        return bool(np.any(self.bound >= 0.5 * UNBOUNDED))

    def advance(self, target: np.ndarray) -> None:
        """Move the bounds on, given ``target`` = G(current bounds)."""
        if self.guessing:
            self._history, self.bound = [], target
            return
        self._history = [*self._history[-self.DEPTH :], (self.bound, target - self.bound)]
        points = np.array([b for b, _ in self._history])
        residuals = np.array([r for _, r in self._history])
        point_steps, residual_steps = np.diff(points, axis=0), np.diff(residuals, axis=0)
        mean_point, mean_residual = points[-1], residuals[-1]
        if self.by_rows and len(points) > 1:
            gamma = _least_squares_by_rows(residual_steps, residuals[-1])
            mean_point = mean_point - _combination(gamma, point_steps)
            mean_residual = mean_residual - _combination(gamma, residual_steps)
        elif len(points) > 1:
            gamma = _least_squares(residual_steps, residuals[-1])
            mean_point = mean_point - gamma @ point_steps
            mean_residual = mean_residual - gamma @ residual_steps
        self.bound = np.maximum(mean_point + self.MIXING * mean_residual, 0.0)


# singular values of the Anderson differences below this fraction of the largest are
# dropped: the Gram matrix resolves them to about √ε of the largest
GRAM_CUTOFF = 1e-7


def _least_squares(differences: np.ndarray, target: np.ndarray) -> np.ndarray:
    """γ = argmin ‖target − differencesᵀ γ‖ for the few rows of ``differences`` (k, m),
    from the k × k Gram matrix A Aᵀ = V Λ Vᵀ: γ = V Λ⁺ Vᵀ A target, directions whose
    singular value √λ is below ``GRAM_CUTOFF`` of the largest dropped (the truncated
    SVD solution; one pass over the m contacts instead of an m × k SVD)."""
    values, vectors = np.linalg.eigh(differences @ differences.T)
    kept = values > (GRAM_CUTOFF**2) * max(float(values[-1]), 0.0)
    projected = vectors.T @ (differences @ target)
    return vectors[:, kept] @ (projected[kept] / values[kept])


def _least_squares_by_rows(differences: np.ndarray, target: np.ndarray) -> np.ndarray:
    """:func:`_least_squares` with the products over the contacts as dot products row
    by row and the rest scalar loops: the compiled step (:mod:`dda.solve.band_step`)
    runs this function compiled, with the same numbers."""
    k = len(differences)
    gram, product = np.empty((k, k)), np.empty(k)
    for i in range(k):
        product[i] = np.dot(differences[i], target)
        for j in range(k):
            gram[i, j] = np.dot(differences[i], differences[j])
    gamma = np.zeros(k)
    if not np.all(np.isfinite(gram)):
        return gamma
    values, vectors = np.linalg.eigh(gram)
    cutoff = (GRAM_CUTOFF**2) * max(float(values[k - 1]), 0.0)
    for a in range(k):
        if values[a] > cutoff:
            projected = 0.0
            for i in range(k):
                projected += vectors[i, a] * product[i]
            for i in range(k):
                gamma[i] += vectors[i, a] * (projected / values[a])
    return gamma


def _combination(gamma: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Σ_k γ_k rows[k], summed in row order."""
    total = np.zeros(rows.shape[1])
    for k in range(len(gamma)):
        total += gamma[k] * rows[k]
    return total


def update(
    contacts: ContactSet,
    terms: ContactTerms,
    g: np.ndarray,
    s: np.ndarray,
    previous_g: np.ndarray | None,
    joint: JointProperties,
    law: ContactLaw,
) -> LawOutcome:
    """Update multipliers, penalties and bonds after a converged Newton solve (in place).

    ``g``, ``s``: penetration and shear motion of each contact at the solution;
    ``previous_g``: the penetrations of the previous solve of this step (None for
    the first). Returns whether another solve is needed.
    """
    settled = True
    if compiled(law_kernels.forces_and_bounds_kernel):
        normal, bound, changed = law_kernels.forces_and_bounds_kernel(
            *terms.kernel_arrays(), floats(g), floats(s), contacts.intact,
            joint.kernel_strength(), bool(law.friction),
        )  # fmt: skip
    else:
        normal = terms.normal_force(g)
        bound = friction_bound(contacts, joint, normal) if law.friction else terms.bound
        if law.friction:
            after = formulas.limited_shear(terms.shear_trial(s), bound)
            changed = np.abs(after - terms.shear_force(s))
    if law.friction:
        settled = bool(np.linalg.norm(changed) <= law.friction_tolerance * np.linalg.norm(bound))
    augmented, violation = 0, 0.0
    if law.augmented:
        augmented, violation = _augment(contacts, terms, g, s, previous_g, law)
        settled &= augmented == 0
    broken = 0
    if settled:  # bonds are judged on consistent forces only: a break is for good
        broken = break_bonds(contacts, terms, joint, g, s)
        settled = broken == 0
    contacts.normal_force = normal
    return LawOutcome(bool(settled), bound, augmented, broken, violation)


def break_bonds(
    contacts: ContactSet,
    terms: ContactTerms,
    joint: JointProperties,
    g: np.ndarray,
    s: np.ndarray,
) -> int:
    """Intact contacts with a bond to lose (a peak strength above the residual: tensile
    strength, cohesion or friction) pulled to their tensile strength, or slipping, have
    their residual strength from then on, for good."""
    breakable = joint.breakable
    if compiled(law_kernels.broken_kernel):
        lost = law_kernels.broken_kernel(
            *terms.kernel_arrays(), floats(g), floats(s), contacts.intact, breakable
        )
        contacts.intact &= ~lost
        return int(np.count_nonzero(lost))
    lost = contacts.intact & breakable & formulas.bond_lost(*terms.kernel_arrays(), g, s)
    contacts.intact &= ~lost
    return int(np.count_nonzero(lost))


def _augment(contacts, terms, g, s, previous_g, law) -> tuple[int, float]:
    """Eq. 7 beyond the tolerance, and the variable penalty; returns (count, violation)."""
    tolerance = law.tolerance
    if compiled(law_kernels.augment_kernel):
        has_previous = previous_g is not None
        previous = floats(previous_g if has_previous else g)
        normal, shear, penalty, count, violation = law_kernels.augment_kernel(
            *terms.kernel_arrays(), floats(g), floats(s), previous, has_previous,
            contacts.fresh, floats(contacts.penetration), floats(contacts.shear_multiplier),
            float(tolerance), float(law.shrink_target), float(law.max_penalty),
            float(law.penalty_growth), bool(law.persistent),
        )  # fmt: skip
        contacts.normal_multiplier, contacts.shear_multiplier = normal, shear
        if has_previous:
            contacts.penalty = penalty
        return int(count), float(violation)
    # a contact found this step already deeper than the tolerance is not augmented: in a
    # static step its penalty spring pushes it out (removing all of its overlap within one
    # step can take more than any multiplier gives once Δt is cut: a 4.6 cm overlap among
    # fragments, cut to 1e-13 s); a dynamic step solves it from touch and moves the
    # overlap out by position (dda.contact.push_out)
    target = formulas.rest_target(contacts.penetration, tolerance, law.persistent)
    elastic, far, stuck, slid, normal, shear = formulas.augmentation(
        *terms.kernel_arrays(), g, s, contacts.fresh, contacts.penetration,
        contacts.shear_multiplier, tolerance, target, law.persistent,
    )  # fmt: skip
    if previous_g is not None:
        normal, contacts.penalty = formulas.grown_penalty(
            normal, contacts.penalty, far, g, previous_g, target, law.shrink_target,
            law.max_penalty, law.penalty_growth,
        )  # fmt: skip
    contacts.normal_multiplier, contacts.shear_multiplier = normal, shear
    violation = max(
        float(np.max(np.abs(g[elastic]), initial=0.0)), float(np.max(np.abs(s[stuck]), initial=0.0))
    )
    return int(np.count_nonzero(far | slid)), violation


def record(
    contacts: ContactSet,
    terms: ContactTerms,
    g: np.ndarray,
    s: np.ndarray,
    limit_band: float = 0.0,
    persistent: bool = False,
) -> None:
    """Write the step's solution into the contact set (in place).

    States: open where the normal force is at its limit 0, else sliding where
    the shear force is at the friction bound (or there is no shear term), else
    locked. The solve settles the bounds only to ``limit_band`` (the law's
    ``friction_tolerance``): a shear force within that fraction of its bound,
    |λt + ps s| ≥ (1 − band) b, is at the bound (a block in limiting
    equilibrium would otherwise be called locked or sliding by the solver's
    last digits). λt becomes the shear force carried into the next step.
    """
    if compiled(law_kernels.recorded_kernel):
        state, multiplier, direction, normal, shear = law_kernels.recorded_kernel(
            *terms.kernel_arrays(),
            floats(g),
            floats(s),
            floats(contacts.normal_multiplier),
            float(limit_band),
            bool(persistent),
        )
        contacts.state, contacts.normal_multiplier = state, multiplier
        contacts.slide_direction = direction
        contacts.normal_force, contacts.shear_force = normal, shear
        contacts.shear_multiplier = shear
        contacts.penetration, contacts.slip = g, s
        return
    state, multiplier, direction, normal, shear = formulas.recorded(
        *terms.kernel_arrays(), g, s, contacts.normal_multiplier, limit_band, persistent
    )
    contacts.state = state.astype(np.int8)
    contacts.normal_multiplier, contacts.slide_direction = multiplier, direction
    contacts.normal_force = normal
    contacts.shear_force = shear
    contacts.shear_multiplier = shear
    contacts.penetration = g
    contacts.slip = s


def friction_dissipation(terms: ContactTerms, s: np.ndarray) -> float:
    """Work of the friction forces against the slips of the step: Σ b ⟨|λt + ps s| − b⟩₊ / ps.

    The plastic part of a contact's shear motion is the trial force's excess
    over the bound divided by ps; friction does b times that.
    """
    work = formulas.friction_work(terms.shear_base, terms.shear_penalty, terms.bound, s)
    return float(np.sum(work))
