"""A step's outer loop compiled on band systems (dda.solve.band_step) is the Python loop."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import dda
from dda import jit
from dda.bench.scenes import wall_scene
from dda.contact.contact_set import ContactSet
from dda.contact.law import ContactLaw, JointProperties
from dda.effects.base import StepContext
from dda.result import LOCKED, OPEN, SLIDING
from dda.solve import band_newton, band_step
from dda.solve.dense_system import DenseSystem
from dda.solve.newton import BlockQuadratic
from dda.solve.policy import DEFAULT
from dda.solve.step import _StepLoop
from dda.solve.timing import StageTimer
from tests.helpers import use_policy
from tests.solve.test_band_newton import band_twin, random_problem
from tests.test_cases import load_case

pytestmark = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")

WRITTEN = (
    "intact", "penalty", "normal_multiplier", "shear_multiplier", "state", "slide_direction",
    "normal_force", "shear_force", "penetration", "slip",
)  # fmt: skip


def random_contacts(seed: int, m: int) -> tuple[ContactSet, JointProperties]:
    """Contacts in every state, some found this step (locked, as the contact search makes
    them), some bonded (cohesion, tension)."""
    rng = np.random.default_rng(500 + seed)
    contacts = dataclasses.replace(
        ContactSet.empty(),
        **{name: np.zeros(m, np.int64) for name in ("vertex", "edge", "block_a", "block_b")},
        key=np.arange(m, dtype=np.int64),
        state=rng.choice(np.array([OPEN, SLIDING, LOCKED], np.int8), m),
        normal_multiplier=rng.uniform(0.0, 1.0, m) * (rng.uniform(size=m) > 0.5),
        shear_multiplier=rng.uniform(-0.3, 0.3, m),
        penalty=rng.uniform(5.0, 50.0, m),
        reference=np.zeros(m),
        slide_direction=rng.choice([-1.0, 1.0], m),
        intact=rng.uniform(size=m) > 0.6,
        fresh=rng.uniform(size=m) > 0.8,
        normal_force=rng.uniform(0.0, 2.0, m),
        shear_force=np.zeros(m),
        penetration=rng.normal(scale=0.05, size=m),
        slip=np.zeros(m),
    )
    contacts.state[contacts.fresh] = LOCKED  # found this step: touching, stuck (merge)
    joints = JointProperties(
        friction=rng.uniform(0.3, 0.9, m),
        cohesion=rng.uniform(0.0, 0.3, m) * (rng.uniform(size=m) > 0.5),
        tensile=rng.uniform(0.0, 0.4, m) * (rng.uniform(size=m) > 0.5),
    )
    return contacts, joints


def random_loop(seed: int, augmented: bool, static: bool, indefinite: bool = False):
    """A step's loop on a random band problem (tests.solve.test_band_newton.random_problem)."""
    fixed, a, b, rows, base_k, base_f, _ = random_problem(seed, n=12, m=40)
    if indefinite:
        base_k = base_k - 50.0 * np.eye(6)
    contacts, joints = random_contacts(seed, len(a))
    contacts.block_a, contacts.block_b = a, b

    def dense():
        return DenseSystem(fixed, a, b, rows, base_k, base_f, True, None, StageTimer())

    system = band_twin(fixed, a, b, rows, base_k, base_f, dense)
    law = ContactLaw(augmented=augmented, tolerance=1e-3, shear_ratio=0.5, friction=True)
    velocity = np.random.default_rng(seed).normal(scale=0.2, size=(len(fixed), 6))
    blocks = SimpleNamespace(count=len(fixed), fixed=fixed, velocity=velocity)
    ctx = StepContext(dt=0.1, time=0.1, step=1, static=static)
    return _StepLoop(
        blocks, contacts, rows, joints, law, system, 60,
        DEFAULT.size_rules(60, not static, band=True), ctx, StageTimer(),
        BlockQuadratic(base_k, base_f, ~fixed, None), DEFAULT,
    )  # fmt: skip


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("augmented", [False, True])
@pytest.mark.parametrize("static", [False, True])
def test_the_compiled_loop_is_the_python_loop(seed, augmented, static):
    """Random problems with friction, bonds that can break, guessed first bounds and
    (AL) multipliers and growing penalties, with the mid rules (chord steps first,
    conjugated) in dynamic steps and the small ones in static steps: the same Newton
    iterations, chord steps and factorisations, and the same D and contact data to the
    bit (the two loops make the same operations in the same order: Anderson's products
    row by row, norms as BLAS's dot); the dissipation, a sum over the contacts in another
    order, to 1e-12."""
    compiled, oracle = random_loop(seed, augmented, static), random_loop(seed, augmented, static)
    with jit.run_work(1, 1e9):
        d, solves, chords, converged, dissipated = band_step.solve_on_band(
            compiled.system, compiled
        )
        d_, solves_, chords_, converged_, dissipated_ = oracle.solve()
    assert (solves, chords, converged) == (solves_, chords_, converged_)
    assert compiled.system.factorisations == oracle.system.factorisations >= 1
    np.testing.assert_array_equal(d, d_)
    assert dissipated == pytest.approx(dissipated_, rel=1e-12, abs=1e-15)
    for name in WRITTEN:
        got, want = getattr(compiled.contacts, name), getattr(oracle.contacts, name)
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_a_k_not_positive_definite_leaves_the_step_to_the_python_loop():
    """LAPACK refuses K: the compiled loop returns None with the contacts untouched and
    no factorisation kept; the Python loop then solves the step on the fallback system."""
    loop = random_loop(0, augmented=True, static=False, indefinite=True)
    before = loop.contacts.copy()
    with jit.run_work(1, 1e9):
        assert band_step.solve_on_band(loop.system, loop) is None
        for name in WRITTEN:
            np.testing.assert_array_equal(getattr(loop.contacts, name), getattr(before, name))
        state = loop.system.factor.state
        assert state[band_newton.FAILED] == 0 and state[band_newton.HAS_FACTOR] == 0
        d, *_ = loop.solve()
    assert np.all(np.isfinite(d))


