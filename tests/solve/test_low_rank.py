"""Solves through a kept factorisation after a few contact springs changed (Woodbury)."""

from __future__ import annotations

import gc
import weakref
from types import SimpleNamespace

import numpy as np
import pytest

import dda
import dda.solve.step
from dda.bench.scenes import wall_scene
from dda.solve.assembly import BlockPattern, assemble
from dda.solve.linsolve import Factorisation
from dda.solve.low_rank import StepUpdates
from dda.solve.policy import DEFAULT
from tests.helpers import use_policy


@pytest.fixture(autouse=True)
def any_size(monkeypatch):
    """These systems are small: solve through the updates whatever the size."""
    use_policy(monkeypatch, low_rank_min_rows=0)


def contact_system(seed: int, n: int = 12, m: int = 60):
    """Blocks with SPD diagonal blocks (some fixed) and m random contacts, 1/5 open."""
    rng = np.random.default_rng(seed)
    fixed = np.zeros(n, bool)
    fixed[:2] = True
    a = rng.integers(0, n, m)
    b = (a + rng.integers(1, n, m)) % n
    diagonal = np.tile(1e3 * np.eye(6), (n, 1, 1))
    rows = SimpleNamespace(
        **{k: rng.normal(size=(m, 6)) for k in ("normal_i", "normal_j", "shear_i", "shear_j")}
    )
    springs = np.stack([rng.uniform(1e3, 1e5, m), rng.uniform(1e3, 1e5, m)])
    springs[:, ::5] = 0.0
    pattern = BlockPattern(fixed, a, b)
    return fixed, a, b, diagonal, rows, springs, pattern


def stiffness(pattern, diagonal, fixed, rows, springs):
    terms = [(rows.normal_i, rows.normal_j, springs[0]), (rows.shear_i, rows.shear_j, springs[1])]
    return assemble(pattern, diagonal, fixed, terms)


@pytest.mark.parametrize("seed", range(3))
def test_a_few_changed_springs_are_solved_through_the_kept_factorisation(seed):
    """Springs taken out (contacts opening), put in (closing) and changed (sliding):
    the solve equals a direct solve of the new K, with no new factorisation."""
    fixed, a, b, diagonal, rows, springs, pattern = contact_system(seed)
    k_f = stiffness(pattern, diagonal, fixed, rows, springs)
    factor = Factorisation(k_f)
    updates = StepUpdates(k_f, springs, pattern, rows, a, b, factor.solve_many)
    new = springs.copy()
    new[:, 1] = 0.0  # opens
    new[:, 5] = 4e4  # closes
    new[1, 7] = 0.0  # slides: no shear spring
    k = stiffness(pattern, diagonal, fixed, rows, new)
    f = np.linspace(-1.0, 1.0, k.shape[0])
    x = updates.solve(k, f, new)
    assert x is not None
    np.testing.assert_allclose(k @ x, f, atol=1e-12 * np.abs(f).max())
    np.testing.assert_allclose(x, Factorisation(k).solve(f), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("free_side", [0, 1])
def test_the_preconditioner_is_exact_when_a_contact_has_a_fixed_block(free_side):
    """A contact between a fixed block and the block at matrix row 0: the fixed block's
    entries of U point at row 0 with zeros, beside the free block's real ones. The
    Woodbury inverse must still be K's inverse (it lost the free block's first
    component when the fixed block came second)."""
    fixed, a, b, diagonal, rows, springs, _ = contact_system(0)
    a, b = a.copy(), b.copy()
    pattern = BlockPattern(fixed, a, b)
    for _ in range(5):  # the order depends on the contacts: settle which block is row 0
        ends = [int(np.flatnonzero(pattern.block_of_row == 0)[0]), 0]  # block 0 is fixed
        a[3], b[3] = ends[free_side], ends[1 - free_side]
        pattern = BlockPattern(fixed, a, b)
        if pattern.block_of_row[ends[0]] == 0:
            break
    assert pattern.block_of_row[ends[0]] == 0 and fixed[ends[1]]
    springs[:, 3] = 1e4
    k_f = stiffness(pattern, diagonal, fixed, rows, springs)
    updates = StepUpdates(k_f, springs, pattern, rows, a, b, Factorisation(k_f).solve_many)
    new = springs.copy()
    new[:, 3] = 0.0
    k = stiffness(pattern, diagonal, fixed, rows, new)
    f = np.linspace(-1.0, 1.0, k.shape[0])
    exact = Factorisation(k).solve(f)
    np.testing.assert_allclose(updates._preconditioner(k, new)(f), exact, rtol=1e-9, atol=1e-15)


def test_many_or_no_changed_springs_are_left_to_a_factorisation():
    fixed, a, b, diagonal, rows, springs, pattern = contact_system(0)
    k_f = stiffness(pattern, diagonal, fixed, rows, springs)
    updates = StepUpdates(k_f, springs, pattern, rows, a, b, Factorisation(k_f).solve_many)
    f = np.ones(k_f.shape[0])
    assert updates.solve(k_f, f, springs) is None
    many = springs * 2.0
    assert np.count_nonzero(many != springs) > DEFAULT.low_rank_columns
    assert updates.solve(stiffness(pattern, diagonal, fixed, rows, many), f, many) is None


def test_a_wall_runs_the_same_with_fewer_factorisations(monkeypatch):
    """The 6 x 6 wall for 20 steps: the same solves and displacements (every solve is
    to a residual of 1e-13), fewer factorisations. Without chord steps, whose
    direction depends on which matrix was factorised last."""
    monkeypatch.setattr(dda.solve.step._PieceSystem, "chord", lambda self, residual: None)
    scene = dda.load_scene(wall_scene(6, steps=20))
    with_updates = dda.simulate(scene)
    use_policy(monkeypatch, low_rank_columns=0)
    without = dda.simulate(scene)
    assert with_updates.summary["iterations_per_step"] == without.summary["iterations_per_step"]
    assert with_updates.summary["factorisations"] < 0.8 * without.summary["factorisations"]
    np.testing.assert_allclose(
        with_updates.final.displacements, without.final.displacements, rtol=0, atol=1e-10
    )


def test_the_updates_are_freed_as_soon_as_they_are_dropped():
    """No reference cycle (the preconditioner's closure held the updates): a step's
    updates, their K and their columns go when the next factorisation replaces them,
    not when Python's cycle collector happens to run. At 10,000 blocks with the
    default band, up to 28 matrices of 12 MiB had waited for it (peak 1.3 GiB)."""
    fixed, a, b, diagonal, rows, springs, pattern = contact_system(1)
    k_f = stiffness(pattern, diagonal, fixed, rows, springs)
    updates = StepUpdates(k_f, springs, pattern, rows, a, b, Factorisation(k_f).solve_many)
    new = springs.copy()
    new[:, 1] = 0.0
    k = stiffness(pattern, diagonal, fixed, rows, new)
    assert updates.solve(k, np.ones(k.shape[0]), new) is not None  # the closure is made
    gone = weakref.ref(updates)
    gc.disable()
    try:
        del updates
        assert gone() is None
    finally:
        gc.enable()
