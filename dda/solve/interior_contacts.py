"""The interior point's contact-by-contact algebra (:mod:`dda.solve.interior_point`): the
springs of an iteration's matrix, the contacts' part of its right-hand side, the
contact unknowns' direction from the blocks' and the longest step that keeps them
positive.

Each is a :func:`dda.jit.formula` of one contact's numbers: numpy calls it on arrays,
the kernels below compile it into a loop over the contacts with the sparse products by
the gap gradients ∇g, ∇s (CSR rows, one per contact) beside it, so that an iteration's
work outside the LU is two compiled calls a direction. Notation (the module docstring
of :mod:`dda.solve.interior_point`): N' (``lift``), w (``spare``), u, v, σ₁, σ₂ the
contact unknowns, p, ps the springs, b'(N) the bound's slope (``slope``), the residuals
r_N = y + w − N', r_F = z − u + v − F, r₁ = b − F − σ₁, r₂ = b + F − σ₂, the products'
target μ_t and their terms beyond the linear ones c_N, c_u, c_v.
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import normal_trial, shear_trial
from dda.jit import formula, kernel, select

# the rows of the contacts' unknowns (``state``) and of a direction
LIFT, SPARE, SHEAR, SLIP_FORWARD, SLIP_BACK, ROOM_FORWARD, ROOM_BACK = range(7)
UNKNOWNS = 7


@formula
def springs(lift, spare, u, v, r1, r2, slope, penalty, shear_penalty, live):
    """(kn, ks, k_sn, q) of a contact: kn = p N' / (N' + w), q = 1 + u/σ₁ + v/σ₂,
    ks = ps / q, k_sn = b'(N) (u/σ₁ − v/σ₂) / q (ks = k_sn = 0, q = 1 where not live)."""
    kn = penalty * lift / (lift + spare)
    q = select(live, 1.0 + u / r1 + v / r2, 1.0)
    ks = select(live, shear_penalty / q, 0.0)
    k_sn = select(live, slope * (u / r1 - v / r2) / q, 0.0)
    return kn, ks, k_sn, q


@formula
def free_terms(lift, spare, u, v, r1, r2, q, res_n, res_s, res_1, res_2, target, c_n, c_u, c_v,
               live):  # fmt: skip
    """(ΔN', ΔF) of a contact at Δg = Δs = 0 (its unknowns eliminated, the rest of their
    direction kn Δg and ks Δs + k_sn ΔN'):
    ΔN'₀ = (N' r_N + μ_t − N'w − c_N) / (N' + w),
    ΔF₀ = (r_F − a + c) / q,
    a = (μ_t − uσ₁ − c_u − u r₁) / σ₁, c = (μ_t − vσ₂ − c_v − v r₂) / σ₂."""
    n_free = (lift * res_n + target - lift * spare - c_n) / (lift + spare)
    forward = (target - u * r1 - c_u - u * res_1) / r1
    back = (target - v * r2 - c_v - v * res_2) / r2
    f_free = select(live, (res_s - forward + back) / q, 0.0)
    return n_free, f_free


@formula
def contact_direction(dg, ds, lift, spare, u, v, r1, r2, kn, ks, k_sn, slope, penalty,
                      shear_penalty, n_free, f_free, res_n, res_s, res_1, res_2, target,
                      c_u, c_v, live):  # fmt: skip
    """(ΔN', Δw, ΔF, Δu, Δv, Δσ₁, Δσ₂) of a contact from its gaps' changes Δg, Δs:
    ΔN' = kn Δg + ΔN'₀, ΔF = ks Δs + k_sn ΔN' + ΔF₀, Δσ₁,₂ = b' ΔN' ∓ ΔF + r₁,₂,
    Δw = ΔN' − p Δg − r_N; u and v from their complementarity, but the one of a
    sliding contact (u/σ₁ or v/σ₂ the larger) from the shear equation, which it then
    keeps to round-off (its complementarity holds in exact arithmetic either way)."""
    d_lift = kn * dg + n_free
    d_shear = select(live, ks * ds + k_sn * d_lift + f_free, 0.0)
    d_r1 = select(live, slope * d_lift - d_shear + res_1, 0.0)
    d_r2 = select(live, slope * d_lift + d_shear + res_2, 0.0)
    d_forward = (target - u * r1 - c_u - u * d_r1) / r1
    d_back = (target - v * r2 - c_v - v * d_r2) / r2
    forward_slides = u / r1 >= v / r2
    d_forward = select(forward_slides, shear_penalty * ds + d_back + res_s - d_shear, d_forward)
    d_back = select(forward_slides, d_back, d_shear - shear_penalty * ds + d_forward - res_s)
    d_spare = d_lift - penalty * dg - res_n
    return (d_lift, d_spare, d_shear, select(live, d_forward, 0.0), select(live, d_back, 0.0),
            d_r1, d_r2)  # fmt: skip


