"""Small steps' systems held dense (dda.solve.dense_system) solve the sparse path's equations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dda
from dda.solve.dense_system import DenseSystem
from dda.solve.policy import DEFAULT
from dda.solve.timing import StageTimer
from tests.helpers import use_policy

CASES = "cases/{}.toml"


class Rows:
    """Random contact rows: gaps at the step's start and their gradients."""

    def __init__(self, rng: np.random.Generator, m: int) -> None:
        self.normal_i, self.normal_j = rng.normal(size=(m, 6)), rng.normal(size=(m, 6))
        self.shear_i, self.shear_j = rng.normal(size=(m, 6)), rng.normal(size=(m, 6))
        self.penetration = rng.normal(scale=0.05, size=m)
        self.slip = rng.normal(scale=0.05, size=m)


def random_system(seed: int, n: int = 9, m: int = 30):
    rng = np.random.default_rng(seed)
    fixed = np.zeros(n, bool)
    fixed[[0, 4]] = True
    a = rng.integers(0, n, m)
    b = (a + rng.integers(1, n, m)) % n  # another block
    base = rng.normal(size=(n, 6, 6))
    base_k = np.einsum("nij,nkj->nik", base, base) + 6.0 * np.eye(6)
    base_f = rng.normal(size=(n, 6))
    rows = Rows(rng, m)
    springs = rng.uniform(0.0, 2.0, (2, m)) * (rng.uniform(size=(2, m)) > 0.3)
    return fixed, a, b, rows, base_k, base_f, springs, rng.normal(size=(2, m))


def explicit_system(fixed, a, b, rows, base_k, base_f, springs, offsets):
    """K and F over every block's unknowns, term by term (the equations, eqs. 9-13):
    K = K₀ + Σ k [r_i r_j]ᵀ[r_i r_j], F = F₀ − Σ N₀ r, restricted to the free blocks."""
    n = len(fixed)
    k = np.zeros((6 * n, 6 * n))
    f = base_f.ravel().copy()
    for i in range(n):
        k[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = base_k[i]
    for c in range(len(a)):
        for q, (row_i, row_j) in enumerate(
            [(rows.normal_i, rows.normal_j), (rows.shear_i, rows.shear_j)]
        ):
            r = np.zeros(6 * n)
            r[6 * a[c] : 6 * a[c] + 6] += row_i[c]
            r[6 * b[c] : 6 * b[c] + 6] += row_j[c]
            k += springs[q, c] * np.outer(r, r)
            f -= offsets[q, c] * r
    free = np.repeat(~fixed, 6)
    return k[np.ix_(free, free)], f[free]


def test_dense_system_solves_the_assembled_equations():
    fixed, a, b, rows, base_k, base_f, springs, offsets = random_system(3)
    k, f = explicit_system(fixed, a, b, rows, base_k, base_f, springs, offsets)
    system = DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer())
    d = system(springs[0], springs[1], offsets[0], offsets[1])
    expected = np.linalg.solve(k, f)
    np.testing.assert_allclose(d[~fixed].ravel(), expected, rtol=1e-10, atol=1e-12)
    assert np.all(d[fixed] == 0.0)
    # the chord step with the kept factorisation is K⁻¹ r; the force vector is Σ N r
    residual = np.random.default_rng(1).normal(size=d.shape)
    chord = system.chord(residual)
    np.testing.assert_allclose(chord[~fixed].ravel(), np.linalg.solve(k, residual[~fixed].ravel()))
    _, pushed = explicit_system(fixed, a, b, rows, 0 * base_k, 0 * base_f, springs, -offsets)
    vector = system.contact_vector(offsets[0], offsets[1])
    np.testing.assert_allclose(vector[~fixed].ravel(), pushed, rtol=1e-12, atol=1e-12)
    assert system.factorisations == 1


def test_without_friction_the_shear_springs_stay_out_of_k():
    fixed, a, b, rows, base_k, base_f, springs, offsets = random_system(5)
    no_shear = np.stack([springs[0], np.zeros_like(springs[1])])
    k, f = explicit_system(fixed, a, b, rows, base_k, base_f, no_shear, offsets)
    system = DenseSystem(fixed, a, b, rows, base_k, base_f, False, None, StageTimer())
    d = system(springs[0], springs[1], offsets[0], offsets[1])
    np.testing.assert_allclose(d[~fixed].ravel(), np.linalg.solve(k, f), rtol=1e-10, atol=1e-12)


def final_state(name: str) -> tuple[np.ndarray, np.ndarray, dict]:
    scene = dda.load_scene(CASES.format(name))
    if name == "stack":  # the stack's first 0.3 s (of 1 s): its blocks land and settle
        scene = dataclasses.replace(
            scene, analysis=dataclasses.replace(scene.analysis, duration=None, steps=300)
        )
    result = dda.simulate(scene)
    final = result.final
    return np.concatenate(final.vertices), final.stresses, result.summary


@pytest.mark.parametrize(
    "name", ["paper_two_blocks", "stack", "bolted_block", "wet_slope", "jointed_slope_fos"]
)
def test_a_run_with_dense_systems_is_the_sparse_run(monkeypatch, name):
    """Shipped cases of a few blocks (contacts opening, sliding; a bolt; water; the
    augmented Lagrangian): the dense systems give the sparse path's run, vertices to
    1e-9 of the model's size (band systems off: the paths of the numpy Newton)."""
    use_policy(monkeypatch, band_work=0.0)
    dense, dense_stress, dense_summary = final_state(name)
    use_policy(monkeypatch, dense_system_rows=0)  # every system on its block pattern
    sparse, sparse_stress, sparse_summary = final_state(name)
    np.testing.assert_allclose(dense, sparse, rtol=0, atol=1e-9 * np.abs(sparse).max())
    # Newton stops within newton_tolerance (1e-4) of ∇Π's scale: two solves of a step
    # that differ in round-off agree to that (stresses: E times the strain's difference)
    scale = max(np.abs(sparse_stress).max(), 1.0)
    np.testing.assert_allclose(dense_stress, sparse_stress, rtol=0, atol=1e-4 * scale)
    assert dense_summary["steps"] == sparse_summary["steps"]


def test_the_threshold_is_below_where_dense_stops_paying():
    """Dense Cholesky costs n³/3: the threshold stays where it was measured to pay."""
    assert 150 <= DEFAULT.dense_system_rows <= 240
