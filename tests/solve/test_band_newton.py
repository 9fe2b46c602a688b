"""The compiled Newton on band systems (dda.solve.band_newton) is the numpy minimise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.contact.potential import ContactTerms
from dda.effects.pair_springs import PairSprings
from dda.solve import band_newton, band_system
from dda.solve.band_system import BandOrder, BandSystem, band_order, band_terms, half_width
from dda.solve.dense_system import DenseSystem, contact_columns
from dda.solve.newton import BlockQuadratic, ContactGeometry, minimise, potential
from dda.solve.policy import StepPolicy
from dda.solve.timing import StageTimer
from tests.helpers import use_policy
from tests.solve.test_dense_system import Rows

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


def random_bolts(seed: int, fixed: np.ndarray, count: int = 5) -> PairSprings:
    """``count`` springs between random blocks (one end fixed for some)."""
    rng = np.random.default_rng(100 + seed)
    n = len(fixed)
    i = rng.integers(0, n, count)
    j = (i + rng.integers(1, n, count)) % n
    rows = rng.normal(size=(2, count, 6))
    return PairSprings(i, j, rows[0], rows[1], rng.uniform(1.0, 20.0, count))


def band_twin(fixed, a, b, rows, base_k, base_f, make_fallback=None, couplings=None):
    """The problem's BandSystem in the band numbering of its contacts (and bolts)."""
    none = np.zeros(0, np.int64)
    bolts = (none, none) if couplings is None else (couplings.block_i, couplings.block_j)
    numbering = BandOrder().numbering(fixed, a, b, *bolts)
    return BandSystem(
        fixed, a, b, rows, base_k, base_f, True, couplings, numbering, StageTimer(),
        make_fallback,
    )  # fmt: skip


def test_a_chain_of_blocks_is_numbered_along_the_chain():
    """Ten free blocks in a chain, given shuffled, between two fixed ones: each block's
    neighbours are next to it in the numbering, so the band is two blocks wide (kd =
    11), where the given numbering spreads over most of K."""
    rng = np.random.default_rng(3)
    labels = rng.permutation(12)  # labels[k]: the block at place k along the chain
    fixed = np.zeros(12, bool)
    fixed[labels[[0, 11]]] = True
    a, b = labels[:-1], labels[1:]
    position = band_order(fixed, a, b)
    assert sorted(position[~fixed]) == list(range(10)) and np.all(position[fixed] == -1)
    assert half_width(contact_columns(position, a, b)) == 11
    given = np.where(fixed, -1, np.cumsum(~fixed) - 1)
    assert half_width(contact_columns(given, a, b)) > 11


@pytest.mark.parametrize("seed", range(3))
def test_compiled_columns_and_width_equal_numpy(seed, monkeypatch):
    """The band numbering's columns and half-width in one compiled pass against
    contact_columns and half_width, on random pairs with fixed blocks (and none)."""
    rng = np.random.default_rng(seed)
    fixed = rng.random(40) < 0.2
    a, b = rng.integers(0, 40, 150), rng.integers(0, 40, 150)
    none = np.zeros(0, np.int64)
    order = BandOrder()
    compiled = order.numbering(fixed, a, b, a[:5], b[:5])
    empty = order.numbering(fixed, a[:0], b[:0], none, none)
    monkeypatch.setattr(band_system, "_columns_kernel", None)
    reference = order.numbering(fixed, a, b, a[:5], b[:5])
    np.testing.assert_array_equal(compiled.contacts, reference.contacts)
    np.testing.assert_array_equal(compiled.bolts, reference.bolts)
    assert compiled.width == reference.width > 5
    assert empty.width == 5 and empty.contacts.shape == (0, 12)


@pytest.mark.parametrize("bolted", [False, True])
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
def test_the_band_kernel_takes_the_numpy_iterations(seed, rule, bolted):
    """The same Newton iterations, chord steps, outcome, factorisations and minimiser (to
    rounding) as the numpy Newton on the dense systems, from D = 0 and, on lower friction
    bounds, from the last pass's end with the kept factorisation (chord first); with
    and without springs between blocks (rock bolts) in K₀."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed, n=12, m=40)
    bolts = random_bolts(seed, fixed) if bolted else None
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed, bolts)
    start = np.zeros_like(base_f)
    kernel_system = band_twin(fixed, a, b, rows, base_k, base_f, couplings=bolts)
    numpy_system = DenseSystem(fixed, a, b, rows, base_k, base_f, True, bolts, StageTimer())
    for chord_first in (False, True):
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


@pytest.mark.parametrize("seed", range(4))
def test_the_band_potential_is_the_numpy_one(seed):
    """Π at random steps D (contacts elastic and at their limit, stuck and slipping, ps = 0
    for some; bolts): the compiled value to rounding, and the same better start."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(seed, n=12, m=40)
    no_shear = np.random.default_rng(seed).uniform(size=len(a)) > 0.8
    terms = dataclasses.replace(terms, shear_penalty=np.where(no_shear, 0.0, terms.shear_penalty))
    bolts = random_bolts(seed, fixed)
    system = band_twin(fixed, a, b, rows, base_k, base_f, couplings=bolts)
    geometry = ContactGeometry(rows, a, b)
    quadratic = BlockQuadratic(base_k, base_f, ~fixed, bolts)
    rng = np.random.default_rng(10 + seed)
    steps = [
        np.where(fixed[:, None], 0.0, rng.normal(scale=0.1, size=base_f.shape)) for _ in (0, 1)
    ]
    with jit.run_work(1, 1e9):
        for d in steps:
            value = band_newton.potential_kernel(
                system.geometry, band_terms(terms), np.ascontiguousarray(d[system.order].ravel())
            )
            assert value == pytest.approx(potential(quadratic, geometry, terms, d), rel=1e-12)
        chosen = system.better_start(terms, steps)
    values = [potential(quadratic, geometry, terms, d) for d in steps]
    assert chosen is steps[int(np.argmin(values))]