@formula
def room(value, change):
    """The step to the bound 0 of an unknown ``value`` that moves by ``change`` a unit
    step: −value / change where it falls, else infinite."""
    return select(change < 0.0, -value / select(change < 0.0, change, -1.0), np.inf)


def _rhs(equilibrium, rows, state, spring_values, residual, target, second, live):
    """(−r_eq − Σ ΔN'₀ ∇g − Σ (ΔF₀ + k_sn ΔN'₀) ∇s, ΔN'₀, ΔF₀) contact by contact
    (:func:`free_terms`; ``rows``: ∇g and ∇s, the contacts' CSR rows (indptr, indices,
    data) of each; ``state`` (7, m), ``spring_values`` (4, m), ``residual`` (5, m),
    ``second`` (3, m): the module docstring's rows), each sum in numpy's order
    (scipy's product by the transposed rows adds the contacts in turn): the same numbers."""
    n_indptr, n_indices, n_data, s_indptr, s_indices, s_data = rows
    m, size = state.shape[1], equilibrium.shape[0]
    normal_part, shear_part = np.zeros(size), np.zeros(size)
    n_free, f_free = np.empty(m), np.empty(m)
    for c in range(m):  # contact by contact, each unknown's sums in contact order
        n_free[c], f_free[c] = free_terms(
            state[LIFT, c], state[SPARE, c], state[SLIP_FORWARD, c], state[SLIP_BACK, c],
            state[ROOM_FORWARD, c], state[ROOM_BACK, c], spring_values[3, c],
            residual[0, c], residual[1, c], residual[2, c], residual[3, c], target,
            second[0, c], second[1, c], second[2, c], live[c],
        )  # fmt: skip
        for k in range(n_indptr[c], n_indptr[c + 1]):
            normal_part[n_indices[k]] += n_data[k] * n_free[c]
        shear_force = f_free[c] + spring_values[2, c] * n_free[c]
        for k in range(s_indptr[c], s_indptr[c + 1]):
            shear_part[s_indices[k]] += s_data[k] * shear_force
    rhs = np.empty(size)
    for k in range(size):
        rhs[k] = -equilibrium[k] - normal_part[k] - shear_part[k]
    return rhs, n_free, f_free


def _direction(dx, rows, state, spring_values, residual, penalty, shear_penalty, n_free,
               f_free, target, second, live):  # fmt: skip
    """(the contact unknowns' direction (7, m), the largest step that keeps them positive
    (:func:`room`, infinite when none falls)) from the blocks' Δx by way of the gaps'
    changes Δg, Δs (``rows`` and the stacked arguments: as :func:`_rhs`'s)."""
    n_indptr, n_indices, n_data, s_indptr, s_indices, s_data = rows
    m = state.shape[1]
    out = np.empty((UNKNOWNS, m))
    limit = np.inf
    for c in range(m):
        dg = ds = 0.0
        for k in range(n_indptr[c], n_indptr[c + 1]):
            dg += n_data[k] * dx[n_indices[k]]
        for k in range(s_indptr[c], s_indptr[c + 1]):
            ds += s_data[k] * dx[s_indices[k]]
        changes = contact_direction(
            dg, ds, state[LIFT, c], state[SPARE, c], state[SLIP_FORWARD, c],
            state[SLIP_BACK, c], state[ROOM_FORWARD, c], state[ROOM_BACK, c],
            spring_values[0, c], spring_values[1, c], spring_values[2, c], residual[4, c],
            penalty[c], shear_penalty[c], n_free[c], f_free[c], residual[0, c],
            residual[1, c], residual[2, c], residual[3, c], target, second[1, c],
            second[2, c], live[c],
        )  # fmt: skip
        for j in range(UNKNOWNS):
            out[j, c] = changes[j]
        limit = min(limit, room(state[LIFT, c], changes[0]), room(state[SPARE, c], changes[1]))
        if live[c]:
            for j in range(SLIP_FORWARD, UNKNOWNS):
                limit = min(limit, room(state[j, c], changes[j]))
    return out, limit


