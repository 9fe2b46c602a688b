"""Newton with an exact line search on a step's potential (dda.solve.newton), on random
problems solved densely: Π falls at every iteration, and the result is Π's minimiser
(its gradient vanishes and no nearby point is lower)."""

from __future__ import annotations

import numpy as np
import pytest

from dda.contact.potential import ContactTerms
from dda.contact.rows import _empty_rows
from dda.solve.newton import BlockQuadratic, ContactGeometry, _conjugated, minimise, potential


def problem(seed: int, blocks: int = 6, contacts: int = 40):
    """Block-diagonal SPD K₀ (mass-like), loads, and contacts between random block pairs,
    half of them touching or overlapping at D = 0, with friction and some tension."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(blocks, 6, 6))
    stiffness = np.einsum("nij,nkj->nik", a, a) + 1e4 * np.eye(6)
    forces = rng.normal(0, 300, (blocks, 6))
    pair = np.array([rng.choice(blocks, 2, replace=False) for _ in range(contacts)])
    rows = _empty_rows(contacts)
    for name in ("normal_i", "normal_j", "shear_i", "shear_j"):
        getattr(rows, name)[:] = rng.normal(size=(contacts, 6))
    rows.penetration[:] = rng.normal(0, 2e-3, contacts)
    rows.slip[:] = 0.0
    penalty = np.full(contacts, 1e5)
    tension = np.where(rng.random(contacts) < 0.2, 20.0, 0.0)
    bound = rng.uniform(0, 80, contacts)
    terms = ContactTerms(
        normal_base=np.maximum(rng.normal(0, 20, contacts), -tension),
        penalty=penalty,
        tension=tension,
        shear_base=np.clip(rng.normal(0, 30, contacts), -bound, bound),
        shear_penalty=0.4 * penalty,
        bound=bound,
    )
    quadratic = BlockQuadratic(stiffness, forces, np.ones(blocks, bool))
    geometry = ContactGeometry(rows, pair[:, 0].copy(), pair[:, 1].copy())
    return quadratic, geometry, terms


def dense(quadratic, geometry):
    """The piece solver and the contact force vector, with dense matrices."""
    n = quadratic.forces.shape[0]
    rows, a, b = geometry.rows, geometry.block_a, geometry.block_b

    def spread(row_i, row_j):  # (m, 6n) gradients
        out = np.zeros((len(a), 6 * n))
        for c in range(len(a)):
            out[c, 6 * a[c] : 6 * a[c] + 6] += row_i[c]
            out[c, 6 * b[c] : 6 * b[c] + 6] += row_j[c]
        return out

    grad_n, grad_t = spread(rows.normal_i, rows.normal_j), spread(rows.shear_i, rows.shear_j)
    k0 = np.zeros((6 * n, 6 * n))
    for i in range(n):
        k0[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = quadratic.stiffness[i]

    factored = []  # the matrix of the last solve, as a solver keeps its factorisation

    def solve(kn, ks, offset_n, offset_t):
        k = k0 + grad_n.T @ (kn[:, None] * grad_n) + grad_t.T @ (ks[:, None] * grad_t)
        f = quadratic.forces.ravel() - grad_n.T @ offset_n - grad_t.T @ offset_t
        factored[:] = [k]
        return np.linalg.solve(k, f).reshape(n, 6)

    def contact_vector(normal, shear):
        return (grad_n.T @ normal + grad_t.T @ shear).reshape(n, 6)

    def chord(residual):
        return np.linalg.solve(factored[0], residual.ravel()).reshape(n, 6) if factored else None

    solve.chord = chord
    return solve, contact_vector


@pytest.mark.parametrize("seed", range(6))
def test_the_potential_falls_at_every_iteration_to_its_minimum(seed):
    quadratic, geometry, terms = problem(seed)
    solve, contact_vector = dense(quadratic, geometry)
    start = np.zeros_like(quadratic.forces)
    iterates = [start]
    result = minimise(quadratic, geometry, terms, solve, contact_vector, start, 50, None, iterates)
    assert result.converged
    values = [potential(quadratic, geometry, terms, d) for d in iterates]
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(values, values[1:], strict=False))
    g, s = geometry.at(result.d)
    gradient = (
        quadratic.product(result.d)
        - quadratic.forces
        + contact_vector(terms.normal_force(g), terms.shear_force(s))
    )
    assert np.linalg.norm(gradient) <= 1e-6 * np.linalg.norm(quadratic.forces)
    rng = np.random.default_rng(seed + 100)
    best = values[-1]
    for _ in range(50):  # convex: the minimiser is lower than any point around it
        nearby = result.d + rng.normal(0, 1e-4, result.d.shape)
        assert potential(quadratic, geometry, terms, nearby) >= best - 1e-9 * abs(best)


def test_any_first_pieces_lead_to_the_same_minimum():
    """Wrong first guesses (every contact closed and stuck, or all open) cost iterations,
    not the answer."""
    quadratic, geometry, terms = problem(42)
    solve, contact_vector = dense(quadratic, geometry)
    start = np.zeros_like(quadratic.forces)
    m = len(terms.penalty)
    answers = []
    for normal, shear in ((1, 0), (0, 1)):
        guess = (np.full(m, normal, np.int8), np.full(m, shear, np.int8))
        answers.append(
            minimise(quadratic, geometry, terms, solve, contact_vector, start, 50, guess)
        )
    assert all(r.converged for r in answers)
    np.testing.assert_allclose(answers[0].d, answers[1].d, rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("conjugate", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_chord_steps_keep_the_descent_and_reach_the_same_minimum(seed, conjugate):
    """Chord steps (−K_f⁻¹∇Π with the last Newton matrix, plain or conjugated) after
    Newton iterations: Π still falls at every iterate and the result is the minimiser
    Newton finds alone, to the stopping tolerance (‖∇Π‖ ≤ 1e-4 of the forces: Π within
    ~1e-8)."""
    quadratic, geometry, terms = problem(seed)
    solve, contact_vector = dense(quadratic, geometry)
    start = np.zeros_like(quadratic.forces)
    plain = minimise(quadratic, geometry, terms, solve, contact_vector, start, 50)
    iterates = [start]
    result = minimise(
        quadratic,
        geometry,
        terms,
        solve,
        contact_vector,
        start,
        50,
        None,
        iterates,
        solve.chord,
        rate=0.99 if conjugate else 0.5,
        conjugate=conjugate,
    )
    assert result.converged and plain.converged
    values = [potential(quadratic, geometry, terms, d) for d in iterates]
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(values, values[1:], strict=False))
    best = potential(quadratic, geometry, terms, plain.d)
    assert values[-1] == pytest.approx(best, rel=1e-7)
    g, s = geometry.at(result.d)
    forces = contact_vector(terms.normal_force(g), terms.shear_force(s))
    gradient = quadratic.product(result.d) - quadratic.forces + forces
    scale = sum(np.linalg.norm(x) for x in (quadratic.product(result.d), quadratic.forces, forces))
    assert np.linalg.norm(gradient) <= 1e-4 * scale


def chord_iterations(conjugate: bool, steps: int, rank: int = 3, size: int = 40) -> float:
    """‖∇Π‖ / ‖∇Π₀‖ after ``steps`` chord steps with exact line searches on a quadratic
    ½ xᵀAx − bᵀx, with K_f = A plus a positive rank-``rank`` change (a factorisation made
    before ``rank`` contact springs changed)."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(size, size))
    matrix = a @ a.T + size * np.eye(size)
    change = rng.normal(size=(size, rank))
    kept = matrix + 50.0 * change @ change.T
    b = rng.normal(size=size)
    x, last = np.zeros(size), None
    gradient = matrix @ x - b
    first = np.linalg.norm(gradient)
    for _ in range(steps):
        z = np.linalg.solve(kept, gradient)
        direction = -z
        if conjugate and last is not None:
            direction = _conjugated(direction, gradient, z, last)
        last = (direction, gradient, z)
        x = x - (gradient @ direction) / (direction @ matrix @ direction) * direction
        gradient = matrix @ x - b
    return float(np.linalg.norm(gradient) / first)