def test_a_k_not_positive_definite_goes_to_the_fallback_system():
    """LAPACK refuses K: the pass comes back None, and the rest of the step is the
    fallback system's (here the dense one, whose numpy Newton factorises K by LU)."""
    fixed, a, b, rows, base_k, base_f, terms = random_problem(0, n=12, m=40)
    indefinite = base_k - 50.0 * np.eye(6)

    def dense():
        return DenseSystem(fixed, a, b, rows, indefinite, base_f, True, None, StageTimer())

    system = band_twin(fixed, a, b, rows, indefinite, base_f, dense)
    with jit.run_work(1, 1e9):
        assert system.minimise(terms, np.zeros_like(base_f), 5) is None
        assert system.minimise(terms, np.zeros_like(base_f), 5) is None
    d = system(terms.penalty, terms.shear_penalty, terms.normal_base, terms.shear_base)
    assert np.all(np.isfinite(d)) and system.factorisations == 1


@pytest.mark.parametrize("method", ["penalty", "augmented-lagrangian"])
def test_a_run_on_band_systems_is_the_numpy_newtons_run(monkeypatch, method):
    """The 8 x 8 wall (384 unknowns) as a long run takes it, every step in band storage,
    against the numpy Newton on the same systems held dense, both with the rules of numpy
    systems of its size (band systems' own rules take chord steps first, conjugated: the
    random problems above check the pass under them): over the first 4 steps the
    same linear solves and factorisations and vertices to 1e-9 m; over 40 steps within
    1e-6 m (0.15 % of the wall's 0.7 mm of motion). The wall rings: from step 5 the two
    runs' Newton passes stop, within the Newton tolerance (‖∇Π‖ ≤ 1e-4 of its scale), at
    iterates a rounding apart, and they stay about 2e-7 m apart from step 20 on."""
    import dda.solve.step

    made = []
    build = BandSystem.__init__

    def counted(self, *args, **kwargs):
        build(self, *args, **kwargs)
        made.append(self.size)

    monkeypatch.setattr(BandSystem, "__init__", counted)
    rules = StepPolicy.size_rules  # the rules of numpy systems of its size, in both
    monkeypatch.setattr(
        StepPolicy,
        "size_rules",
        lambda self, rows, dynamic=True, band=False: rules(self, rows, dynamic),
    )

    def run(steps):
        with jit.run_work(65, 10_000):
            result = dda.simulate(dda.load_scene(wall_scene(8, method=method, steps=steps)))
        return np.concatenate(result.final.vertices), result.summary

    runs = [run(4), run(40)]
    assert len(made) >= 44 and set(made) == {384}

    def numpy_newton(cache, blocks, contacts, rows, base_k, base_f, law, couplings, timer, _):
        return DenseSystem(
            blocks.fixed, contacts.block_a, contacts.block_b, rows, base_k, base_f,
            law.friction, couplings, timer,
        )  # fmt: skip

    monkeypatch.setattr(dda.solve.step, "_band_system", numpy_newton)
    monkeypatch.setattr(DenseSystem, "minimise", lambda self, *a, **k: None)
    monkeypatch.setattr(DenseSystem, "better_start", lambda self, *a, **k: None)
    oracles = [run(4), run(40)]
    (band, band_summary), (oracle, oracle_summary) = runs[0], oracles[0]
    np.testing.assert_allclose(band, oracle, rtol=0, atol=1e-9)
    for count in ("iterations", "factorisations", "newton_iterations"):
        assert band_summary.get(count) == oracle_summary.get(count)
    np.testing.assert_allclose(runs[1][0], oracles[1][0], rtol=0, atol=1e-6)
    assert runs[1][1]["cut_steps"] == oracles[1][1]["cut_steps"] == 0


def test_a_band_too_wide_to_pay_is_numbered_once(monkeypatch):
    """With BAND_WORK at 1.5e7, the 20 x 20 wall (2,400 unknowns, kd 125: n kd² = 3.8e7)
    runs on the sparse systems; its band numbering is made at the first step and not
    again."""
    use_policy(monkeypatch, band_work=1.5e7)
    numberings = []
    made = band_system.band_order

    def counted(*args):
        numberings.append(1)
        return made(*args)

    monkeypatch.setattr(band_system, "band_order", counted)
    built = []
    monkeypatch.setattr(BandSystem, "__init__", lambda self, *a, **k: built.append(1))
    with jit.run_work(401, 10_000):
        result = dda.simulate(dda.load_scene(wall_scene(20, steps=3)))
    assert result.summary["steps"] == 3
    assert len(numberings) == 1 and not built
