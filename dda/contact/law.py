"""Contact laws: open-close with Coulomb friction, penalty or augmented Lagrangian.

Per closed contact the energy is λn d + p d²/2 (paper eq. 8) in the normal
direction and, while locked, λt s + ps s²/2 in the shear direction
(ps = shear_ratio · p). The pure penalty method is the same with λ ≡ 0.
A sliding contact instead carries a friction force λt = ±(μ N + c l) as a
pair of point loads. Contributions (eqs. 16-21):

    K_ii += p EᵀE, K_ij += p EᵀG, K_ji += p GᵀE, K_jj += p GᵀG
    F_i  -= (λ + p S0/l) Eᵀ,  F_j -= (λ + p S0/l) Gᵀ

After each solve, d = S0/l + E D_i + G D_j and s likewise; the law updates
states and multipliers (λ_{k+1} = λ_k + p d, eq. 7) and, in AL mode, raises
the penalty of contacts whose penetration does not shrink fast enough.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows
from dda.jit import compiled, kernel
from dda.result import LOCKED, OPEN, SLIDING


@dataclass(frozen=True)
class ContactLaw:
    """Settings of the contact law.

    augmented : augmented Lagrangian (True) or pure penalty (False)
    tolerance : AL convergence: largest |d| (closed) and |s| (locked) accepted
    shear_ratio : ps / p
    friction : False when no joint has friction or cohesion (every closed
        contact then slides freely and no shear spring is built)
    penalty_growth : factor applied to a contact's penalty when its
        penetration did not shrink below ``shrink_target`` of its previous value
    max_penalty : the penalty is never raised above this
    state_band : the evidence a contact state change needs, as a length
        (``[contact] state_band``, default ``dda.model.STATE_BAND``, of the
        model size): an open contact closes
        when d > band, a closed one opens when its normal force is tensile
        beyond T·l + k·band, a locked one slips when its shear force exceeds
        the Coulomb bound by ks·band, a sliding one sticks when it moved back
        by more than band since the step start (not since its shear reference
        point: a contact that slipped during this step still has the
        reference of its locked state). k = min(p, band_stiffness) and
        ks = shear_ratio·k: the force band does not grow with a huge penalty
        (which would let a contact hold tension). Without a band, contacts
        that touch with next to no force (at rest, or the side joints of a
        wall under gravity) flip state on motions of 1e-10 of the model
        forever, each flip costing a solve.
    band_stiffness : the largest spring constant of the force band (the
        stiffest material's Young's modulus)
    """

    augmented: bool
    tolerance: float
    shear_ratio: float
    friction: bool
    penalty_growth: float = 10.0
    shrink_target: float = 0.25
    max_penalty: float = np.inf
    state_band: float = 0.0
    band_stiffness: float = np.inf


@dataclass
class JointProperties:
    """Per contact: tan φ, cohesion force c·l and tensile force T·l capacities."""

    friction: np.ndarray
    cohesion: np.ndarray
    tensile: np.ndarray


@dataclass
class LawOutcome:
    """What one law update decided."""

    settled: bool  # nothing changed and every tolerance met
    stiffness_changed: bool  # states or penalties changed: K must be rebuilt
    state_changes: int
    max_violation: float


def contact_coefficients(contacts: ContactSet, rows: ContactRows, law: ContactLaw):
    """Per-contact stiffness (normal, shear) and force coefficients (normal, shear).

    The generalised force is F -= coef·(row); the stiffness is k·rowᵀrow.
    """
    closed = contacts.state != OPEN
    locked = contacts.state == LOCKED
    p = np.where(closed, contacts.penalty, 0.0)
    ps = np.where(locked, law.shear_ratio * contacts.penalty, 0.0)
    lam_n = contacts.normal_multiplier if law.augmented else 0.0
    normal_force = np.where(closed, lam_n + p * rows.penetration, 0.0)
    lam_t_locked = contacts.shear_multiplier if law.augmented else 0.0
    shear_force = np.where(
        locked,
        lam_t_locked + ps * rows.slip,
        np.where(contacts.state == SLIDING, contacts.shear_multiplier, 0.0),
    )
    return p, ps, normal_force, shear_force


def update(
    contacts: ContactSet,
    rows: ContactRows,
    d: np.ndarray,
    s: np.ndarray,
    previous_d: np.ndarray | None,
    joint: JointProperties,
    law: ContactLaw,
    held: tuple[np.ndarray, np.ndarray] | None = None,
) -> LawOutcome:
    """Apply the law after a solve; edits ``contacts`` in place.

    ``d`` and ``s`` are the normal penetration and the shear position of each
    contact after the solve; ``previous_d`` those of the previous iteration.
    ``held`` = (keep_closed, keep_sliding) masks: contacts that keep
    flipping open/closed (sliding/locked) within one step are held closed
    (sliding), which ends a cycle of state changes among contacts whose
    flips move next to nothing. Held closed, a contact is a spring whose AL
    multiplier stays within the joint's tensile strength (one that was open
    is closed at its gap, a spring stretched by p·d from the start: energy
    that appears from nothing, docs/contact.md "What holding closed costs in
    energy"): the augmentation λ ← λ + p d would otherwise pile up tension
    in it, solve after solve and, warm-started, step after step; held
    sliding, it carries the Coulomb force, which is right for a contact at
    the friction limit (one that moves back pushes the blocks: the
    summary's held_friction_work).

    A sliding contact that moves back sticks, unless it carries next to no
    friction (capacity within the force band): then it only turns its
    friction round, which changes F but not K.

    Augmented Lagrangian: eq. 7 is applied only while the gap is beyond the
    tolerance (the paper iterates "until |d| ≤ tolerance"). A contact that kept
    its closed state (locked or sliding) with |d| ≤ tolerance keeps its λn, and
    one that stayed locked with |s| ≤ tolerance keeps its λt; the contact force
    is λ + p d either way. A contact that changed state gets what the law gives
    it (0 when it opens or closes; augmented between locked and sliding: keeping
    λn there too took the paper's pushed block from 1.1e-3 to 2.6e-3 off
    Newton's acceleration); a contact held closed gets its bounded multiplier.
    Augmenting within the tolerance is an integral controller across steps: a
    step that ends after one solve leaves λ ← λ + p d while d is still there at
    the next step's start, so the force grows by p d per step. Against an
    oscillation d = D sin ωt that force lags by 90°, and its power on the
    blocks, (p D²/Δt) cos² ωt, is never negative: negative damping. A stack of
    five blocks with p = 0.1 E (tolerance 1e-4 of the model size, Δt = 1e-3 s)
    gained 2.4e3 J in 0.2 s and its blocks jumped; now it never gains energy.
    Within the tolerance a contact is a spring with a fixed preload λ, which
    stores energy and cannot create any. It also ended a failure of the AL
    walls of ``dda bench`` from 30x30 up: every solve moved each contact's λn,
    and with it the friction capacity tan φ·λn, by p·d (a few N on blocks of
    25.5 N, |d| ~1e-7 m against a tolerance of 3.4e-3 m) while the open–close
    iteration searched for the states.
    """
    if held is None:
        nothing = np.zeros(len(contacts), bool)
        held = (nothing, nothing)
    if compiled(_decide_kernel):
        changes, violation = _decide_compiled(contacts, rows, d, s, joint, law, held)
    else:
        changes = _decide(contacts, rows, d, s, joint, law, held)
        violation = _violation(d, s, contacts.state, law)
    now_closed = contacts.state != OPEN
    penalty_raised = False
    if law.augmented and changes == 0:
        penalty_raised = _raise_penalties(contacts, d, previous_d, now_closed, law)
    settled = changes == 0 and (not law.augmented or violation <= law.tolerance)
    return LawOutcome(
        settled=settled,
        stiffness_changed=changes > 0 or penalty_raised,
        state_changes=changes,
        max_violation=violation,
    )


def _decide(contacts, rows, d, s, joint, law, held) -> int:
    """numpy: new states, directions, multipliers and forces (edits ``contacts``); the
    number of state changes. ``held``: (keep closed, keep sliding) masks."""
    state = contacts.state
    closed = state != OPEN
    p = contacts.penalty
    lam_n = contacts.normal_multiplier if law.augmented else np.zeros_like(p)
    normal = lam_n + p * d  # trial normal force (compression > 0)
    tensile = np.where(contacts.intact, joint.tensile, 0.0)
    cohesion = np.where(contacts.intact, joint.cohesion, 0.0)

    eps = law.state_band
    moved = s - rows.slip  # shear motion since the step start
    band_force = np.minimum(p, law.band_stiffness) * eps
    keep_closed, keep_sliding = held
    opens = closed & ~keep_closed & (normal < -tensile - band_force)
    closes = ~closed & ((d > eps) | keep_closed)
    new_state = state.copy()
    new_state[opens] = OPEN
    new_state[closes] = LOCKED

    shear_capacity = np.maximum(joint.friction * normal, 0.0) + cohesion
    lam_t = contacts.shear_multiplier if law.augmented else np.zeros_like(p)
    trial_shear = lam_t + law.shear_ratio * p * s
    still_closed = closed & ~opens
    if law.friction:
        shear_noise = law.shear_ratio * band_force
        slips = (
            still_closed
            & (state == LOCKED)
            & ((np.abs(trial_shear) > shear_capacity + shear_noise) | keep_sliding)
        )
        moved_back = still_closed & (state == SLIDING) & (contacts.slide_direction * moved < -eps)
        weightless = shear_capacity <= shear_noise
        sticks = moved_back & ~weightless & ~keep_sliding
        reverses = moved_back & weightless
        new_state[slips] = SLIDING
        new_state[sticks] = LOCKED
        contacts.slide_direction[slips] = np.sign(trial_shear[slips])
        contacts.slide_direction[reverses] = np.sign(moved[reverses])
    else:
        slips = still_closed & (state == LOCKED)
        sticks = np.zeros_like(slips)
        new_state[slips] = SLIDING
        contacts.slide_direction[still_closed] = np.sign(s[still_closed])
    contacts.intact &= ~(opens | slips)

    now_closed = new_state != OPEN
    now_sliding = new_state == SLIDING
    now_locked = new_state == LOCKED
    normal = np.where(now_closed, normal, 0.0)
    friction_force = contacts.slide_direction * (
        np.maximum(joint.friction * normal, 0.0) + np.where(contacts.intact, cohesion, 0.0)
    )
    friction_force = np.where(law.friction, friction_force, 0.0)
    if law.augmented:
        # held closed, a contact cannot open: its multiplier stops at the joint's
        # tensile strength instead of accumulating tension (docs/theory.md §5)
        bounded = np.where(keep_closed, np.maximum(normal, -tensile), normal)
        kept = (new_state == state) & closed & ~keep_closed & (np.abs(d) <= law.tolerance)
        contacts.normal_multiplier = np.where(
            now_closed & ~closes, np.where(kept, lam_n, bounded), 0.0
        )
    shear_out = np.where(now_sliding, friction_force, np.where(now_locked, trial_shear, 0.0))
    stayed_locked = now_locked & (state == LOCKED) & (np.abs(s) <= law.tolerance)
    locked_multiplier = np.where(stayed_locked, lam_t, trial_shear)
    contacts.shear_multiplier = np.where(
        now_sliding, friction_force, np.where(now_locked & law.augmented, locked_multiplier, 0.0)
    )
    contacts.shear_multiplier[sticks] = np.where(law.augmented, friction_force[sticks], 0.0)

    contacts.normal_force = normal
    contacts.shear_force = shear_out
    contacts.penetration = d
    contacts.slip = s

    changes = int(np.count_nonzero(new_state != state))
    contacts.state = new_state
    return changes


def _decide_compiled(contacts, rows, d, s, joint, law, held) -> tuple[int, float]:
    """:func:`_decide` and :func:`_violation` in one compiled pass (the same numbers)."""
    m = len(contacts)
    new_state = np.empty(m, contacts.state.dtype)
    normal, shear, lam_n, lam_t = (np.empty(m) for _ in range(4))
    changes, violation = _decide_kernel(
        contacts.state,
        contacts.penalty,
        np.ascontiguousarray(d, dtype=np.float64),
        np.ascontiguousarray(s, dtype=np.float64),
        rows.slip,
        contacts.normal_multiplier,
        contacts.shear_multiplier,
        contacts.slide_direction,
        contacts.intact,
        (joint.friction, joint.cohesion, joint.tensile),
        held,
        (law.augmented, law.friction),
        (law.shear_ratio, law.state_band, law.band_stiffness, law.tolerance),
        (new_state, normal, shear, lam_n, lam_t),
    )
    if law.augmented:
        contacts.normal_multiplier = lam_n
    contacts.shear_multiplier = lam_t
    contacts.normal_force = normal
    contacts.shear_force = shear
    contacts.penetration = d
    contacts.slip = s
    contacts.state = new_state
    return int(changes), float(violation)


def _decide_each(
    state,
    penalty,
    d,
    s,
    start_slip,
    lam_n_in,
    lam_t_in,
    direction,
    intact,
    joint,
    held,
    switches,
    settings,
    out,
):
    """Compiled :func:`_decide` contact by contact, with the same floating-point
    operations in the same order; ``direction`` and ``intact`` are edited in place."""
    friction, cohesion, tensile = joint
    keep_closed, keep_sliding = held
    augmented, with_friction = switches
    shear_ratio, band, band_stiffness, tolerance = settings
    new_state, normal_out, shear_out, lam_n_out, lam_t_out = out
    changes = 0
    violation = 0.0
    for c in range(state.shape[0]):
        was = state[c]
        closed = was != OPEN
        p = penalty[c]
        normal = (lam_n_in[c] if augmented else 0.0) + p * d[c]
        cohesion_c = cohesion[c] if intact[c] else 0.0
        tensile_c = tensile[c] if intact[c] else 0.0
        band_force = min(p, band_stiffness) * band
        opens = closed and not keep_closed[c] and normal < -tensile_c - band_force
        closes = not closed and (d[c] > band or keep_closed[c])
        now = OPEN if opens else (LOCKED if closes else was)
        capacity = max(friction[c] * normal, 0.0) + cohesion_c
        trial = (lam_t_in[c] if augmented else 0.0) + shear_ratio * p * s[c]
        still_closed = closed and not opens
        sticks = False
        if with_friction:
            noise = shear_ratio * band_force
            slips = (
                still_closed
                and was == LOCKED
                and (abs(trial) > capacity + noise or keep_sliding[c])
            )
            moved = s[c] - start_slip[c]
            moved_back = still_closed and was == SLIDING and direction[c] * moved < -band
            weightless = capacity <= noise
            sticks = moved_back and not weightless and not keep_sliding[c]
            if slips:
                now = SLIDING
                direction[c] = np.sign(trial)
            if sticks:
                now = LOCKED
            if moved_back and weightless:
                direction[c] = np.sign(moved)
        else:
            slips = still_closed and was == LOCKED
            if slips:
                now = SLIDING
            if still_closed:
                direction[c] = np.sign(s[c])
        if opens or slips:
            intact[c] = False
        now_closed = now != OPEN
        normal = normal if now_closed else 0.0
        friction_force = 0.0
        if with_friction:
            held_cohesion = cohesion_c if intact[c] else 0.0
            friction_force = direction[c] * (max(friction[c] * normal, 0.0) + held_cohesion)
        if augmented:
            bounded = max(normal, -tensile_c) if keep_closed[c] else normal
            if closed and now == was and not keep_closed[c] and abs(d[c]) <= tolerance:
                bounded = lam_n_in[c]  # within the tolerance: not augmented
            lam_n_out[c] = bounded if now_closed and not closes else 0.0
        if now == SLIDING:
            shear_out[c] = friction_force
            lam_t_out[c] = friction_force
        elif now == LOCKED:
            shear_out[c] = trial
            kept = was == LOCKED and abs(s[c]) <= tolerance
            lam_t_out[c] = (lam_t_in[c] if kept else trial) if augmented else 0.0
        else:
            shear_out[c] = 0.0
            lam_t_out[c] = 0.0
        if sticks:
            lam_t_out[c] = friction_force if augmented else 0.0
        normal_out[c] = normal
        new_state[c] = now
        changes += now != was
        if now_closed:
            violation = max(violation, abs(d[c]))
        if with_friction and now == LOCKED:
            violation = max(violation, abs(s[c]))
    return changes, violation


_decide_kernel = kernel(_decide_each)


def _violation(d: np.ndarray, s: np.ndarray, state: np.ndarray, law: ContactLaw) -> float:
    """Largest |d| over closed contacts and |s| over locked ones."""
    closed = state != OPEN
    parts = [np.abs(d[closed])]
    if law.friction:
        parts.append(np.abs(s[state == LOCKED]))
    values = np.concatenate(parts)
    return float(values.max()) if len(values) else 0.0


def _raise_penalties(contacts, d, previous_d, closed, law) -> bool:
    """Variable penalty: p ← growth·p where |d| > tol and |d| > target·|d_prev|.

    Each augmentation shrinks the penetration by about k/(k+p) (k: the
    contact's stiffness without the spring); when that ratio is poor, a
    larger p is worth one re-factorisation.
    """
    if previous_d is None:
        return False
    slow = (
        closed
        & (np.abs(d) > law.tolerance)
        & (np.abs(d) > law.shrink_target * np.abs(previous_d))
        & (contacts.penalty < law.max_penalty)
    )
    if not slow.any():
        return False
    contacts.penalty[slow] = np.minimum(
        contacts.penalty[slow] * law.penalty_growth, law.max_penalty
    )
    return True