def test_conjugated_chord_steps_are_preconditioned_conjugate_gradients():
    """On a quadratic, conjugated chord steps are conjugate gradients preconditioned by
    K_f: with K_f off by a rank-3 change they end in rank + 1 = 4 steps (to round-off),
    (measured 1.8e-11), where plain chord steps have left 7e-3 of the gradient."""
    assert chord_iterations(conjugate=True, steps=4) < 1e-10
    assert chord_iterations(conjugate=False, steps=4) > 1e-3


def test_the_line_slope_is_taken_from_the_force_difference_not_two_large_products():
    """a = ΔDᵀ(K₀D − F₀) near a step's solution, where K₀D ≈ F₀ (inertia, 2M/Δt² ~ 1e12
    here): subtracting the two dot products ΔDᵀK₀D − ΔDᵀF₀ would lose the slope to
    cancellation (an inexact line minimum; on a 20-block toppling stack that created 60 %
    of the initial energy), the element-wise difference keeps it to rounding."""
    rng = np.random.default_rng(3)
    n = 200
    stiffness = np.tile(1e12 * np.eye(6), (n, 1, 1))
    d = rng.normal(size=(n, 6)) * 1e-2
    product = np.einsum("nij,nj->ni", stiffness, d)
    imbalance = rng.normal(size=(n, 6)) * 1e-3  # K₀D − F₀, ~1e-13 of K₀D
    quadratic = BlockQuadratic(stiffness, product - imbalance, np.ones(n, bool))
    direction = rng.normal(size=(n, 6))
    exact = float(np.sum(direction * (product - quadratic.forces)))
    a, _ = quadratic.along(product, direction, np.zeros_like(direction))
    assert abs(a - exact) <= 1e-9 * abs(exact)
    assert abs(exact - float(np.sum(direction * imbalance))) <= 1e-2 * abs(exact)


def test_a_run_counts_newton_iterations_and_chord_steps_apart(monkeypatch):
    """summary["iterations"] = Newton iterations + chord steps; summary["newton_iterations"]
    the Newton iterations alone (assembled systems), counted here from minimise() itself."""
    import dda
    import dda.solve.step as step_module
    from dda.bench.scenes import wall_scene

    counted = {"newton": 0, "chords": 0}
    original = step_module.minimise

    def counting(*args, **kwargs):
        result = original(*args, **kwargs)
        counted["newton"] += result.solves
        counted["chords"] += result.chords
        return result

    monkeypatch.setattr(step_module, "minimise", counting)
    summary = dda.simulate(dda.load_scene(wall_scene(6, steps=20))).summary
    assert counted["chords"] > 0  # the run has both kinds
    assert summary["newton_iterations"] == counted["newton"]
    assert summary["iterations"] == counted["newton"] + counted["chords"]
    assert summary["newton_iterations_per_step"] == counted["newton"] / 20
