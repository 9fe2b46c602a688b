"""Compiled Newton on a small step's potential, its systems held dense: one kernel call a pass.

:func:`dda.solve.newton.minimise` spends a few dozen numpy calls on each Newton
iteration and chord step; on a small model (a few dozen blocks) those calls,
not the arithmetic, are the step. On the systems of
:class:`dda.solve.dense_system.DenseSystem` (unknowns of the free blocks,
contact gradient rows G_n, G_s dense) this kernel runs the same iteration —
the same pieces, springs and offsets (:mod:`dda.contact.potential`), the same
exact line search (the compiled twin of :func:`dda.contact.line_search.line_minimum`),
chord steps with the kept factorisation while each leaves at most ``rate`` of
‖∇Π‖ (conjugated when asked), the same convergence test — in one call, with a
dense Cholesky (LAPACK through numba) and triangular solves:

    K = K₀ + Σ k_n r_n r_nᵀ + Σ k_s r_s r_sᵀ,   F = F₀ − G_nᵀ N₀ − G_sᵀ T₀,
    ∇Π(D) = K₀ D − F₀ + G_nᵀ N(g) + G_sᵀ F(s),   g = g₀ + G_n D,  s = s₀ + G_s D.

The numpy :func:`~dda.solve.newton.minimise` is its oracle (tests/test_dense_newton.py):
the two agree to rounding (sums in another order).
"""

from __future__ import annotations

import numpy as np

from dda.contact.line_search import _line_minimum_kernel
from dda.jit import kernel
from dda.solve.newton import RELATIVE_TOLERANCE

# what the kernel's ``state`` array holds: whether ``lower`` is a factorisation of the K of
# ``springs``, and the factorisations the kernel made
HAS_FACTOR, FACTORISATIONS = 0, 1


def _pieces(lam_n, p, tension, lam_t, ps, bound, g, s, normal, shear):
    """:meth:`dda.contact.potential.ContactTerms.pieces`, written into ``normal``, ``shear``."""
    for c in range(g.shape[0]):
        normal[c] = 1 if lam_n[c] + p[c] * g[c] >= -tension[c] else 0
        trial = lam_t[c] + ps[c] * s[c]
        if trial <= -bound[c]:
            shear[c] = -1
        elif trial >= bound[c]:
            shear[c] = 1
        else:
            shear[c] = 0


def _same_pieces(ps, bound, normal, shear, other_normal, other_shear):
    """:meth:`~dda.contact.potential.ContactTerms.same_pieces`."""
    for c in range(normal.shape[0]):
        if normal[c] != other_normal[c]:
            return False
        if ps[c] > 0.0 and bound[c] > 0.0 and shear[c] != other_shear[c]:
            return False
    return True


def _springs(p, ps, friction, normal, shear, kn, ks):
    """The springs of the pieces into ``kn``, ``ks``: p on the elastic normal piece,
    ps on the stuck shear piece (with friction), else 0."""
    for c in range(normal.shape[0]):
        kn[c] = p[c] if normal[c] == 1 else 0.0
        ks[c] = ps[c] if shear[c] == 0 and friction else 0.0


def _same_springs(kn, ks, springs):
    """True when (kn, ks) are the springs of the kept factorisation (``springs`` (2, m))."""
    for c in range(kn.shape[0]):
        if kn[c] != springs[0, c] or ks[c] != springs[1, c]:
            return False
    return True


def _offsets(lam_n, p, tension, lam_t, ps, bound, g0, s0, normal, shear):
    """(N₀, T₀) of the pieces: λn + p g₀ on the elastic normal piece, −T off it;
    λt + ps s₀ stuck, ±b sliding."""
    m = normal.shape[0]
    offset_n, offset_t = np.empty(m), np.empty(m)
    for c in range(m):
        if normal[c] == 1:
            offset_n[c] = lam_n[c] + p[c] * g0[c]
        else:
            offset_n[c] = -tension[c]
        if shear[c] == 0:
            offset_t[c] = lam_t[c] + ps[c] * s0[c]
        else:
            offset_t[c] = shear[c] * bound[c]
    return offset_n, offset_t


def _add_springs(k, columns, normal, kn, shear, ks):
    """K += Σ kn r_n r_nᵀ + ks r_s r_sᵀ over the contacts' 12 columns (−1: a fixed
    block's, left out)."""
    for c in range(columns.shape[0]):
        for a in range(12):
            row = columns[c, a]
            if row < 0:
                continue
            an, as_ = kn[c] * normal[c, a], ks[c] * shear[c, a]
            for b in range(12):
                col = columns[c, b]
                if col >= 0:
                    k[row, col] += an * normal[c, b] + as_ * shear[c, b]


