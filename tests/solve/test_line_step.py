"""The compiled line step (dda.solve.line_step) is the numpy one of dda.solve.newton.minimise."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.contact.line_search import line_minimum
from dda.solve import line_step, newton
from dda.solve.dense_system import DenseSystem
from dda.solve.newton import BlockQuadratic, ContactGeometry, minimise
from dda.solve.timing import StageTimer
from tests.helpers import use_policy
from tests.solve.test_band_newton import random_problem

pytestmark = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")


def numpy_line_step(quadratic, geometry, terms, system, d, direction, rates):
    """The numpy lines of minimise, written out: (D, g, s, K₀D, ∇Π, ‖∇Π‖, scale, α)."""
    g, s = geometry.at(d)
    kd = quadratic.product(d)
    dg, ds = geometry.rates(direction) if rates is None else rates
    kp = quadratic.product(direction)
    a, c = quadratic.along(kd, direction, kp)
    alpha, _ = line_minimum(terms, a, c, g, dg, s, ds)
    d, g, s, kd = d + alpha * direction, g + alpha * dg, s + alpha * ds, kd + alpha * kp
    residual, scale = newton._residual(quadratic, terms, system.contact_vector, kd, g, s)
    return d, g, s, kd, residual, np.linalg.norm(residual), scale, alpha


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("given_rates", [False, True])
def test_the_kernel_takes_the_numpy_line_step(seed, given_rates):
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed)
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed)
    system = DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer())
    rng = np.random.default_rng(100 + seed)
    d = np.where(fixed[:, None], 0.0, rng.normal(size=base_f.shape))
    g, s = geometry.at(d)  # down the gradient: a line whose minimum is not at its start
    direction = -newton._residual(
        quadratic, terms, system.contact_vector, quadratic.product(d), g, s
    )[0]
    rates = geometry.rates(direction) if given_rates else None
    with jit.run_work(1, 1e9):
        g, s = geometry.at(d)
        compiled = newton._compiled_line_step(
            quadratic, geometry, terms, d, g, s, quadratic.product(d), direction, rates
        )
    oracle = numpy_line_step(quadratic, geometry, terms, system, d, direction, rates)
    assert oracle[7] > 0.0  # the line minimum is not at its start
    for mine, theirs in zip(compiled, oracle, strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-11, atol=1e-11)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("rule", [{}, {"rate": 0.85, "conjugate": True}, {"max_steps": 3}])
def test_minimise_with_compiled_lines_takes_the_numpy_iterations(seed, rule):
    """Same Newton iterations, chord steps, outcome and minimiser (to rounding)."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed)
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed)
    start = np.zeros_like(base_f)
    results = []
    for compiled_lines in (True, False):
        system = DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer())
        arguments = (quadratic, geometry, terms, system, system.contact_vector, start, 12)
        with jit.run_work(1, 1e9):
            results.append(
                minimise(*arguments, chord=system.chord, forces_from_rows=compiled_lines, **rule)
            )
    mine, oracle = results
    assert (mine.solves, mine.chords, mine.converged) == (
        oracle.solves,
        oracle.chords,
        oracle.converged,
    )
    np.testing.assert_allclose(mine.d, oracle.d, rtol=1e-9, atol=1e-12)


def test_a_sparse_run_with_compiled_lines_is_the_numpy_run(monkeypatch):
    """The 7 x 7 wall (294 unknowns) on the sparse systems (band systems off), 40 steps:
    the same solves and factorisations, vertices within 1e-9 of the wall's size; the
    kernel did the lines."""
    use_policy(monkeypatch, band_work=0.0)
    scene = dda.load_scene(wall_scene(7, steps=40))
    calls = []
    kernel = line_step.line_step_kernel

    def counted(*args):
        calls.append(1)
        return kernel(*args)

    runs = []
    for lines in (counted, None):
        monkeypatch.setattr(line_step, "line_step_kernel", lines)
        with jit.run_work(50, 1e6):
            runs.append(dda.simulate(scene))
    mine, oracle = runs
    assert len(calls) > 40
    for key in ("iterations", "factorisations", "newton_iterations"):
        assert mine.summary[key] == oracle.summary[key]
    size = np.ptp(np.concatenate(oracle.final.vertices), axis=0).max()
    difference = np.abs(
        np.concatenate(mine.final.vertices) - np.concatenate(oracle.final.vertices)
    ).max()
    assert difference <= 1e-9 * size
