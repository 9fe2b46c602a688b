"""Sparse solves: orderings, PCG with a kept factorisation, re-factorisation rules."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

import dda
import dda.solve.linsolve as linsolve
from dda.bench.scenes import wall_scene
from dda.solve import thread_policy
from dda.solve.linsolve import Factorisation, ReusingSolver, block_ordering, pcg
from dda.solve.policy import DEFAULT, StepPolicy
from dda.solve.step import _keyed_springs

SETTINGS = (DEFAULT.pcg_tolerance, DEFAULT.max_pcg_iterations)  # the runs' PCG


def spd_matrix(seed: int, n: int = 60, density: float = 0.08) -> sp.csc_matrix:
    """A random sparse symmetric positive definite matrix."""
    rng = np.random.default_rng(seed)
    a = sp.random(n, n, density=density, random_state=rng)
    return sp.csc_matrix(a @ a.T + sp.eye(n) * n)


def test_factorisation_solves():
    k = spd_matrix(0)
    f = np.arange(60.0)
    np.testing.assert_allclose(k @ Factorisation(k).solve(f), f, rtol=1e-12, atol=1e-12)


def test_block_ordering_is_a_permutation():
    rng = np.random.default_rng(2)
    pairs = np.unique(np.sort(rng.integers(0, 50, (120, 2)), axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    position = block_ordering(50, pairs)
    np.testing.assert_array_equal(np.sort(position), np.arange(50))


def test_pcg_with_an_old_factorisation_equals_the_direct_solve():
    k_old = spd_matrix(3)
    rng = np.random.default_rng(4)
    change = sp.diags(1.0 + 1e-3 * rng.random(60))
    k_new = sp.csc_matrix(change @ k_old @ change)  # a slightly different SPD matrix
    f = rng.normal(size=60)
    x, iterations, ok = pcg(k_new, f, Factorisation(k_old).solve, *SETTINGS)
    direct = Factorisation(k_new).solve(f)
    assert ok and iterations <= 6
    np.testing.assert_allclose(x, direct, rtol=1e-10, atol=1e-12 * np.abs(direct).max())


def test_pcg_with_the_exact_factorisation_takes_one_application():
    k = spd_matrix(5)
    f = np.ones(60)
    x, iterations, ok = pcg(k, f, Factorisation(k).solve, *SETTINGS)
    assert ok and iterations == 1


def test_reusing_solver_factorises_only_when_needed():
    solver = ReusingSolver(permc_spec="MMD_AT_PLUS_A", backend="superlu")
    k = spd_matrix(6)
    f = np.ones(60)
    solver.solve(k, f, key="graph")
    solver.solve(k, 2 * f, key="graph")  # same matrix: direct re-solve
    assert solver.factorisations == 1
    near = sp.csc_matrix(k * (1 + 1e-8))
    x = solver.solve(near, f, key="graph")  # same pattern: PCG on the kept factor
    assert solver.factorisations == 1 and solver.pcg_solves == 1
    np.testing.assert_allclose(near @ x, f, rtol=1e-11)
    solver.solve(near, f, key="another graph")  # new pattern: factorise
    assert solver.factorisations == 2


def test_reusing_solver_refactorises_when_pcg_does_not_converge():
    policy = dataclasses.replace(DEFAULT, max_pcg_iterations=2)
    solver = ReusingSolver(permc_spec="MMD_AT_PLUS_A", backend="superlu", policy=policy)
    k = spd_matrix(7)
    f = np.ones(60)
    solver.solve(k, f, key=1)
    far = spd_matrix(8)  # unrelated matrix, same key
    x = solver.solve(far, f, key=1)
    assert solver.factorisations == 2
    np.testing.assert_allclose(far @ x, f, rtol=1e-11)


def test_dense_cholesky_equals_superlu():
    k = spd_matrix(12)
    f = np.linspace(-1.0, 1.0, 60)
    dense = linsolve.DenseFactorisation(k)
    x = dense.solve(f)
    assert np.linalg.norm(k @ x - f) <= 1e-13 * np.linalg.norm(f)
    np.testing.assert_allclose(x, Factorisation(k).solve(f), rtol=1e-12, atol=1e-15)
    columns = np.stack([f, f**2, np.ones(60)], axis=1)
    np.testing.assert_allclose(k @ dense.solve_many(columns), columns, rtol=1e-12, atol=1e-12)


def test_dense_cholesky_hands_a_matrix_it_cannot_factorise_to_superlu():
    """K indefinite by round-off (a nearly singular K): LAPACK's Cholesky stops; SuperLU
    without pivoting factorises it as it did before the dense path existed."""
    k = spd_matrix(13).tolil()
    k[0, 0] = -1.0  # symmetric, indefinite, not singular
    k = sp.csc_matrix(k)
    f = np.ones(60)
    dense = linsolve.DenseFactorisation(k)
    assert dense._fallback is not None
    np.testing.assert_array_equal(dense.solve(f), Factorisation(k, "NATURAL").solve(f))


def test_a_small_k_solved_by_numpy_equals_the_cholesky():
    """Up to ``numpy_rows`` rows K is kept and numpy's LU solves it each time (no scipy):
    the same x as the Cholesky to 1e-12, one right-hand side or several."""
    k = spd_matrix(5).toarray()[:30, :30]
    f = np.linspace(-1.0, 1.0, 30)
    by_numpy = linsolve.DenseFactorisation(k, numpy_rows=30)
    assert by_numpy._matrix is not None
    np.testing.assert_allclose(by_numpy.solve(f), linsolve.DenseFactorisation(k).solve(f),
                               rtol=1e-12, atol=1e-15)  # fmt: skip
    columns = np.stack([f, f**2, np.ones(30)], axis=1)
    np.testing.assert_allclose(k @ by_numpy.solve_many(columns), columns, rtol=1e-12, atol=1e-12)
    assert linsolve.DenseFactorisation(k, numpy_rows=29)._matrix is None


def test_a_small_k_that_numpy_finds_singular_goes_to_superlu():
    """numpy's LU refuses an exactly singular K; SuperLU is then asked, as the Cholesky's
    failure asks it (and says so in the same way: it cannot factorise it either)."""
    k = np.zeros((6, 6))
    dense = linsolve.DenseFactorisation(k, numpy_rows=6)
    with pytest.raises(RuntimeError):
        dense.solve(np.ones(6))
    assert dense._matrix is None and dense._fallback is None


def test_automatic_solver_uses_a_dense_cholesky_for_small_k_and_never_pcg(monkeypatch):
    solver = ReusingSolver()
    k = spd_matrix(14)
    f = np.ones(60)
    solver.solve(k, f, key="graph")
    assert isinstance(solver._factor, linsolve.DenseFactorisation)
    assert solver.pcg_budget == 0  # a factorisation costs about 5 back-substitutions
    near = sp.csc_matrix(k * (1 + 1e-8))
    x = solver.solve(near, f, key="graph")
    assert solver.factorisations == 2 and solver.pcg_solves == 0
    assert np.linalg.norm(near @ x - f) <= 1e-13 * np.linalg.norm(f)
    solver.policy = dataclasses.replace(solver.policy, dense_factor_rows=59)
    solver.solve(k, f, key="graph")
    assert not isinstance(solver._factor, linsolve.DenseFactorisation)


def test_pardiso_backend_equals_superlu(monkeypatch):
    pytest.importorskip("pypardiso")
    k = spd_matrix(9)
    f = np.linspace(-1.0, 1.0, 60)
    pardiso = ReusingSolver(
        backend="pardiso", policy=dataclasses.replace(DEFAULT, dense_factor_rows=0)
    )
    x = pardiso.solve(k, f, key="graph")
    np.testing.assert_allclose(x, Factorisation(k).solve(f), rtol=1e-10, atol=1e-14)
    near = sp.csc_matrix(k * (1 + 1e-3))  # same pattern: numeric phase only
    pardiso.solve(near, f, key="graph", similar=False)
    np.testing.assert_allclose(near @ pardiso.solve(near, f, key="graph"), f, rtol=1e-11)
    assert pardiso.factorisations == 2


def test_pardiso_solves_without_iterative_refinement():
    """PARDISO's defaults (iparm[0] = 0) include two refinement steps per solve, 3-4
    back-substitutions' cost; they are off, and the residual is a direct solve's."""
    pytest.importorskip("pypardiso")
    k = spd_matrix(40)
    f = np.linspace(-1.0, 1.0, k.shape[0])
    handle = None  # a new handle, then the same one re-used for a new pattern
    for _ in range(2):
        factor = linsolve.PardisoFactorisation(k, handle)
        handle = factor._solver
        factor.factor(k, 1)
        x = factor.solve(f)
        assert factor._solver.iparm[6] == 0  # refinement steps performed (output)
        assert np.linalg.norm(k @ x - f) <= 1e-13 * np.linalg.norm(f)


def test_solver_threads_follow_dda_threads_or_the_thread_policy(monkeypatch):
    monkeypatch.delenv("DDA_THREADS", raising=False)
    monkeypatch.setattr(thread_policy.POLICY, "threads", lambda: 7)
    assert StepPolicy.from_environment().solver_threads() == 7
    monkeypatch.setenv("DDA_THREADS", " 3 ")
    assert StepPolicy.from_environment().solver_threads() == 3
    monkeypatch.setenv("DDA_THREADS", "1.5")
    with pytest.raises(ValueError, match="DDA_THREADS='1.5'"):
        StepPolicy.from_environment()
    with pytest.raises(ValueError, match="DDA_THREADS"):
        dda.simulate(wall_scene(2, steps=1))  # refused before the run starts


def test_the_solver_choice_is_pardiso_superlu_or_unset(monkeypatch):
    monkeypatch.setenv("DDA_SOLVER", " SuperLU ")
    policy = StepPolicy.from_environment()
    assert policy.solver == "superlu" and not linsolve.pardiso_available(policy)
    monkeypatch.setenv("DDA_SOLVER", "super-lu")
    with pytest.raises(ValueError, match="DDA_SOLVER='super-lu'"):
        linsolve.pardiso_available()
    with pytest.raises(ValueError, match="DDA_SOLVER"):
        dda.simulate(wall_scene(2, steps=1))  # refused before the run starts
    monkeypatch.delenv("DDA_SOLVER")
    assert StepPolicy.from_environment().solver == ""


def test_dda_systems_sparse_puts_every_step_on_the_block_pattern(monkeypatch):
    """DDA_SYSTEMS=sparse: a 3 x 3 wall with the kernels (band systems otherwise) takes
    the sparse block pattern at every step; a misspelt value stops the run at once."""
    import dda.solve.step as step
    from dda.solve.band_system import BandSystem

    made = {"band": 0, "sparse": 0}
    for kind, system in (("band", BandSystem), ("sparse", step._PieceSystem)):
        build = system.__init__

        def counted(self, *args, _build=build, _kind=kind, **kwargs):
            _build(self, *args, **kwargs)
            made[_kind] += 1

        monkeypatch.setattr(system, "__init__", counted)
    monkeypatch.setenv("DDA_SYSTEMS", " Sparse ")
    assert StepPolicy.from_environment().systems == "sparse"
    with dda.jit.run_work(10, 1e6):
        dda.simulate(wall_scene(3, steps=5))
    assert made == {"band": 0, "sparse": 5}
    monkeypatch.setenv("DDA_SYSTEMS", "dense")
    with pytest.raises(ValueError, match="DDA_SYSTEMS='dense'"):
        dda.simulate(wall_scene(2, steps=1))
    monkeypatch.delenv("DDA_SYSTEMS")
    assert StepPolicy.from_environment().systems == ""


def test_pardiso_allows_more_pcg_iterations_on_large_systems(monkeypatch):
    """A factorisation grows faster with the size than a back-substitution: the
    budget is 3 PCG iterations below pardiso_large_rows, 5 from there on."""
    pytest.importorskip("pypardiso")
    k = spd_matrix(11)
    solver = ReusingSolver(
        backend="pardiso", policy=dataclasses.replace(DEFAULT, dense_factor_rows=0)
    )
    solver.solve(k, np.ones(60), key="graph")
    assert solver.pcg_budget == 3
    solver.policy = dataclasses.replace(solver.policy, pardiso_large_rows=60)
    assert solver.pcg_budget == 5
    assert ReusingSolver(backend="superlu").pcg_budget == DEFAULT.max_pcg_iterations


def test_dissimilar_matrix_is_factorised_without_pcg():
    solver = ReusingSolver(permc_spec="MMD_AT_PLUS_A", backend="superlu")
    k = spd_matrix(10)
    f = np.ones(60)
    solver.solve(k, f, key=1)
    solver.solve(sp.csc_matrix(k * 2.0), f, key=1, similar=False)
    assert solver.factorisations == 2 and solver.pcg_solves == 0


def test_a_run_is_reproducible_bit_for_bit():
    """Whether PCG or a new factorisation solves a step never depends on timings."""

    def run():
        raw = wall_scene(5, 5, "penalty")
        raw["analysis"]["steps"] = 20
        return dda.simulate(dda.load_scene(raw)).final.displacements

    np.testing.assert_array_equal(run(), run())


def test_pardiso_runs_repeat_bit_for_bit_under_mkl_cbwr_auto():
    """On two threads PARDISO may sum a factorisation's updates in another order each
    time (the 20x20 wall's runs differed by up to 1e-13); with MKL's own
    ``MKL_CBWR=AUTO`` (README) a run repeats to the bit."""
    pytest.importorskip("pypardiso")
    code = (
        "import numpy as np, dda\n"
        "from dda.bench.scenes import wall_scene\n"
        "scene = dda.load_scene(wall_scene(20, 20, steps=30))\n"
        "runs = [np.concatenate(dda.simulate(scene).final.vertices) for _ in range(2)]\n"
        "print(np.array_equal(*runs))\n"
    )
    env = {**os.environ, "MKL_CBWR": "AUTO", "DDA_THREADS": "2"}
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "True"


def test_open_contacts_are_no_spring_of_k():
    """Only closed contacts (a nonzero spring) count when K is compared with the factorised one."""
    contacts = SimpleNamespace(key=np.array([9, 3, 5, 1]))
    springs = np.array([[2.0, 0.0, 1.0, 0.0], [0.8, 0.0, 0.0, 0.0]])  # 3 and 1 are open
    keys, kept = _keyed_springs(contacts, springs)
    np.testing.assert_array_equal(keys, [5, 9])
    np.testing.assert_array_equal(kept, [[1.0, 2.0], [0.0, 0.8]])


def test_direct_pardiso_calls_solve_many_columns_and_report_errors():
    """The ctypes call (dda.solve.pardiso_call) solves one or several right-hand sides, and a
    matrix that is not positive definite is PARDISO's error, raised, not a wrong x."""
    pytest.importorskip("pypardiso")
    from pypardiso.pardiso_wrapper import PyPardisoError

    k = spd_matrix(41)
    factor = linsolve.PardisoFactorisation(k)
    factor.factor(k, 1)
    columns = np.random.default_rng(3).normal(size=(k.shape[0], 5))
    many = factor.solve_many(columns)
    assert many.shape == columns.shape and many.flags.c_contiguous
    np.testing.assert_allclose(k @ many, columns, rtol=1e-11, atol=1e-11)
    # several columns go through PARDISO's blocked kernels: equal to round-off
    np.testing.assert_allclose(many[:, 2], factor.solve(columns[:, 2]), rtol=1e-12, atol=1e-15)
    indefinite = sp.csc_matrix(k - 2.0 * k.shape[0] * sp.eye(k.shape[0]))
    with pytest.raises(PyPardisoError):
        factor.factor(indefinite, 1)


def test_pardiso_factorises_on_the_threads_it_analysed_with():
    """PARDISO analysed on two threads and asked to factorise on one factorised wrongly
    (a residual of 174 on this 30,000-unknown grid, silently): a factorisation on
    another count than the analysis' analyses the pattern again on that count."""
    pytest.importorskip("pypardiso")
    m = 173
    line = sp.diags([-1.0, 4.5, -1.0], [-1, 0, 1], shape=(m, m))
    neighbours = sp.diags([-1.0, -1.0], [-1, 1], shape=(m, m))
    k = sp.csc_matrix(sp.kron(sp.eye(m), line) + sp.kron(neighbours, sp.eye(m)))
    f = np.ones(k.shape[0])
    factor = linsolve.PardisoFactorisation(k, None, 2)
    for threads in (1, 2, 1):
        factor.factor(k, threads)
        assert factor.threads == threads
        assert np.linalg.norm(k @ factor.solve(f) - f) <= 1e-12 * np.linalg.norm(f)
