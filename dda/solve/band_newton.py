"""Compiled Newton on a step's potential, K in band storage: one kernel call a pass.

The iteration of :func:`dda.solve.newton.minimise` — the same pieces, springs and
offsets (:mod:`dda.solve.contact_pieces`), the exact line search (the compiled twin
of :func:`dda.contact.line_search.line_minimum`), chord steps with the kept
factorisation while each leaves at most ``rate`` of ‖∇Π‖ (conjugated when asked), the
same convergence test — in one call. The contacts' gradients are kept as twelve
entries a contact (the columns of its two blocks' unknowns, ``columns``, and the
rows r = [r_i r_j]), K₀ as its 6 × 6 blocks plus the springs between blocks (rock
bolts, twelve entries each too), and

    K = K₀ + Σ k_n r_n r_nᵀ + Σ k_s r_s r_sᵀ,   K₀ = blockdiag + Σ k_b r_b r_bᵀ,
    ∇Π(D) = K₀ D − F₀ + G_nᵀ N(g) + G_sᵀ F(s),   g = g₀ + G_n D,  s = s₀ + G_s D,

in LAPACK's lower band storage, AB[j, i − j] = K[i, j] for j ≤ i ≤ j + kd, factorised
by ``dpbtrf`` (about n kd² flops) and solved by ``dpbtrs`` (4 n kd). The blocks are
numbered so that every contact's (and bolt's) two blocks lie close
(:mod:`dda.solve.band_system`): kd is 6 × the largest distance in that numbering
between two blocks in contact, plus 5. Products with G and Gᵀ are O(12 m), with K₀
O(36 n).

The numpy :func:`dda.solve.newton.minimise` is its oracle (tests/solve/test_band_newton.py):
the two agree to rounding (sums in another order).
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import normal_force as normal_force_of
from dda.contact.formulas import shear_force as shear_force_of
from dda.contact.line_search import _line_minimum_kernel
from dda.jit import Lapack, kernel
from dda.solve.band_arguments import PassOutcome
from dda.solve.contact_pieces import (
    _add_contact_energy,
    _offsets,
    _pieces,
    _same_pieces,
    _same_springs,
    _springs,
)

# what the kernel's ``state`` array holds: whether ``band`` is a factorisation of the K of
# ``springs``, the factorisations the kernel made, and 1 once LAPACK found a K not
# positive definite (the caller's numpy Newton takes the pass over)
HAS_FACTOR, FACTORISATIONS, FAILED = 0, 1, 2

_dpbtrf = Lapack("dpbtrf", 6)  # UPLO, N, KD, AB, LDAB, INFO
_dpbtrs = Lapack("dpbtrs", 9)  # UPLO, N, KD, NRHS, AB, LDAB, B, LDB, INFO
_LOWER = 76  # "L"


def _along(columns, rows, x):
    """r · x of each contact (Σ over its 12 entries; a column −1 is a fixed block's)."""
    m = columns.shape[0]
    out = np.zeros(m)
    for c in range(m):
        total = 0.0
        for a in range(12):
            column = columns[c, a]
            if column >= 0:
                total += rows[c, a] * x[column]
        out[c] = total
    return out


def _gather(columns, normal_rows, normal, shear_rows, shear, size):
    """Σ N r_n + Σ T r_s over the contacts, a vector of ``size`` unknowns."""
    out = np.zeros(size)
    for c in range(columns.shape[0]):
        for a in range(12):
            column = columns[c, a]
            if column >= 0:
                out[column] += normal[c] * normal_rows[c, a] + shear[c] * shear_rows[c, a]
    return out


def _base_product(geometry, x):
    """K₀ x: the (n, 6, 6) diagonal blocks and the bolts' springs k_b r_b r_bᵀ
    (``geometry``: a :class:`~dda.solve.band_arguments.BandGeometry`)."""
    blocks, bolt_columns, bolt_rows, bolt_k = (
        geometry.blocks, geometry.bolt_columns, geometry.bolt_rows, geometry.bolt_k
    )  # fmt: skip
    out = np.empty(x.shape[0])
    for b in range(blocks.shape[0]):
        for r in range(6):
            total = 0.0
            for q in range(6):
                total += blocks[b, r, q] * x[6 * b + q]
            out[6 * b + r] = total
    if bolt_k.shape[0]:
        stretch = bolt_k * _along(bolt_columns, bolt_rows, x)
        out += _gather(
            bolt_columns, bolt_rows, stretch, bolt_rows, np.zeros_like(stretch), x.shape[0]
        )
    return out


def _add_band_springs(band, columns, normal_rows, kn, shear_rows, ks):
    """``band`` (lower band storage) += Σ kn r_n r_nᵀ + ks r_s r_sᵀ over the 12 columns
    of each spring (−1: a fixed block's, left out)."""
    for c in range(columns.shape[0]):
        for a in range(12):
            row = columns[c, a]
            if row < 0:
                continue
            an, as_ = kn[c] * normal_rows[c, a], ks[c] * shear_rows[c, a]
            for e in range(12):
                column = columns[c, e]
                if 0 <= column <= row:
                    band[column, row - column] += an * normal_rows[c, e] + as_ * shear_rows[c, e]


def _band_factorise(geometry, kn, ks, band):
    """``band`` = L of K = K₀ + Σ kn r_n r_nᵀ + ks r_s r_sᵀ = L Lᵀ in lower band
    storage; returns LAPACK's INFO (0: done; > 0: K is not positive definite)."""
    blocks, bolt_rows, bolt_k = geometry.blocks, geometry.bolt_rows, geometry.bolt_k
    band[:, :] = 0.0
    for b in range(blocks.shape[0]):
        for q in range(6):
            for r in range(q, 6):
                band[6 * b + q, r - q] = blocks[b, r, q]
    _add_band_springs(
        band, geometry.bolt_columns, bolt_rows, bolt_k, bolt_rows, np.zeros_like(bolt_k)
    )
    _add_band_springs(band, geometry.columns, geometry.normal_rows, kn, geometry.shear_rows, ks)
    n, width = band.shape
    numbers = np.array([n, width - 1, width, 0], np.int32)  # N, KD, LDAB, INFO
    uplo = np.array([_LOWER], np.uint8)
    _dpbtrf(
        uplo.ctypes.data, numbers[0:].ctypes.data, numbers[1:].ctypes.data,
        band.ctypes.data, numbers[2:].ctypes.data, numbers[3:].ctypes.data,
    )  # fmt: skip
    return numbers[3]


def _band_solve(band, rhs):
    """x with L Lᵀ x = rhs, L in lower band storage (``dpbtrs``)."""
    n, width = band.shape
    numbers = np.array([n, width - 1, 1, width, n, 0], np.int32)  # N, KD, NRHS, LDAB, LDB, INFO
    uplo = np.array([_LOWER], np.uint8)
    x = rhs.copy()
    _dpbtrs(
        uplo.ctypes.data, numbers[0:].ctypes.data, numbers[1:].ctypes.data,
        numbers[2:].ctypes.data, band.ctypes.data, numbers[3:].ctypes.data, x.ctypes.data,
        numbers[4:].ctypes.data, numbers[5:].ctypes.data,
    )  # fmt: skip
    return x


def _residual(geometry, terms, kd, g, s):
    """(∇Π, ‖K₀D‖ + ‖contact forces‖ + ‖F₀‖) at the point whose K₀D, g, s are given
    (``terms``: a :class:`~dda.solve.band_arguments.BandTerms`)."""
    lam_n, p, tension, lam_t, ps, bound = terms
    forces, columns = geometry.forces, geometry.columns
    normal_rows, shear_rows = geometry.normal_rows, geometry.shear_rows
    m = g.shape[0]
    normal_force, shear_force = np.empty(m), np.empty(m)
    for c in range(m):
        normal_force[c] = normal_force_of(lam_n[c], p[c], tension[c], g[c])
        shear_force[c] = shear_force_of(lam_t[c], ps[c], bound[c], s[c])
    contact = _gather(columns, normal_rows, normal_force, shear_rows, shear_force, kd.shape[0])
    residual = kd - forces + contact
    scale = np.linalg.norm(kd) + np.linalg.norm(contact) + np.linalg.norm(forces)
    return residual, scale


def _band_minimise(geometry, terms, friction, start, rules, factor):
    """Compiled :func:`dda.solve.newton.minimise` on band systems (module docstring).

    ``geometry``, ``terms``: a :class:`~dda.solve.band_arguments.BandGeometry` and
    :class:`~dda.solve.band_arguments.BandTerms`; ``start``: a
    :class:`~dda.solve.band_arguments.PassStart` (copied, not changed; its gaps computed
    here unless ``have_gaps``); ``rules``: a :class:`~dda.solve.band_arguments.PassRules`
    (``max_steps`` < 0: no limit); ``factor``: the kept
    :class:`~dda.solve.band_arguments.Factor`, its ``state`` :data:`HAS_FACTOR` /
    :data:`FACTORISATIONS` / :data:`FAILED` updated in place. Returns a
    :class:`~dda.solve.band_arguments.PassOutcome`.
    """
    columns, normal_rows, shear_rows = geometry.columns, geometry.normal_rows, geometry.shear_rows
    forces, g0, s0 = geometry.forces, geometry.g0, geometry.s0
    lam_n, p, tension, lam_t, ps, bound = terms
    band, springs, state = factor
    max_solves, max_steps, rate = rules.max_solves, rules.max_steps, rules.rate
    m, n = g0.shape[0], start.d.shape[0]
    d = start.d.copy()
    if start.have_gaps:
        g, s = start.g.copy(), start.s.copy()
    else:
        g = g0 + _along(columns, normal_rows, d)
        s = s0 + _along(columns, shear_rows, d)
    kd = _base_product(geometry, d)
    normal, shear = np.empty(m, np.int8), np.empty(m, np.int8)
    other_normal, other_shear = np.empty(m, np.int8), np.empty(m, np.int8)
    have_pieces = start.have_pieces
    if have_pieces:
        for c in range(m):
            normal[c], shear[c] = start.normal[c], start.shear[c]
    gradient = np.zeros(n)
    have_gradient = False
    if rules.chord_first:
        gradient, _ = _residual(geometry, terms, kd, g, s)
        have_gradient = True
    solves = chords = 0
    last_direction, last_gradient, last_preconditioned = np.zeros(n), np.zeros(n), np.zeros(n)
    have_last = False
    kn, ks = np.empty(m), np.empty(m)
    while solves < max_solves and (max_steps < 0 or solves + chords < max_steps):
        if have_gradient and state[HAS_FACTOR] == 1:
            preconditioned = _band_solve(band, gradient)
            direction = -preconditioned
            chords += 1
            if rules.conjugate and have_last:
                scale = last_preconditioned @ last_gradient
                if scale > 0.0:
                    beta = max(0.0, (preconditioned @ (gradient - last_gradient)) / scale)
                    conjugated = direction + beta * last_direction
                    if gradient @ conjugated < 0.0:
                        direction = conjugated
            last_direction, last_gradient = direction, gradient
            last_preconditioned, have_last = preconditioned, True
            dg, ds = _along(columns, normal_rows, direction), _along(columns, shear_rows, direction)
        else:
            have_last = False
            solves += 1
            if not have_pieces:
                _pieces(lam_n, p, tension, lam_t, ps, bound, g, s, normal, shear)
            _springs(p, ps, friction, normal, shear, kn, ks)
            if not (state[HAS_FACTOR] == 1 and _same_springs(kn, ks, springs)):
                state[HAS_FACTOR] = 0
                info = _band_factorise(geometry, kn, ks, band)
                if info != 0:
                    state[FAILED] = 1
                    return PassOutcome(d, g, s, solves, chords, False, False, False)
                for c in range(m):
                    springs[0, c], springs[1, c] = kn[c], ks[c]
                state[HAS_FACTOR] = 1
                state[FACTORISATIONS] += 1
            offset_n, offset_t = _offsets(
                lam_n, p, tension, lam_t, ps, bound, g0, s0, normal, shear
            )
            rhs = forces - _gather(columns, normal_rows, offset_n, shear_rows, offset_t, n)
            target = _band_solve(band, rhs)
            if not np.all(np.isfinite(target)):
                return PassOutcome(target, g, s, solves, chords, False, False, False)
            g_target = g0 + _along(columns, normal_rows, target)
            s_target = s0 + _along(columns, shear_rows, target)
            _pieces(
                lam_n, p, tension, lam_t, ps, bound, g_target, s_target, other_normal, other_shear
            )
            if _same_pieces(ps, bound, normal, shear, other_normal, other_shear):
                return PassOutcome(target, g_target, s_target, solves, chords, True, False, True)
            direction = target - d
            have_pieces = False
            dg, ds = g_target - g, s_target - s
        kp = _base_product(geometry, direction)
        a = direction @ (kd - forces)
        curvature = direction @ kp
        alpha, _ = _line_minimum_kernel(
            lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, a, curvature
        )
        d = d + alpha * direction
        g = g + alpha * dg
        s = s + alpha * ds
        kd = kd + alpha * kp
        residual, scale = _residual(geometry, terms, kd, g, s)
        size = np.linalg.norm(residual)
        if size <= rules.tolerance * scale:
            return PassOutcome(d, g, s, solves, chords, True, False, True)
        shrunk = (not have_gradient) or size <= rate * np.linalg.norm(gradient)
        if shrunk:
            gradient, have_gradient = residual, True
        else:
            have_gradient = False
    return PassOutcome(d, g, s, solves, chords, False, have_gradient, True)


def _potential(geometry, terms, d):
    """Π(D) = ½ DᵀK₀D − F₀ᵀD + Σ φn(g) + Σ φt(s) (:func:`dda.solve.newton.potential`)."""
    value = d @ (0.5 * _base_product(geometry, d) - geometry.forces)
    g = geometry.g0 + _along(geometry.columns, geometry.normal_rows, d)
    s = geometry.s0 + _along(geometry.columns, geometry.shear_rows, d)
    lam_n, p, tension, lam_t, ps, bound = terms
    return _add_contact_energy(value, lam_n, p, tension, lam_t, ps, bound, g, s)


_along = kernel(_along) or _along
_gather = kernel(_gather) or _gather
_base_product = kernel(_base_product) or _base_product
_add_band_springs = kernel(_add_band_springs) or _add_band_springs
_band_factorise = kernel(_band_factorise) or _band_factorise
_band_solve = kernel(_band_solve) or _band_solve
_residual = kernel(_residual) or _residual
band_minimise_kernel = kernel(_band_minimise)
potential_kernel = kernel(_potential)
