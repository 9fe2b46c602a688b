"""The contact law's formulas, each written once for every path that evaluates it.

Every function here is a :func:`dda.jit.formula`: it takes numpy arrays (the numpy
paths: one call over all contacts) or numbers (the compiled loops of
:mod:`dda.contact.law_kernels`, :mod:`dda.solve.contact_pieces` and
:mod:`dda.solve.band_step`, one contact at a time, which compile the same function into
themselves), using only arithmetic, comparisons, ``&``, ``|``, :func:`select`
(``np.where``) and numpy's elementwise functions (``np.maximum``, ``np.minimum``,
``np.abs``, ``np.sign``, ``np.logical_not``, ``np.log10``, ``np.tan``), which mean the
same on both (for finite numbers: Python's ``min`` of a NaN differs). The joint
strengths come as ``joint``: the contacts' :class:`~dda.contact.strength.JointProperties`
(arrays) in numpy, one contact's :func:`~dda.contact.strength.joint_of` (numbers) in
the compiled loops.

With λn the normal multiplier, p the penalty, T the tension a contact holds, λt the
shear force carried, ps the shear penalty and b the friction bound (docs/theory.md
§4-6, docs/contact.md)::

    N = max(λn + p g, −T)                      normal force (eq. 7's trial, limited)
    F = clamp(λt + ps s, −b, b)                shear force
    T = T_peak l while intact, else T_res l    tension held
    b = tan φ ⟨N⟩₊ + c l                       Coulomb, peak while intact, residual after
    b = (⟨N⟩₊ tan φ_mob + c l) / F_s           Barton–Bandis, φ_mob of σn = N / l

Barton–Bandis: φ_mob = φr + JRC log10(JCS / σn) (degrees), bounded below by φr (the
formula is not meant beyond σn = JCS, where it would fall under the residual angle)
and above by ``MOBILISED_CAP`` = 70° (at small σn the logarithm grows without bound;
70° is Barton's cut-off for the peak angle of a rough joint under low stress): b is 0
at σn = 0, continuous and rising with σn.
"""

from __future__ import annotations

import math

import numpy as np

from dda.jit import formula, select
from dda.result import LOCKED, OPEN, SLIDING
from dda.scene.joints import MOBILISED_CAP_DEGREES

# pieces of a contact's terms (shear: which side of the friction bound, or stuck)
NORMAL_LIMIT, NORMAL_ELASTIC = 0, 1  # at the limit −T (open when T = 0) / elastic spring
SLIP_BACK, STICK, SLIP_FORWARD = -1, 0, 1

UNBOUNDED = 1e300  # the friction bound of a contact whose normal force is not known yet
MOBILISED_CAP = math.radians(MOBILISED_CAP_DEGREES)
TINY = 1e-300  # keeps the logarithm of σn = 0 and of a Coulomb joint's JCS = 0 finite


@formula
def limited_normal(value, tension):
    """max(value, −T): a normal force or multiplier held at or above −T."""
    return np.maximum(value, -tension)


@formula
def limited_shear(value, bound):
    """clamp(value, −b, b): a shear force or multiplier held within ±b."""
    return np.minimum(np.maximum(value, -bound), bound)


@formula
def normal_trial(normal_base, penalty, gap):
    """λn + p g."""
    return normal_base + penalty * gap


@formula
def normal_force(normal_base, penalty, tension, gap):
    """N = max(λn + p g, −T)."""
    return limited_normal(normal_trial(normal_base, penalty, gap), tension)


@formula
def shear_trial(shear_base, shear_penalty, slip):
    """λt + ps s."""
    return shear_base + shear_penalty * slip


@formula
def shear_force(shear_base, shear_penalty, bound, slip):
    """F = clamp(λt + ps s, −b, b)."""
    return limited_shear(shear_trial(shear_base, shear_penalty, slip), bound)


