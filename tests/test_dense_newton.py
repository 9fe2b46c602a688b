"""The compiled Newton on dense systems (dda.solve.dense_newton) is the numpy minimise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.contact.potential import ContactTerms
from dda.solve import band_system, dense_newton, dense_system
from dda.solve.dense_system import DenseSystem
from dda.solve.newton import BlockQuadratic, ContactGeometry, minimise, potential
from dda.solve.timing import StageTimer
from tests.test_dense_system import Rows

pytestmark = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")


def random_problem(seed: int, n: int = 8, m: int = 24):
    """Blocks (two fixed) under loads, contacts with penalties, some tension, friction
    bounds of which some are zero, some augmented (λn, λt ≠ 0)."""
    rng = np.random.default_rng(seed)
    fixed = np.zeros(n, bool)
    fixed[[0, 3]] = True
    a = rng.integers(0, n, m)
    b = (a + rng.integers(1, n, m)) % n
    base = rng.normal(size=(n, 6, 6))
    base_k = np.einsum("nij,nkj->nik", base, base) + 2.0 * np.eye(6)
    base_f = rng.normal(scale=3.0, size=(n, 6))
    base_f[fixed] = 0.0
    rows = Rows(rng, m)
    penalty = rng.uniform(5.0, 50.0, m)
    terms = ContactTerms(
        normal_base=rng.uniform(0.0, 1.0, m) * (rng.uniform(size=m) > 0.5),
        penalty=penalty,
        tension=rng.uniform(0.0, 0.5, m) * (rng.uniform(size=m) > 0.7),
        shear_base=rng.uniform(-0.2, 0.2, m),
        shear_penalty=0.5 * penalty,
        bound=rng.uniform(0.0, 1.5, m) * (rng.uniform(size=m) > 0.2),
    )
    return fixed, a, b, rows, base_k, base_f, terms


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(
    "rule",
    [
        {},
        {"max_steps": 3},
        {"rate": 0.85, "conjugate": True},
        {"rate": 0.99, "conjugate": True, "max_steps": 4},
    ],
)
def test_the_kernel_takes_the_numpy_iterations(seed, rule):
    """The same Newton iterations, chord steps, outcome and minimiser (to rounding), from a
    start D = 0 and, on lower friction bounds (the law's next pass), from the last pass's
    end with its kept factorisation (chord first)."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed)
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed)
    start = np.zeros_like(base_f)
    twins = [
        DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer()) for _ in (0, 1)
    ]
    kernel_system, numpy_system = twins
    for chord_first in (False, True):  # the second pass goes on with the kept factorisation
        with jit.run_work(1, 1e9):
            compiled = kernel_system.minimise(terms, start, 12, chord_first=chord_first, **rule)
            oracle = minimise(
                quadratic, geometry, terms, numpy_system, numpy_system.contact_vector, start, 12,
                chord=numpy_system.chord, chord_first=chord_first, **rule,
            )  # fmt: skip
        assert compiled is not None
        assert (compiled.solves, compiled.chords) == (oracle.solves, oracle.chords)
        assert (compiled.converged, compiled.chord_next) == (oracle.converged, oracle.chord_next)
        np.testing.assert_allclose(compiled.d, oracle.d, rtol=1e-9, atol=1e-12)
        for mine, theirs in zip(compiled.gaps, oracle.gaps, strict=True):
            np.testing.assert_allclose(mine, theirs, rtol=1e-9, atol=1e-12)
        assert kernel_system.factorisations == numpy_system.factorisations
        start = compiled.d
        terms = dataclasses.replace(terms, bound=0.7 * terms.bound)
        terms = dataclasses.replace(
            terms, shear_base=np.clip(terms.shear_base, -terms.bound, terms.bound)
        )


@pytest.mark.parametrize("method", ["penalty", "augmented-lagrangian"])
def test_a_run_with_the_kernel_is_the_numpy_run(monkeypatch, method):
    """The 5 x 5 wall held dense (band systems off: the path of a bolted model), 40 steps
    as a long run's kernels would take them: the same linear solves and factorisations,
    vertices to 1e-9 m."""
    monkeypatch.setattr(band_system, "BAND_WORK", 0.0)

    def run():
        with jit.run_work(26, 10_000):
            result = dda.simulate(dda.load_scene(wall_scene(5, method=method, steps=40)))
        return np.concatenate(result.final.vertices), result.summary

    compiled, compiled_summary = run()
    monkeypatch.setattr(dense_system.DenseSystem, "minimise", lambda self, *a, **k: None)
    oracle, oracle_summary = run()
    np.testing.assert_allclose(compiled, oracle, rtol=0, atol=1e-9)
    for count in ("iterations", "factorisations", "newton_iterations"):
        assert compiled_summary.get(count) == oracle_summary.get(count)


@pytest.mark.parametrize("seed", range(4))
def test_the_compiled_potential_is_the_numpy_one(seed):
    """Π at random steps D (contacts elastic and at their limit, stuck and slipping, ps = 0
    for some): the compiled value to rounding, and the same better start."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed)
    no_shear = np.random.default_rng(seed).uniform(size=len(a)) > 0.8
    terms = dataclasses.replace(terms, shear_penalty=np.where(no_shear, 0.0, terms.shear_penalty))
    system = DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer())
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed)
    rng = np.random.default_rng(10 + seed)
    steps = [
        np.where(fixed[:, None], 0.0, rng.normal(scale=0.1, size=base_f.shape)) for _ in (0, 1)
    ]
    with jit.run_work(1, 1e9):
        for d in steps:
            x = np.ascontiguousarray(d[~fixed].ravel())
            arrays = (terms.normal_base, terms.penalty, terms.tension, terms.shear_base)
            arrays += (terms.shear_penalty, terms.bound)
            value = dense_newton.potential_kernel(
                system.base, system.forces, system.normal, system.shear, system.g0, system.s0,
                *arrays, x,
            )  # fmt: skip
            expected = potential(quadratic, geometry, terms, d)
            assert value == pytest.approx(expected, rel=1e-12, abs=1e-12)
        chosen = system.better_start(terms, steps)
    assert (
        chosen is steps[int(np.argmin([potential(quadratic, geometry, terms, d) for d in steps]))]
    )


def test_a_k_not_positive_definite_falls_back_to_the_numpy_newton():
    """LAPACK's Cholesky refuses K: the kernel gives the pass back (None) and stays out of
    the rest of the step, whose numpy Newton factorises K by LU."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(0)
    indefinite = base_k - 50.0 * np.eye(6)
    system = DenseSystem(fixed, a, b, rows, indefinite, base_f, True, None, StageTimer())
    with jit.run_work(1, 1e9):
        assert system.minimise(terms, np.zeros_like(base_f), 5) is None
        assert system.minimise(terms, np.zeros_like(base_f), 5) is None
    d = system(terms.penalty, terms.shear_penalty, terms.normal_base, terms.shear_base)
    assert np.all(np.isfinite(d)) and system.factorisations == 1