rhs_kernel = kernel(_rhs)
direction_kernel = kernel(_direction)


@formula
def contact_residuals(lift, spare, shear, u, v, r1, r2, y, z, bound, bound_after, step, live):
    """(r_N, r_F, r₁, r₂, b'(N)) of a contact: r_N = y + w − N', r_F = z − u + v − F,
    r₁ = b − F − σ₁, r₂ = b + F − σ₂ and b'(N) ≈ (b(N + h) − b(N)) / h (``bound_after``
    at N + ``step``); 0 but r_N where not live. y = λn + p g + T, z = λt + ps s."""
    return (
        y + spare - lift,
        select(live, z - u + v - shear, 0.0),
        select(live, bound - shear - r1, 0.0),
        select(live, bound + shear - r2, 0.0),
        select(live, (bound_after - bound) / step, 0.0),
    )


def _residuals(state, g, s, terms, bound, bound_after, step, live):
    """(5, m): :func:`contact_residuals` of every contact, y and z from its gaps g, s and
    ``terms`` (5, m): λn, p, T, λt, ps."""
    m = state.shape[1]
    out = np.empty((5, m))
    for c in range(m):
        y = normal_trial(terms[0, c], terms[1, c], g[c]) + terms[2, c]
        z = shear_trial(terms[3, c], terms[4, c], s[c])
        values = contact_residuals(
            state[LIFT, c], state[SPARE, c], state[SHEAR, c], state[SLIP_FORWARD, c],
            state[SLIP_BACK, c], state[ROOM_FORWARD, c], state[ROOM_BACK, c], y, z, bound[c],
            bound_after[c], step[c], live[c],
        )  # fmt: skip
        for j in range(5):
            out[j, c] = values[j]
    return out


residuals_kernel = kernel(_residuals)


@formula
def product_after(value, change, other, other_change, alpha):
    """A complementarity product after ``alpha`` × the step: (x + α Δx)(y + α Δy)."""
    return (value + alpha * change) * (other + alpha * other_change)


@formula
def centring_push(product, target):
    """Gondzio's push of a product towards [0.1, 10] μ_t: its distance to that band
    (negative above it), at most 10 μ_t down."""
    bounded = np.minimum(np.maximum(product, 0.1 * target), 10.0 * target)
    return np.maximum(bounded - product, -10.0 * target)


def _springs(state, slope, penalty, shear_penalty, live):
    """(4, m): :func:`springs` (kn, ks, k_sn, q) of every contact."""
    m = state.shape[1]
    out = np.empty((4, m))
    for c in range(m):
        values = springs(
            state[LIFT, c], state[SPARE, c], state[SLIP_FORWARD, c], state[SLIP_BACK, c],
            state[ROOM_FORWARD, c], state[ROOM_BACK, c], slope[c], penalty[c],
            shear_penalty[c], live[c],
        )  # fmt: skip
        for j in range(4):
            out[j, c] = values[j]
    return out


springs_kernel = kernel(_springs)


@formula
def moved_value(value, change, alpha, moved):
    """x + α Δx where ``moved``, else x itself (an infinite x stays infinite: 0 × inf is
    not 0)."""
    return value + alpha * change if moved else value


def _mean_product(state, step, alpha, moved, live):
    """μ: the mean of N'w over the contacts and of u σ₁, v σ₂ over the live ones, at the
    iterate, or after ``alpha`` × ``step`` where ``moved`` (:func:`product_after`), each
    sum BLAS's dot of the factors, as numpy's ``@`` makes it."""
    m = state.shape[1]
    live_count = 0
    for c in range(m):
        if live[c]:
            live_count += 1
    lift, spare = np.empty(m), np.empty(m)
    u, r1 = np.empty(live_count), np.empty(live_count)
    v, r2 = np.empty(live_count), np.empty(live_count)
    k = 0
    for c in range(m):
        lift[c] = moved_value(state[LIFT, c], step[LIFT, c], alpha, moved)
        spare[c] = moved_value(state[SPARE, c], step[SPARE, c], alpha, moved)
        if live[c]:
            u[k] = moved_value(state[SLIP_FORWARD, c], step[SLIP_FORWARD, c], alpha, moved)
            r1[k] = moved_value(state[ROOM_FORWARD, c], step[ROOM_FORWARD, c], alpha, moved)
            v[k] = moved_value(state[SLIP_BACK, c], step[SLIP_BACK, c], alpha, moved)
            r2[k] = moved_value(state[ROOM_BACK, c], step[ROOM_BACK, c], alpha, moved)
            k += 1
    total = np.dot(lift, spare) + np.dot(u, r1) + np.dot(v, r2)
    return total / max(1, m + 2 * live_count)