@formula
def tension_held(joint, intact, opened):
    """T l while intact, the residual T_r l after, and none while the contact is open
    (``opened``: open at the step's start, stretched beyond its tension or apart, a
    ductile joint's too, whose bond never breaks: it holds tension again once it has
    closed, from its spring's stretch 0, so that the force follows the gap without a
    jump)."""
    return select(opened, 0.0, select(intact, joint.tensile, joint.residual_tensile))


@formula
def mobilised_tangent(joint, pressed):
    """tan φ_mob of Barton–Bandis at the normal force ``pressed`` ≥ 0 (module notes). The
    ratio JCS l / σn l is held below 1/TINY (σn l at least TINY JCS l), so that an
    unloaded contact of a strong joint gives the cap without overflowing."""
    strength = np.maximum(joint.jcs_length, TINY)
    ratio = strength / np.maximum(np.maximum(pressed, TINY * strength), TINY)
    residual = joint.residual_angle
    angle = residual + joint.jrc * np.log10(ratio) * (math.pi / 180.0)
    return np.tan(np.minimum(np.maximum(angle, residual), MOBILISED_CAP))


@formula
def friction_bound(joint, normal, intact):
    """b of the normal force ``normal``: Coulomb, peak while intact and residual after,
    or Barton–Bandis (module notes; its formula only where some joint has it)."""
    pressed = np.maximum(normal, 0.0)
    held = select(intact, joint.cohesion, joint.residual_cohesion)
    tangent = select(intact, joint.friction, joint.residual_friction)
    coulomb = tangent * pressed + held
    if not joint.any_barton:
        return coulomb
    barton = (pressed * mobilised_tangent(joint, pressed) + held) / joint.divisor
    return select(joint.barton, barton, coulomb)


@formula
def normal_piece(normal_base, penalty, tension, gap):
    """Elastic where λn + p g ≥ −T, else at the limit −T."""
    elastic = normal_trial(normal_base, penalty, gap) >= -tension
    return select(elastic, NORMAL_ELASTIC, NORMAL_LIMIT)


@formula
def shear_piece(shear_base, shear_penalty, bound, slip):
    """Slipping back where λt + ps s ≤ −b, else forward where ≥ b, else stuck."""
    trial = shear_trial(shear_base, shear_penalty, slip)
    return select(trial <= -bound, SLIP_BACK, select(trial >= bound, SLIP_FORWARD, STICK))


@formula
def normal_spring(penalty, piece):
    """kn: p on the elastic normal piece, else 0."""
    return select(piece == NORMAL_ELASTIC, penalty, 0.0)


@formula
def shear_spring(shear_penalty, piece):
    """ks: ps on the stuck shear piece, else 0."""
    return select(piece == STICK, shear_penalty, 0.0)


@formula
def normal_offset(normal_base, penalty, tension, gap0, piece):
    """N of the piece's quadratic at D = 0: λn + p g₀ (elastic) or −T."""
    elastic = piece == NORMAL_ELASTIC
    return select(elastic, normal_trial(normal_base, penalty, gap0), -tension)


@formula
def shear_offset(shear_base, shear_penalty, bound, slip0, piece):
    """F of the piece's quadratic at D = 0: λt + ps s₀ (stuck) or ±b (the piece's sign)."""
    stuck = piece == STICK
    return select(stuck, shear_trial(shear_base, shear_penalty, slip0), piece * bound)


@formula
def normal_energy(normal_base, penalty, tension, gap):
    """φn(g) = (N² − λn²) / 2p, less T (λn + p g + T) / p beyond the limit (potential.py)."""
    trial = normal_trial(normal_base, penalty, gap)
    force = limited_normal(trial, tension)
    beyond = select(trial < -tension, tension * (trial + tension) / penalty, 0.0)
    return (force * force - normal_base * normal_base) / (2.0 * penalty) - beyond


@formula
def shear_energy(shear_base, shear_penalty, bound, slip):
    """φt(s) = (F² − λt²) / 2ps + b ⟨|λt + ps s| − b⟩₊ / ps (ps > 0)."""
    trial = shear_trial(shear_base, shear_penalty, slip)
    force = limited_shear(trial, bound)
    excess = np.maximum(np.abs(trial) - bound, 0.0)
    elastic = (force * force - shear_base * shear_base) / (2.0 * shear_penalty)
    return elastic + bound * excess / shear_penalty


