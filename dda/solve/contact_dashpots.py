"""Restitution: a dashpot beside each contact spring of a joint with ``restitution`` e.

A contact between blocks i and j that touches at the step's start gets, in a dynamic
step, the viscous force c ġ along its normal, ġ = (g − g₀)/Δt = ∇g·D/Δt: the energy
½ (c/Δt) (∇g·D)² of a spring of stiffness c/Δt between the two blocks
(:class:`dda.effects.pair_springs.PairSprings`), convex, and dissipating
(c/Δt)(∇g·D)² ≥ 0 a step. A mass m on a spring p and a dashpot c = 2 ζ √(m p)
leaves it at e times the speed it hit it with, e = exp(−ζ π / √(1 − ζ²)), so

    ζ = −ln e / √(π² + ln² e)          (e = 1: no dashpot; e = 0: critical, ζ = 1)

with p the contact's penalty and m the pair's reduced mass m_i m_j / (m_i + m_j) (m_i
alone against a fixed block) shared by the pair's touching contacts: a block landing
flat on two contacts puts half its mass on each. A stuck contact's shear spring gets a
dashpot too, overdamped (``SHEAR_DAMPING_RATIO``): the penalty's shear spring, stretched
by the impact, would otherwise spring back as the contact unloads, where a rigid
Coulomb contact stops the tangential motion it can. The rebound is e for an impact whose
contact Δt resolves (Shi's velocity update damps by about ω Δt / 4 more, ω = √(p/m))
with the contact's spring as it is: the penalty method, or the augmented Lagrangian
while the penetration stays within its tolerance (beyond, its multiplier stiffens the
contact and the dashpot damps less than e says). Static steps and the equilibrium
start have none.
"""

from __future__ import annotations

import numpy as np

from dda.contact.contact_set import ContactSet
from dda.contact.rows import ContactRows
from dda.effects.pair_springs import PairSprings
from dda.result import LOCKED, OPEN

# the damping ratio of a stuck contact's shear spring: overdamped, so that the tangential
# motion an impact stops stays stopped, as in rigid Coulomb friction (a block dropped
# onto a slope inside its friction: 1.8 % of its tangential speed given back by its first
# impact, 14 % with critical damping, 37 % without)
SHEAR_DAMPING_RATIO = 3.0


def damping_ratio(restitution: np.ndarray) -> np.ndarray:
    """ζ of a linear spring and dashpot with coefficient of restitution e (module notes)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        log_e = np.log(restitution)
        return np.where(restitution > 0.0, -log_e / np.sqrt(np.pi**2 + log_e**2), 1.0)


def contact_dashpots(
    contacts: ContactSet,
    rows: ContactRows,
    restitution: np.ndarray,
    masses: np.ndarray,
    fixed: np.ndarray,
    time_step: float,
    shear_ratio: float,
) -> PairSprings | None:
    """The dashpots c/Δt of the touching contacts whose joint has a restitution
    (``restitution``: e per contact, NaN for none; ``masses``: each block's mass), or
    None when there are none."""
    touching = np.flatnonzero((contacts.state != OPEN) & np.isfinite(restitution))
    if not len(touching):
        return None
    a, b = contacts.block_a[touching], contacts.block_b[touching]
    inverse = np.where(fixed, 0.0, 1.0 / masses)
    reduced = 1.0 / (inverse[a] + inverse[b])
    low, high = np.minimum(a, b), np.maximum(a, b)
    pair = low * len(masses) + high
    _, which, count = np.unique(pair, return_inverse=True, return_counts=True)
    shared = reduced / count[which]
    penalty = contacts.penalty[touching]
    normal = 2.0 * damping_ratio(restitution[touching]) * np.sqrt(shared * penalty)
    stuck = contacts.state[touching] == LOCKED
    shear = 2.0 * SHEAR_DAMPING_RATIO * np.sqrt(shared * shear_ratio * penalty)
    pick = np.flatnonzero(stuck)
    return PairSprings(
        block_i=np.concatenate([a, a[pick]]),
        block_j=np.concatenate([b, b[pick]]),
        row_i=np.concatenate([rows.normal_i[touching], rows.shear_i[touching][pick]]),
        row_j=np.concatenate([rows.normal_j[touching], rows.shear_j[touching][pick]]),
        stiffness=np.concatenate([normal, shear[pick]]) / time_step,
    )
