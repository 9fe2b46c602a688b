"""One line step of the Newton minimisation on the sparse systems, in one compiled call.

After each linear solve (a Newton iteration's target or a chord step's
back-substitution) :func:`dda.solve.newton.minimise` goes along the direction
ΔD to the exact minimum of Π on that line and measures the new gradient:

    ∇g·ΔD, ∇s·ΔD (eqs. 9-13),   K₀ΔD,   a = ΔDᵀ(K₀D − F₀),   c = ΔDᵀK₀ΔD,
    α = argmin Π(D + α ΔD) (:func:`dda.contact.line_search.line_minimum`),
    D, g, s, K₀D += α (ΔD, ∇g·ΔD, ∇s·ΔD, K₀ΔD),
    ∇Π = K₀D − F₀ + Σ N(g)∇g + Σ F(s)∇s on the free blocks,
    ‖∇Π‖ and the scale ‖K₀D‖ + ‖Σ N∇g + Σ F∇s‖ + ‖F₀‖ it is measured against.

In numpy that is about 40 calls, each over all blocks or contacts; on models
of tens to thousands of blocks those calls, not the arithmetic, cost most of
a step's time outside the solver. :func:`line_step_kernel` does it in one
call, with the compiled kernels the numpy path calls one by one: the gaps of
:mod:`dda.contact.rows` (for the rates), the force sum of
:mod:`dda.solve.assembly` and the line search. It is used when the kernels are and K₀
is block-diagonal (no rock bolts); the numpy lines in
:func:`dda.solve.newton.minimise` are its oracle (tests/solve/test_line_step.py).
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import normal_force, shear_force
from dda.contact.line_search import _line_minimum_kernel
from dda.contact.rows import _gaps_kernel
from dda.jit import kernel
from dda.solve.assembly import _subtract_pairs_kernel


def _line_step(
    stiffness, forces, free, normal_i, normal_j, shear_i, shear_j, block_a, block_b,
    lam_n, p, tension, lam_t, ps, bound, load_norm,
    d, g, s, kd, direction, dg, ds, have_rates,
):  # fmt: skip
    """The line step of the module docstring from (D, g, s, K₀D) along ``direction``;
    ``dg``, ``ds``: ∇g·ΔD, ∇s·ΔD when ``have_rates`` (else computed here).

    Returns (D, g, s, K₀D, ∇Π, ‖∇Π‖, scale, α) — new arrays, the inputs unchanged.
    """
    n, m = d.shape[0], g.shape[0]
    if not have_rates:  # the gaps' linear part along the direction: gaps from zero
        dg, ds = _gaps_kernel(
            np.zeros(m), np.zeros(m), normal_i, normal_j, shear_i, shear_j, block_a, block_b,
            direction,
        )  # fmt: skip
    kp = np.empty((n, 6))
    slope = curvature = 0.0
    for i in range(n):
        for r in range(6):
            total = 0.0
            for q in range(6):
                total += stiffness[i, r, q] * direction[i, q]
            kp[i, r] = total
            slope += direction[i, r] * (kd[i, r] - forces[i, r])
            curvature += direction[i, r] * total
    alpha, _ = _line_minimum_kernel(
        lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, slope, curvature
    )
    d_new, kd_new = d + alpha * direction, kd + alpha * kp
    g_new, s_new = g + alpha * dg, s + alpha * ds
    minus_normal, minus_shear = np.empty(m), np.empty(m)  # −N(g), −F(s)
    for c in range(m):
        minus_normal[c] = -normal_force(lam_n[c], p[c], tension[c], g_new[c])
        minus_shear[c] = -shear_force(lam_t[c], ps[c], bound[c], s_new[c])
    contact = np.zeros((n, 6))  # Σ N∇g + Σ F∇s: the force sum with −N, −F subtracted
    _subtract_pairs_kernel(
        contact, block_a, block_b, normal_i, normal_j, shear_i, shear_j, minus_normal, minus_shear
    )
    residual = np.zeros((n, 6))
    size = kd_size = contact_size = 0.0
    for i in range(n):
        if not free[i]:
            continue
        for r in range(6):
            residual[i, r] = kd_new[i, r] - forces[i, r] + contact[i, r]
            size += residual[i, r] * residual[i, r]
            kd_size += kd_new[i, r] * kd_new[i, r]
            contact_size += contact[i, r] * contact[i, r]
    scale = np.sqrt(kd_size) + np.sqrt(contact_size) + load_norm
    return d_new, g_new, s_new, kd_new, residual, np.sqrt(size), scale, alpha


line_step_kernel = kernel(_line_step)