@formula
def held_multiplier(multiplier, tension, penalty, allowance):
    """λn held at or above −(T + p a): ``allowance`` a is 0 (λn ≥ −T), or the AL tolerance
    in a dynamic step, where λn = N − p t may hold a contact's force N at a target
    penetration t ≤ a (:func:`augmentation`)."""
    return limited_normal(multiplier, tension + penalty * allowance)


@formula
def multiplier_allowance(tolerance, persistent):
    """How far below −T a multiplier may lie, per unit penalty (:func:`held_multiplier`):
    the tolerance where ``persistent`` (a dynamic step's AL), else 0."""
    return select(persistent, tolerance, 0.0)


@formula
def rest_target(found_penetration, tolerance, persistent):
    """The penetration t that eq. 7 drives a contact to: 0, or where ``persistent`` (a
    dynamic step) the penetration the contact started the step with, within
    [0, tolerance]. Driving a contact already pressed in back to 0 within one step would
    push its blocks apart with a force it never stored: energy the numerics make
    (docs/contact.md, "Energy"); held at t, the update only stops it going deeper."""
    return select(persistent, np.minimum(np.maximum(found_penetration, 0.0), tolerance), 0.0)


@formula
def augmentation(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s,
    fresh, found_penetration, carried_shear, tolerance, target, persistent,
):  # fmt: skip
    """Eq. 7 beyond the tolerance (docs/contact.md): (elastic, far, stuck, slid, λn', λt').

    A contact on the elastic normal piece whose |g − t| or g exceeds ``tolerance`` is
    *far* (t = ``target``, :func:`rest_target`): its λn' = max(λn + p g, −T) − p t, the
    force at the solution carried to g = t; off the elastic piece λn' = 0 (where
    ``persistent``: min(λn, 0), so that a contact held at t > 0 stays there), else λn is
    kept. One found this step already deeper than the tolerance (``fresh``,
    ``found_penetration``: in a static step; a dynamic one solves it from touch,
    :mod:`dda.contact.push_out`) keeps its λn: its spring pushes the overlap out. A stuck
    contact (|λt + ps s| < b, ps > 0) that slid more than the tolerance carries
    λt' = λt + ps s, else ``carried_shear``."""
    trial_n = normal_trial(normal_base, penalty, g)
    elastic = trial_n >= -tension
    found_deep = fresh & (found_penetration > tolerance)
    beyond = (np.abs(g - target) > tolerance) | (g > tolerance)
    far = elastic & beyond & np.logical_not(found_deep)
    trial_t = shear_trial(shear_base, shear_penalty, s)
    stuck = (np.abs(trial_t) < bound) & (shear_penalty > 0.0)
    slid = stuck & (np.abs(s) > tolerance)
    carried = limited_normal(trial_n, tension) - penalty * target
    opened = select(persistent, np.minimum(normal_base, 0.0), 0.0)
    normal = select(elastic, select(far, carried, normal_base), opened)
    return elastic, far, stuck, slid, normal, select(slid, trial_t, carried_shear)


@formula
def grown_penalty(
    multiplier, penalty, far, g, previous_g, target, shrink_target, max_penalty, growth
):  # fmt: skip
    """The variable penalty (§3): (λn', p'). p' = min(p × growth, p_max) where a far
    contact's |g − t| is still above ``shrink_target`` × its |g − t| of the last solve (it
    did not shrink enough), else p; λn' = λn − (p' − p) t keeps the force at the target
    penetration t (:func:`rest_target`; 0: λn' = λn)."""
    distance = np.abs(g - target)
    slow = far & (distance > shrink_target * np.abs(previous_g - target)) & (penalty < max_penalty)
    grown = select(slow, np.minimum(penalty * growth, max_penalty), penalty)
    return multiplier - (grown - penalty) * target, grown