def run(scene, compiled: bool, monkeypatch) -> tuple[dda.Result, int]:
    """The run, and the steps the compiled loop solved."""
    use_policy(monkeypatch, band_loop_compiled=compiled)
    solved = []
    solve = band_step.solve_on_band

    def counted(*args):
        solved.append(solve(*args))
        return solved[-1]

    monkeypatch.setattr(band_step, "solve_on_band", counted)
    with jit.run_work(1_000, 10_000):
        return dda.simulate(scene), len(solved)


@pytest.mark.parametrize(
    ("name", "steps"),
    [("wall", 60), ("rock_slope", 120), ("paper_two_blocks", None), ("bolted_block", None)],
)
def test_a_run_with_the_compiled_loop_is_the_python_loops_run(name, steps, monkeypatch):
    """Whole runs: the 6 x 6 wall (AL; it rings), the rock slope (AL, bedding sliding,
    the Anderson-mixed bounds), the paper's two blocks and the bolted block (static,
    rock bolts): the same linear solves and factorisations every step, and the same
    vertices to the bit."""
    if name == "wall":
        scene = dda.load_scene(wall_scene(6, method="augmented-lagrangian", steps=steps))
    else:
        overrides = {} if steps is None else {"steps": steps}
        scene = load_case(name, overrides)
    (compiled, solved), (oracle, none) = (run(scene, flag, monkeypatch) for flag in (True, False))
    assert none == 0 and solved >= compiled.summary["steps"]
    np.testing.assert_array_equal(compiled.history["iterations"], oracle.history["iterations"])
    assert compiled.summary["factorisations"] == oracle.summary["factorisations"]
    got, want = np.concatenate(compiled.final.vertices), np.concatenate(oracle.final.vertices)
    np.testing.assert_array_equal(got, want)