mean_product_kernel = kernel(_mean_product)


def _centring(state, step, aim, target, second, live):
    """(3, m) the products' terms beyond the linear ones, ``second`` less Gondzio's push
    (:func:`centring_push`) of N'w, u σ₁, v σ₂ after ``aim`` × ``step`` (0 where not
    live)."""
    m = state.shape[1]
    out = np.empty((3, m))
    for c in range(m):
        trial = product_after(state[LIFT, c], step[LIFT, c], state[SPARE, c], step[SPARE, c], aim)
        out[0, c] = second[0, c] - centring_push(trial, target)
        forward = back = 0.0
        if live[c]:
            forward = product_after(state[SLIP_FORWARD, c], step[SLIP_FORWARD, c],
                                    state[ROOM_FORWARD, c], step[ROOM_FORWARD, c], aim)  # fmt: skip
            back = product_after(state[SLIP_BACK, c], step[SLIP_BACK, c],
                                 state[ROOM_BACK, c], step[ROOM_BACK, c], aim)  # fmt: skip
        out[1, c] = second[1, c] - centring_push(forward, target)
        out[2, c] = second[2, c] - centring_push(back, target)
    return out


centring_kernel = kernel(_centring)


def _advance(x, g, s, state, rows, dx, step, alpha):
    """Move the iterate by ``alpha`` × the step, in place: x + α Δx, the gaps g + ∇g·(α Δx)
    and s + ∇s·(α Δx) (sums in scipy's order), the contact unknowns + α × ``step``."""
    n_indptr, n_indices, n_data, s_indptr, s_indices, s_data = rows
    scaled = np.empty(x.shape[0])
    for k in range(x.shape[0]):
        scaled[k] = alpha * dx[k]
        x[k] = x[k] + scaled[k]
    for c in range(g.shape[0]):
        dg = ds = 0.0
        for k in range(n_indptr[c], n_indptr[c + 1]):
            dg += n_data[k] * scaled[n_indices[k]]
        for k in range(s_indptr[c], s_indptr[c + 1]):
            ds += s_data[k] * scaled[s_indices[k]]
        g[c] = g[c] + dg
        s[c] = s[c] + ds
        for j in range(UNKNOWNS):
            state[j, c] = state[j, c] + alpha * step[j, c]


advance_kernel = kernel(_advance)


def _matrix_values(base, where, normal, shear, kn, ks, coupling):
    """The matrix's values: ``base`` + Σ kn ∇g∇gᵀ + Σ ks ∇s∇sᵀ + Σ k_sn kn ∇s∇gᵀ
    (``coupling`` = k_sn kn), each contact's three 12 × 12 terms added in one pass at the
    values ``where`` (−1: a fixed block's unknown), contact by contact and at each value
    its ∇g∇gᵀ term, then its ∇s∇sᵀ, then its ∇s∇gᵀ: the order of numpy's product by the
    fill matrix of :class:`dda.solve.interior_point.NewtonMatrix` (the same numbers)."""
    values = np.zeros(base.shape[0])
    for c in range(where.shape[0]):
        normal_spring, shear_spring, coupled = kn[c], ks[c], coupling[c]
        for i in range(12):
            normal_i, shear_i = normal[c, i], shear[c, i]
            for j in range(12):
                e = where[c, i, j]
                if e >= 0:
                    values[e] += normal_i * normal[c, j] * normal_spring
                    values[e] += shear_i * shear[c, j] * shear_spring
                    values[e] += shear_i * normal[c, j] * coupled
    out = np.empty(base.shape[0])
    for e in range(base.shape[0]):
        out[e] = base[e] + values[e]
    return out


matrix_values_kernel = kernel(_matrix_values)
