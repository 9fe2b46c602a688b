"""The step's settings in one place (dda/solve/policy.py) and the systems behind one
protocol (dda/solve/systems.py)."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import pytest

from dda.solve.band_system import BandSystem
from dda.solve.dense_system import DenseSystem
from dda.solve.policy import DEFAULT, StepPolicy
from dda.solve.step import LinearCache, _PieceSystem
from dda.solve.systems import StepSystems

SOLVE = Path(__file__).resolve().parents[2] / "dda" / "solve"
# module-level numbers in dda/solve that are not thresholds of the step, and why
NOT_THRESHOLDS = {
    ("assembly.py", "BLOCK"): "six unknowns per block: Shi's method",
    ("band_newton.py", "HAS_FACTOR"): "an index into the kernels' state flags",
    ("band_newton.py", "FACTORISATIONS"): "an index into the kernels' state flags",
    ("band_newton.py", "FAILED"): "an index into the kernels' state flags",
    ("band_newton.py", "_LOWER"): "LAPACK's character 'L'",
    ("contact_dashpots.py", "SHEAR_DAMPING_RATIO"): "the restitution law's, not the solve's",
    ("integrator.py", "SHI_GAMMA"): "the scene's default Newmark γ",
    ("interior_contacts.py", "UNKNOWNS"): "a contact's unknowns: N', w, F, u, v, σ₁, σ₂",
    ("unsymmetric.py", "UNSYMMETRIC"): "PARDISO's code of a real unsymmetric matrix",
    ("thread_policy.py", "WINDOW"): "the thread policy's sampling, not the step's",
    ("thread_policy.py", "FIRST_WINDOW"): "the thread policy's sampling, not the step's",
}


def module_numbers(path: Path) -> set[str]:
    """Names bound at module level to a number (or a tuple of numbers)."""
    names = set()
    for node in ast.parse(path.read_text()).body:
        if not isinstance(node, ast.Assign):
            continue
        values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
        numeric = all(
            isinstance(v, ast.Constant) and isinstance(v.value, int | float)
            and not isinstance(v.value, bool) for v in values
        )  # fmt: skip
        if not numeric:
            continue
        for target in node.targets:
            targets = target.elts if isinstance(target, ast.Tuple) else [target]
            names |= {t.id for t in targets if isinstance(t, ast.Name)}
    return names


def test_the_steps_thresholds_live_in_the_policy_alone():
    """No module of dda/solve but policy.py binds a threshold at module level."""
    found = {
        (path.name, name)
        for path in sorted(SOLVE.glob("*.py"))
        if path.name != "policy.py"
        for name in module_numbers(path)
    }
    assert found == set(NOT_THRESHOLDS)


def test_the_environment_is_read_into_the_policy(monkeypatch):
    monkeypatch.setenv("DDA_SOLVER", " SuperLU ")
    monkeypatch.setenv("DDA_SYSTEMS", "sparse")
    monkeypatch.setenv("DDA_THREADS", "2")
    policy = StepPolicy.from_environment()
    assert (policy.solver, policy.systems, policy.threads) == ("superlu", "sparse", 2)
    assert policy.solver_threads() == 2
    assert dataclasses.replace(policy, solver="", systems="", threads=None) == DEFAULT
    monkeypatch.setenv("DDA_SYSTEMS", "band")
    with pytest.raises(ValueError, match="DDA_SYSTEMS='band': expected sparse"):
        StepPolicy.from_environment()


def test_the_size_rules_grow_with_the_system():
    """Plain chord steps in small systems; conjugated ones from mid_rows (dynamic steps)
    and large_rows (any); the bounds after every solve from huge_rows; band systems take
    the mid rules below mid_rows and the large ones from there."""
    rules = DEFAULT.size_rules
    assert DEFAULT.mid_rows < DEFAULT.large_rows < DEFAULT.huge_rows
    assert rules(100) == rules(100, dynamic=False) and not rules(100).chord_first
    assert rules(DEFAULT.mid_rows).rate == DEFAULT.mid_chord_rate
    assert rules(DEFAULT.mid_rows, dynamic=False).rate == DEFAULT.chord_rate
    assert rules(DEFAULT.large_rows, dynamic=False).conjugate
    assert rules(DEFAULT.huge_rows).bounds_every_solve
    assert rules(100, band=True).rate == DEFAULT.mid_chord_rate
    assert rules(DEFAULT.mid_rows, band=True).rate == DEFAULT.large_chord_rate


def test_a_linear_cache_hands_its_policy_to_the_solver_and_the_band_numbering():
    policy = dataclasses.replace(DEFAULT, max_pcg_iterations=2, reorder_growth=3.0)
    cache = LinearCache(policy)
    assert cache.solver.policy is policy and cache.solver.pcg_budget == 2  # at most the max
    assert cache.band.reorder_growth == 3.0


@pytest.mark.parametrize("system", [BandSystem, DenseSystem, _PieceSystem])
def test_every_system_answers_the_protocol(system):
    """What the step asks of a system, each kind has; the step never tests their types."""
    for name in ("compiled_passes", "sums_by_rows"):
        assert isinstance(getattr(system, name), bool)
    members = [m for m in vars(StepSystems) if not m.startswith("_") or m == "__call__"]
    for name in members:
        assert hasattr(system, name), name
    assert "isinstance(system" not in (SOLVE / "step.py").read_text()
