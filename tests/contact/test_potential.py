"""The contact terms of the step's potential and the exact line search on them.

Independent checks: the forces are the derivatives of the energy (central
differences), the energy is convex along any line (second differences), and
the line search finds the minimiser a fine brute-force scan finds.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dda import jit
from dda.contact.law import UNBOUNDED
from dda.contact.line_search import _normal_breaks, _shear_breaks, line_minimum
from dda.contact.potential import (
    NORMAL_ELASTIC,
    NORMAL_LIMIT,
    SLIP_BACK,
    SLIP_FORWARD,
    STICK,
    ContactTerms,
)


def random_terms(seed: int, m: int = 200) -> ContactTerms:
    """Contacts with and without multipliers, tension, friction and shear terms."""
    rng = np.random.default_rng(seed)
    penalty = rng.choice([1e6, 5e7, 1e9], m)
    tension = np.where(rng.random(m) < 0.3, rng.uniform(0, 50, m), 0.0)
    bound = np.where(rng.random(m) < 0.8, rng.uniform(0, 100, m), 0.0)
    shear_penalty = np.where(rng.random(m) < 0.8, 0.4 * penalty, 0.0)
    bound = np.where(shear_penalty > 0, bound, 0.0)  # no shear term: no friction either
    return ContactTerms(
        normal_base=np.maximum(rng.normal(0, 30, m), -tension),
        penalty=penalty,
        tension=tension,
        shear_base=np.clip(rng.normal(0, 50, m), -bound, bound),
        shear_penalty=shear_penalty,
        bound=bound,
    )


def points(terms: ContactTerms, seed: int):
    """(g, s) spread over every piece: trial forces of ±200 around zero."""
    rng = np.random.default_rng(seed)
    m = len(terms.penalty)
    return rng.uniform(-200, 200, m) / terms.penalty, rng.uniform(-200, 200, m) / (
        0.4 * terms.penalty
    )


def single(terms: ContactTerms, k: int) -> ContactTerms:
    return ContactTerms(*(getattr(terms, f)[k : k + 1] for f in terms.__dataclass_fields__))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_forces_are_the_derivatives_of_the_energy(seed):
    terms = random_terms(seed)
    g, s = points(terms, seed + 10)
    for k in range(len(g)):
        one = single(terms, k)
        h_n, h_t = 1e-6 / one.penalty[0], 1e-6 / max(one.shear_penalty[0], one.penalty[0])
        dn = (
            one.energy(g[k : k + 1] + h_n, s[k : k + 1])
            - one.energy(g[k : k + 1] - h_n, s[k : k + 1])
        ) / (2 * h_n)
        dt = (
            one.energy(g[k : k + 1], s[k : k + 1] + h_t)
            - one.energy(g[k : k + 1], s[k : k + 1] - h_t)
        ) / (2 * h_t)
        assert dn == pytest.approx(one.normal_force(g[k : k + 1])[0], abs=1e-5)
        expected_t = one.shear_force(s[k : k + 1])[0] if one.shear_penalty[0] > 0 else 0.0
        assert dt == pytest.approx(expected_t, abs=1e-5)


def test_the_energy_is_convex_along_any_line():
    terms = random_terms(3)
    g, s = points(terms, 4)
    rng = np.random.default_rng(5)
    dg, ds = rng.normal(0, 1, g.shape) / terms.penalty, rng.normal(0, 1, s.shape) / terms.penalty
    alphas = np.linspace(-300, 300, 601)
    values = np.array([terms.energy(g + a * dg, s + a * ds) for a in alphas])
    second = values[2:] - 2 * values[1:-1] + values[:-2]
    assert second.min() >= -1e-9 * np.abs(values).max()


def test_pieces_springs_and_offsets_give_back_the_forces():
    """On its own piece each contact's force is offset + spring × (∇·D): with g = g0 + δ."""
    terms = random_terms(6)
    g, s = points(terms, 7)
    g0, s0 = g - 1e-3 / terms.penalty, s - 1e-3 / terms.penalty  # the step start, nearby
    normal, shear = terms.pieces(g, s)
    kn, ks = terms.springs(normal, shear)
    offset_n, offset_t = terms.offsets(normal, shear, g0, s0)
    np.testing.assert_allclose(
        offset_n + kn * (g - g0), terms.normal_force(g), rtol=1e-9, atol=1e-9
    )
    live = terms.shear_penalty > 0
    np.testing.assert_allclose(
        (offset_t + ks * (s - s0))[live], terms.shear_force(s)[live], rtol=1e-9, atol=1e-9
    )
    assert set(np.unique(normal)) <= {NORMAL_LIMIT, NORMAL_ELASTIC}
    assert set(np.unique(shear)) <= {SLIP_BACK, STICK, SLIP_FORWARD}


def test_shear_pieces_of_contacts_without_a_shear_term_do_not_count():
    terms = random_terms(8, m=4)
    terms = ContactTerms(
        terms.normal_base, terms.penalty, terms.tension, np.zeros(4), np.zeros(4), np.zeros(4)
    )
    normal = np.full(4, NORMAL_ELASTIC, np.int8)
    assert terms.same_pieces(
        (normal, np.full(4, SLIP_BACK, np.int8)), (normal, np.full(4, SLIP_FORWARD, np.int8))
    )
    assert not terms.same_pieces(
        (normal, np.full(4, STICK, np.int8)), (np.full(4, NORMAL_LIMIT, np.int8), normal * 0)
    )


