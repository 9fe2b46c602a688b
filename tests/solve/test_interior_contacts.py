"""The interior point's contact-by-contact kernels (dda/solve/interior_contacts.py) against
the same formulas run by numpy on the arrays: equal to the bit, on random contacts, some
not live (no friction), and on none."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from dda import jit
from dda.solve import interior_contacts as ic
from dda.solve.interior_contacts import LIFT, SHEAR, SPARE, UNKNOWNS

pytestmark = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")

SIZES = [0, 1, 37]


def _contacts(m: int, seed: int = 0):
    """A random iterate of ``m`` contacts: its unknowns (positive but F), a direction, the
    live contacts, the gaps' CSR rows over 30 unknowns."""
    rng = np.random.default_rng(seed + m)
    state = rng.uniform(0.1, 10.0, (UNKNOWNS, m))
    state[SHEAR] = rng.uniform(-5.0, 5.0, m)
    step = rng.normal(0.0, 3.0, (UNKNOWNS, m))
    live = rng.random(m) < 0.7
    gn = sp.random(m, 30, density=0.3, format="csr", random_state=seed + 1)
    gs = sp.random(m, 30, density=0.3, format="csr", random_state=seed + 2)
    return rng, state, step, live, gn, gs


def _rows(gn, gs):
    return (gn.indptr, gn.indices, gn.data, gs.indptr, gs.indices, gs.data)


@pytest.mark.parametrize("m", SIZES)
def test_the_springs_kernel_is_the_formula(m):
    rng, state, _, live, _, _ = _contacts(m)
    slope, penalty, shear_penalty = (rng.uniform(0.1, 2.0, m) for _ in range(3))
    kernel = ic.springs_kernel(state, slope, penalty, shear_penalty, live)
    lift, spare, _, u, v, r1, r2 = state
    numpy = np.array(ic.springs(lift, spare, u, v, r1, r2, slope, penalty, shear_penalty, live))
    assert np.array_equal(kernel, numpy.reshape(4, m))


@pytest.mark.parametrize("m", SIZES)
def test_the_residuals_kernel_is_the_formula(m):
    rng, state, _, live, _, _ = _contacts(m)
    g, s = rng.normal(0.0, 1e-3, m), rng.normal(0.0, 1e-3, m)
    terms = rng.uniform(0.0, 5.0, (5, m))  # λn, p, T, λt, ps
    bound, after, step = rng.uniform(1.0, 3.0, m), rng.uniform(1.0, 3.0, m), rng.random(m)
    kernel = ic.residuals_kernel(state, g, s, terms, bound, after, step, live)
    y = ic.normal_trial(terms[0], terms[1], g) + terms[2]
    z = ic.shear_trial(terms[3], terms[4], s)
    lift, spare, shear, u, v, r1, r2 = state
    numpy = ic.contact_residuals(lift, spare, shear, u, v, r1, r2, y, z, bound, after, step, live)
    assert np.array_equal(kernel, np.array(numpy).reshape(5, m))


@pytest.mark.parametrize("m", SIZES)
def test_the_centring_kernel_is_gondzios_push(m):
    """``second`` less the push of N'w, u σ₁, v σ₂ (0 where not live) into [0.1, 10] μ_t,
    numpy's np.clip form."""
    rng, state, step, live, _, _ = _contacts(m)
    second, aim, target = rng.normal(0.0, 1.0, (3, m)), 0.7, 4.0
    kernel = ic.centring_kernel(state, step, aim, target, second, live)
    after = state + aim * step
    trial = np.array([
        after[LIFT] * after[SPARE],
        np.where(live, after[ic.SLIP_FORWARD] * after[ic.ROOM_FORWARD], 0.0),
        np.where(live, after[ic.SLIP_BACK] * after[ic.ROOM_BACK], 0.0),
    ])  # fmt: skip
    bounded = np.clip(trial, 0.1 * target, 10.0 * target)
    assert np.array_equal(kernel, second - np.maximum(bounded - trial, -10.0 * target))


@pytest.mark.parametrize("m", SIZES)
@pytest.mark.parametrize("moved", [False, True])
def test_mu_is_numpys_mean_of_the_products(m, moved):
    """The mean of N'w and, over the live contacts, u σ₁ and v σ₂: numpy's dot products."""
    _, state, step, live, _, _ = _contacts(m)
    alpha = 0.3
    kernel = ic.mean_product_kernel(state, step, alpha, moved, live)
    after = state + alpha * step if moved else state
    lift, spare, _, u, v, r1, r2 = after
    total = float(lift @ spare) + float(u[live] @ r1[live]) + float(v[live] @ r2[live])
    assert kernel == total / max(1, m + 2 * int(live.sum()))


def test_mu_at_an_iterate_with_an_infinite_unknown_is_infinite():
    """Not NaN (0 × inf): a μ that is NaN would pass the convergence test's μ bound."""
    _, state, step, live, _, _ = _contacts(5)
    state[SPARE, 2] = np.inf
    assert ic.mean_product_kernel(state, step, 0.0, False, live) == np.inf


@pytest.mark.parametrize("m", SIZES)
def test_the_move_is_numpys(m):
    """x + α Δx, the gaps g + ∇g·(α Δx), s + ∇s·(α Δx) in scipy's order, the unknowns
    + α × the step: in place."""
    rng, state, step, _, gn, gs = _contacts(m)
    x, dx, alpha = rng.normal(0.0, 1.0, 30), rng.normal(0.0, 1.0, 30), 0.45
    g, s = rng.normal(0.0, 1.0, m), rng.normal(0.0, 1.0, m)
    expected = (x + alpha * dx, g + gn @ (alpha * dx), s + gs @ (alpha * dx), state + alpha * step)
    ic.advance_kernel(x, g, s, state, _rows(gn, gs), dx, step, alpha)
    for moved, numpy in zip((x, g, s, state), expected, strict=True):
        assert np.array_equal(moved, numpy)