@formula
def bond_lost(normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s):
    """A bond (of a contact with one to lose) goes at its tensile strength (the normal
    force at its limit −T, T > 0) or when it slips: its shear trial at the bound b, but
    not a trial of 0 at b = 0 (a joint in tension without cohesion, carrying no shear,
    is on the kink that the pieces count as slipping; nothing slips there: an audit's
    block hung from a roof by such a joint fell at once)."""
    normal = normal_piece(normal_base, penalty, tension, g)
    shear = shear_piece(shear_base, shear_penalty, bound, s)
    at_tension = (normal != NORMAL_ELASTIC) & (tension > 0.0)
    moving = (bound > 0.0) | (shear_trial(shear_base, shear_penalty, s) != 0.0)
    slipping = (shear != STICK) & (shear_penalty > 0.0) & moving
    return at_tension | slipping


@formula
def recorded(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s,
    normal_multiplier, limit_band, persistent,
):  # fmt: skip
    """A contact's record at the step's end: (state, λn, slide direction, N, F). Open
    where the spring's trial force λn + p g is beyond its limit −T (0: apart; a
    tension T > 0: stretched beyond what it holds, so that it holds none from the next
    step, :func:`tension_held`),
    else sliding where |λt + ps s| ≥ (1 − ``limit_band``) b or there is no shear term,
    else locked; an open contact keeps no N or F, and no λn but, where ``persistent``
    and still pressed in (g > 0), a negative one: the target penetration it was held at
    (:func:`augmentation`)."""
    closed = normal_trial(normal_base, penalty, g) >= -tension
    trial = shear_trial(shear_base, shear_penalty, s)
    stuck = (np.abs(trial) < (1.0 - limit_band) * bound) & (shear_penalty > 0.0)
    state = select(closed, select(stuck, LOCKED, SLIDING), OPEN)
    normal = select(closed, normal_force(normal_base, penalty, tension, g), 0.0)
    shear = select(closed, shear_force(shear_base, shear_penalty, bound, s), 0.0)
    direction = select(state == SLIDING, np.sign(trial), 0.0)
    kept = select(persistent & (g > 0.0), np.minimum(normal_multiplier, 0.0), 0.0)
    return state, select(closed, normal_multiplier, kept), direction, normal, shear


@formula
def first_bound(
    joint, intact, opened, multiplier, penalty, allowance, gap0, last_normal, found_touching
):
    """A step's first friction bound: b of the larger of N at the start geometry,
    max(λn + p g₀, −T) (λn :func:`held_multiplier`), and the last step's N (a contact
    of blocks that turn together may open by one step's second-order rotation and close
    again in the next: its last force is the better guess); ``UNBOUNDED`` (stuck) for a
    contact found touching this step, whose force is not known yet."""
    tension = tension_held(joint, intact, opened)
    held = held_multiplier(multiplier, tension, penalty, allowance)
    start = normal_force(held, penalty, tension, gap0)
    bound = friction_bound(joint, np.maximum(start, last_normal), intact)
    return select(found_touching, UNBOUNDED, bound)


@formula
def remembered_pieces(normal, shear, state, direction):
    """The pieces of a step's first Newton iteration: those at the start point
    (``normal``, ``shear``), except that a contact closed at the last step's end is taken
    elastic, one locked then stuck, and one sliding then sliding the same way."""
    normal = select(state != OPEN, NORMAL_ELASTIC, normal)
    sliding = select(direction < 0.0, SLIP_BACK, SLIP_FORWARD)
    shear = select(state == SLIDING, sliding, shear)
    return normal, select(state == LOCKED, STICK, shear)


@formula
def friction_work(shear_base, shear_penalty, bound, slip):
    """b ⟨|λt + ps s| − b⟩₊ / ps: the work of a contact's friction against its slip in the
    step (the plastic part of its shear motion is the trial force's excess over the bound
    over ps); 0 without a shear term (ps = 0)."""
    excess = np.maximum(np.abs(shear_trial(shear_base, shear_penalty, slip)) - bound, 0.0)
    live = shear_penalty > 0.0
    return select(live, bound * excess / select(live, shear_penalty, 1.0), 0.0)
