"""Compiled twins of the contact law's passes over the contacts (:mod:`dda.contact.law`).

Each function here runs one numpy function of the law contact by contact, its formulas
those of :mod:`dda.contact.formulas` (the same functions, compiled), in the same order
(so the same numbers: every value is an elementwise result; the norms and sums over
the contacts stay numpy's, at the call site). The law's functions call them where the
kernels are used (:func:`dda.jit.compiled`); their numpy bodies call the same formulas
on arrays, and tests/contact/test_law_kernels.py and tests/jit/test_twins.py hold the
loops to them.
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import (
    augmentation,
    bond_lost,
    friction_bound,
    grown_penalty,
    held_multiplier,
    limited_shear,
    normal_force,
    recorded,
    rest_target,
    shear_force,
    tension_held,
)
from dda.contact.strength import joint_of
from dda.jit import kernel
from dda.result import OPEN


def _terms(
    intact, state, strength, multiplier, carried, penalty, shear_ratio, bound, friction, allowance
):
    """:func:`dda.contact.law.contact_terms`: (λn, T, λt, ps, b) of each contact; T the
    tension held (:func:`~dda.contact.formulas.tension_held`), λn the multiplier held
    (:func:`~dda.contact.formulas.held_multiplier`),
    b = ``bound`` (0 without friction), λt = clamp(carried, −b, b), ps = ``shear_ratio`` p
    (0 without friction)."""
    m = penalty.shape[0]
    tension, normal_base = np.empty(m), np.empty(m)
    shear_base, shear_penalty, bounds = np.empty(m), np.empty(m), np.empty(m)
    for c in range(m):
        tension[c] = tension_held(joint_of(strength, c), intact[c], state[c] == OPEN)
        normal_base[c] = held_multiplier(multiplier[c], tension[c], penalty[c], allowance)
        b = bound[c] if friction else 0.0
        bounds[c] = b
        shear_penalty[c] = shear_ratio * penalty[c] if friction else 0.0
        shear_base[c] = limited_shear(carried[c], b)
    return normal_base, tension, shear_base, shear_penalty, bounds


def _forces_and_bounds(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s,
    intact, strength, friction,
):  # fmt: skip
    """:func:`dda.contact.law.update`'s forces: N (:func:`~dda.contact.formulas.normal_force`);
    the new bounds b' (:func:`~dda.contact.formulas.friction_bound`; without friction
    b' = b) and the change |clamp(λt + ps s, ±b') − clamp(λt + ps s, ±b)| they make to the
    shear forces."""
    m = g.shape[0]
    normal, new_bound, changed = np.empty(m), np.empty(m), np.zeros(m)
    for c in range(m):
        normal[c] = normal_force(normal_base[c], penalty[c], tension[c], g[c])
        if not friction:
            new_bound[c] = bound[c]
            continue
        new_bound[c] = friction_bound(joint_of(strength, c), normal[c], intact[c])
        after = shear_force(shear_base[c], shear_penalty[c], new_bound[c], s[c])
        changed[c] = abs(after - shear_force(shear_base[c], shear_penalty[c], bound[c], s[c]))
    return normal, new_bound, changed


def _augment(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s, previous_g,
    has_previous, fresh, penetration, shear_multiplier, tolerance, shrink_target,
    max_penalty, growth, persistent,
):  # fmt: skip
    """:func:`dda.contact.law._augment`: the new (λn, λt, p), the contacts augmented and
    the largest |g| of an elastic contact or |s| of a stuck one."""
    m = g.shape[0]
    new_n, new_t, new_p = np.empty(m), np.empty(m), np.empty(m)
    count, violation = 0, 0.0
    for c in range(m):
        target = rest_target(penetration[c], tolerance, persistent)
        elastic, far, stuck, slid, new_n[c], new_t[c] = augmentation(
            normal_base[c], penalty[c], tension[c], shear_base[c], shear_penalty[c], bound[c],
            g[c], s[c], fresh[c], penetration[c], shear_multiplier[c], tolerance, target,
            persistent,
        )  # fmt: skip
        new_p[c] = penalty[c]
        if has_previous:
            new_n[c], new_p[c] = grown_penalty(
                new_n[c], penalty[c], far, g[c], previous_g[c], target, shrink_target,
                max_penalty, growth,
            )  # fmt: skip
        count += far or slid
        if elastic:
            violation = max(violation, abs(g[c]))
        if stuck:
            violation = max(violation, abs(s[c]))
    return new_n, new_t, new_p, count, violation


def _broken(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s, intact, breakable
):  # fmt: skip
    """:func:`dda.contact.law.break_bonds`: which intact contacts with a bond to lose
    (``breakable``) are at their tensile strength or slipping (their bonds lost)."""
    m = g.shape[0]
    lost = np.zeros(m, np.bool_)
    for c in range(m):
        if not (intact[c] and breakable[c]):
            continue
        lost[c] = bond_lost(
            normal_base[c], penalty[c], tension[c], shear_base[c], shear_penalty[c], bound[c],
            g[c], s[c],
        )  # fmt: skip
    return lost


def _recorded(
    normal_base, penalty, tension, shear_base, shear_penalty, bound, g, s,
    normal_multiplier, limit_band, persistent,
):  # fmt: skip
    """:func:`dda.contact.law.record`: (state, λn, slide direction, N, F) of each contact."""
    m = g.shape[0]
    state = np.empty(m, np.int8)
    new_n, direction = np.empty(m), np.empty(m)
    normal, shear = np.empty(m), np.empty(m)
    for c in range(m):
        state[c], new_n[c], direction[c], normal[c], shear[c] = recorded(
            normal_base[c], penalty[c], tension[c], shear_base[c], shear_penalty[c], bound[c],
            g[c], s[c], normal_multiplier[c], limit_band, persistent,
        )  # fmt: skip
    return state, new_n, direction, normal, shear


terms_kernel = kernel(_terms)
forces_and_bounds_kernel = kernel(_forces_and_bounds)
augment_kernel = kernel(_augment)
broken_kernel = kernel(_broken)
recorded_kernel = kernel(_recorded)