@pytest.mark.parametrize("seed", range(5))
def test_the_line_search_finds_the_minimum_along_the_line(seed):
    """π(α) = a α + c α²/2 + Σ φ(g + α δg, s + α δs): the breakpoint walk against a
    golden-section search on the (convex) function."""
    terms = random_terms(seed, m=50)
    g, s = points(terms, seed + 20)
    rng = np.random.default_rng(seed + 30)
    dg, ds = (
        rng.normal(0, 100, g.shape) / terms.penalty,
        rng.normal(0, 100, s.shape) / terms.penalty,
    )
    c = float(rng.uniform(1, 1e3))
    slope0 = float(np.dot(terms.normal_force(g), dg) + np.dot(terms.shear_force(s), ds))
    a = -slope0 - float(rng.uniform(1e2, 1e4))  # a descent direction

    def pi(alpha):
        return a * alpha + 0.5 * c * alpha**2 + terms.energy(g + alpha * dg, s + alpha * ds)

    def slope(alpha):  # π'(α), from the forces (the energy's derivatives, tested above)
        gn, sn = g + alpha * dg, s + alpha * ds
        return a + c * alpha + terms.normal_force(gn) @ dg + terms.shear_force(sn) @ ds

    alpha, _ = line_minimum(terms, a, c, g, dg, s, ds)
    scale = abs(a) + abs(slope0)
    assert abs(slope(alpha)) <= 1e-9 * scale  # the root of π'
    lo, hi = 0.0, 1e3
    ratio = (np.sqrt(5) - 1) / 2
    for _ in range(200):
        x1, x2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        lo, hi = (lo, x2) if pi(x1) < pi(x2) else (x1, hi)
    assert alpha == pytest.approx(0.5 * (lo + hi), rel=1e-4)  # golden section: ~√ε in α
    assert pi(alpha) <= pi(0.5 * (lo + hi)) + 1e-12 * abs(pi(alpha))


def test_no_descent_no_move():
    terms = random_terms(9, m=10)
    g, s = points(terms, 10)
    zero = np.zeros_like(g)
    assert line_minimum(terms, 1.0, 1.0, g, zero, s, zero) == (0.0, False)


def both_line_searches(terms, a, c, g, dg, s, ds):
    """(α, changed) of the kernel large runs use and of the numpy walk (the oracle)."""
    compiled = line_minimum(terms, a, c, g, dg, s, ds)
    with jit.run_work(1, 1):  # a small run: the numpy path
        oracle = line_minimum(terms, a, c, g, dg, s, ds)
    return compiled, oracle


@pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")
@pytest.mark.parametrize("m", [60, 3000])  # 3000: breakpoints halved around the root first
def test_the_compiled_line_search_is_the_numpy_one(m):
    """The same α (to rounding: sums and ties go in another order) and the same answer
    to "did a contact change piece", on lines whose root falls before, among and beyond
    the contacts' breakpoints, with bounds not known yet, zero curvature and zero rates."""
    outcomes = set()
    for seed in range(12):
        terms = random_terms(seed, m=m)
        if seed % 2:  # some bounds not known yet (contacts found this step)
            bound = np.where(np.arange(m) % 7 == 0, UNBOUNDED, terms.bound)
            terms = dataclasses.replace(terms, bound=bound)
        g, s = points(terms, seed + 20)
        rng = np.random.default_rng(seed + 30)
        # rates that move each contact by about its own force scale: p δg² ~ 1e2
        dg = rng.normal(0, 10, g.shape) / np.sqrt(terms.penalty)
        ds = np.where(rng.random(s.shape) < 0.2, 0.0, rng.normal(0, 10, s.shape))
        ds = ds / np.sqrt(terms.penalty)
        slope0 = float(np.dot(terms.normal_force(g), dg) + np.dot(terms.shear_force(s), ds))
        for c, push in ((1e9, 1e2), (1e2, 1e3), (1e-3, 1e3), (1e-3, 1e8), (0.0, 1e2)):
            a = -slope0 - push
            (alpha, changed), (oracle_alpha, oracle_changed) = both_line_searches(
                terms, a, c, g, dg, s, ds
            )
            assert alpha == pytest.approx(oracle_alpha, rel=1e-12)
            assert changed == oracle_changed
            breaks = np.concatenate(
                [_normal_breaks(terms, g, dg)[0], _shear_breaks(terms, s, ds)[0]]
            )
            outcomes.add((changed, bool(alpha < breaks[breaks < 1e200].max())))
    # roots before the first breakpoint, among them, and beyond the last finite one
    assert outcomes == {(False, True), (True, True), (True, False)}


@pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")
def test_the_compiled_line_search_skips_zero_rates():
    """p δg = 0 (no penalty) or ps δs = 0: no breakpoint, as in the numpy walk."""
    terms = dataclasses.replace(random_terms(3, m=50), penalty=np.zeros(50))
    g, s = points(random_terms(3, m=50), 4)
    dg, ds = np.ones(50), np.zeros(50)
    compiled, oracle = both_line_searches(terms, -1e3, 1.0, g, dg, s, ds)
    assert compiled == pytest.approx(oracle, rel=1e-12)