def _factorise(base, columns, normal_rows, shear_rows, kn, ks, lower):
    """``lower`` = L of K = K₀ + Σ kn r_n r_nᵀ + ks r_s r_sᵀ = L Lᵀ (raises if K is not
    positive definite by LAPACK's test)."""
    k = base.copy()
    _add_springs(k, columns, normal_rows, kn, shear_rows, ks)
    lower[:, :] = np.linalg.cholesky(k)


def _cholesky_solve(lower, rhs):
    """x with L Lᵀ x = rhs (forward, then backward substitution)."""
    n = rhs.shape[0]
    y = np.empty(n)
    for i in range(n):
        total = rhs[i]
        for j in range(i):
            total -= lower[i, j] * y[j]
        y[i] = total / lower[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        total = y[i]
        for j in range(i + 1, n):
            total -= lower[j, i] * x[j]
        x[i] = total / lower[i, i]
    return x


def _residual(
    base, forces, normal_matrix, shear_matrix, lam_n, p, tension, lam_t, ps, bound, kd, g, s
):
    """(∇Π, ‖K₀D‖ + ‖contact forces‖ + ‖F₀‖) at the point whose K₀D, g, s are given."""
    m = g.shape[0]
    normal_force, shear_force = np.empty(m), np.empty(m)
    for c in range(m):
        normal_force[c] = max(lam_n[c] + p[c] * g[c], -tension[c])
        shear_force[c] = min(max(lam_t[c] + ps[c] * s[c], -bound[c]), bound[c])
    contact = normal_force @ normal_matrix + shear_force @ shear_matrix
    residual = kd - forces + contact
    scale = np.linalg.norm(kd) + np.linalg.norm(contact) + np.linalg.norm(forces)
    return residual, scale


def _dense_minimise(
    base, forces, normal_matrix, shear_matrix, columns, normal_rows, shear_rows,
    g0, s0, lam_n, p, tension, lam_t, ps, bound, friction,
    d, g, s, first_normal, first_shear, have_first,
    max_solves, max_steps, rate, chord_first, conjugate,
    lower, springs, state,
):  # fmt: skip
    """Compiled :func:`dda.solve.newton.minimise` on dense systems (module docstring).

    ``d``, ``g``, ``s``: the start and its gaps (copied, not changed); ``lower``,
    ``springs`` (2, m), ``state``: the kept factorisation, the springs of its K and
    :data:`HAS_FACTOR` / :data:`FACTORISATIONS` (updated in place). ``max_steps`` < 0:
    no limit. Returns (D, g, s, Newton iterations, chord steps, converged, chord_next,
    finite).
    """
    m, n = g.shape[0], d.shape[0]
    d, g, s = d.copy(), g.copy(), s.copy()
    kd = base @ d
    normal, shear = np.empty(m, np.int8), np.empty(m, np.int8)
    other_normal, other_shear = np.empty(m, np.int8), np.empty(m, np.int8)
    have_pieces = have_first
    if have_first:
        normal[:] = first_normal
        shear[:] = first_shear
    gradient = np.zeros(n)
    have_gradient = False
    if chord_first:
        gradient, _ = _residual(
            base, forces, normal_matrix, shear_matrix, lam_n, p, tension, lam_t, ps, bound,
            kd, g, s,
        )  # fmt: skip
        have_gradient = True
    solves = chords = 0
    last_direction, last_gradient, last_preconditioned = np.zeros(n), np.zeros(n), np.zeros(n)
    have_last = False
    kn, ks = np.empty(m), np.empty(m)
    while solves < max_solves and (max_steps < 0 or solves + chords < max_steps):
        if have_gradient and state[HAS_FACTOR] == 1:
            preconditioned = _cholesky_solve(lower, gradient)
            direction = -preconditioned
            chords += 1
            if conjugate and have_last:
                scale = last_preconditioned @ last_gradient
                if scale > 0.0:
                    beta = max(0.0, (preconditioned @ (gradient - last_gradient)) / scale)
                    conjugated = direction + beta * last_direction
                    if gradient @ conjugated < 0.0:
                        direction = conjugated
            last_direction, last_gradient = direction, gradient
            last_preconditioned, have_last = preconditioned, True
            dg, ds = normal_matrix @ direction, shear_matrix @ direction
        else:
            have_last = False
            solves += 1
            if not have_pieces:
                _pieces(lam_n, p, tension, lam_t, ps, bound, g, s, normal, shear)
            _springs(p, ps, friction, normal, shear, kn, ks)
            if not (state[HAS_FACTOR] == 1 and _same_springs(kn, ks, springs)):
                state[HAS_FACTOR] = 0
                _factorise(base, columns, normal_rows, shear_rows, kn, ks, lower)
                springs[0, :] = kn
                springs[1, :] = ks
                state[HAS_FACTOR] = 1
                state[FACTORISATIONS] += 1
            offset_n, offset_t = _offsets(
                lam_n, p, tension, lam_t, ps, bound, g0, s0, normal, shear
            )
            rhs = forces - offset_n @ normal_matrix - offset_t @ shear_matrix
            target = _cholesky_solve(lower, rhs)
            if not np.all(np.isfinite(target)):
                return target, g, s, solves, chords, False, False, False
            g_target = g0 + normal_matrix @ target
            s_target = s0 + shear_matrix @ target
            _pieces(
                lam_n, p, tension, lam_t, ps, bound, g_target, s_target, other_normal, other_shear
            )
            if _same_pieces(ps, bound, normal, shear, other_normal, other_shear):
                return target, g_target, s_target, solves, chords, True, False, True
            direction = target - d
            have_pieces = False
            dg, ds = g_target - g, s_target - s
        kp = base @ direction
        a = direction @ (kd - forces)
        curvature = direction @ kp
        alpha, _ = _line_minimum_kernel(
            lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, a, curvature
        )
        d = d + alpha * direction
        g = g + alpha * dg
        s = s + alpha * ds
        kd = kd + alpha * kp
        residual, scale = _residual(
            base, forces, normal_matrix, shear_matrix, lam_n, p, tension, lam_t, ps, bound,
            kd, g, s,
        )  # fmt: skip
        size = np.linalg.norm(residual)
        if size <= RELATIVE_TOLERANCE * scale:
            return d, g, s, solves, chords, True, False, True
        shrunk = (not have_gradient) or size <= rate * np.linalg.norm(gradient)
        if shrunk:
            gradient, have_gradient = residual, True
        else:
            have_gradient = False
    return d, g, s, solves, chords, False, have_gradient, True


def _potential(
    base, forces, normal_matrix, shear_matrix, g0, s0, lam_n, p, tension, lam_t, ps, bound, d
):
    """Π(D) = ½ DᵀK₀D − F₀ᵀD + Σ φn(g) + Σ φt(s) (:func:`dda.solve.newton.potential`; φn,
    φt of :meth:`dda.contact.potential.ContactTerms.energy`)."""
    value = d @ (0.5 * (base @ d) - forces)
    g, s = g0 + normal_matrix @ d, s0 + shear_matrix @ d
    return _add_contact_energy(value, lam_n, p, tension, lam_t, ps, bound, g, s)


def _add_contact_energy(value, lam_n, p, tension, lam_t, ps, bound, g, s):
    """``value`` + Σ φn(g) + Σ φt(s), added contact by contact."""
    for c in range(g.shape[0]):
        trial = lam_n[c] + p[c] * g[c]
        force = max(trial, -tension[c])
        value += (force * force - lam_n[c] * lam_n[c]) / (2.0 * p[c])
        if trial < -tension[c]:
            value -= tension[c] * (trial + tension[c]) / p[c]
        if ps[c] > 0.0:
            shear_trial = lam_t[c] + ps[c] * s[c]
            friction = min(max(shear_trial, -bound[c]), bound[c])
            excess = max(abs(shear_trial) - bound[c], 0.0)
            value += (friction * friction - lam_t[c] * lam_t[c]) / (2.0 * ps[c])
            value += bound[c] * excess / ps[c]
    return value


add_springs_kernel = kernel(_add_springs)  # also the dense systems' own assembly
_add_springs = add_springs_kernel or _add_springs  # the compiled kernels call compiled twins
_pieces = kernel(_pieces) or _pieces
_same_pieces = kernel(_same_pieces) or _same_pieces
_springs = kernel(_springs) or _springs
_same_springs = kernel(_same_springs) or _same_springs
_offsets = kernel(_offsets) or _offsets
_add_contact_energy = kernel(_add_contact_energy) or _add_contact_energy
_factorise = kernel(_factorise) or _factorise
_cholesky_solve = kernel(_cholesky_solve) or _cholesky_solve
_residual = kernel(_residual) or _residual
dense_minimise_kernel = kernel(_dense_minimise)
potential_kernel = kernel(_potential)
