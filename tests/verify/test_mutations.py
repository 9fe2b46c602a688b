"""Verification that can fail: named faults put into the engine, one at a time.

Each case declares in its expectation file (``catches``) the faults of
:mod:`tests.engine_faults` it must catch. Here every fault is applied by
monkeypatching the engine and the cases are run again (their FEM side, which
depends on the scene alone, is reused): exactly the declared cases must fail
(a case that raises under the fault counts as failing: ``dda verify`` reports it
as ERROR). A fault that no quick case catches fails the suite. By default every
fault is put in once and the first quick case that declares it must make
``dda verify`` exit 1 (a failed check, not a raise); the full matrices (quick
cases, all cases) run with ``-m slow``.
"""

from __future__ import annotations

import pytest

from tests.engine_faults import FAULTS, UNCAUGHT, apply_fault
from verify.comparison.expect import load_expectation
from verify.harness.cases import discover, run_case

CASES = {case.name: case for case in discover()}
QUICK = [case.name for case in discover(quick=True)]
DECLARED = {name: set(load_expectation(c.expect_path).catches) for name, c in CASES.items()}


def catching(fault: str, names: list[str]) -> set[str]:
    """The cases among ``names`` that declare they catch ``fault``."""
    return {name for name in names if fault in DECLARED[name]}


def fails(name: str, references: dict) -> bool:
    """Whether case ``name`` fails (or raises) with the engine as it is now."""
    try:
        return not run_case(CASES[name], references.get(name)).passed
    except Exception:  # noqa: BLE001 - a case that raises is an ERROR row: caught, loudly
        return True


def failing(names: list[str], references: dict) -> set[str]:
    """The cases among ``names`` that fail or raise with the engine as it is now."""
    return {name for name in names if fails(name, references)}


@pytest.fixture(scope="module")
def references() -> dict:
    """The FEM side of every quick case, from a run of the unchanged engine (which passes)."""
    out = {}
    for name in QUICK:
        result = run_case(CASES[name])
        assert result.passed, name
        out[name] = result.reference
    return out


def test_declared_faults_exist_and_every_fault_is_caught_by_a_quick_case():
    for name, faults in DECLARED.items():
        assert faults <= set(FAULTS), (name, faults - set(FAULTS))
    uncaught = [fault for fault in FAULTS if not catching(fault, QUICK)]
    assert not uncaught


def test_the_acceptance_faults_are_among_them():
    assert {"penalty_x0.5", "gravity_dropped", "young_x0.97", "poisson_zero"} <= set(FAULTS)
    # issue 37's table of engine faults
    assert {
        "inertia_x0.95",
        "velocity_x0.95",
        "stress_replaced",
        "stress_twice",
        "plane_swapped",
        "friction_sin",
        "shear_penalty_x0.1",
        "shear_reset",
        "gap_offset",
        "load_at_centroid",
        "spring_at_centroid",
        "cohesion_dropped",
        "al_wrong_sign",
        "rotation_linearised",
        "al_halved",
        "stress_rotated_backwards",
        "gravity_one_density",
        "pushout_in_velocity",
    } <= set(FAULTS)
    assert not UNCAUGHT


@pytest.mark.slow
@pytest.mark.parametrize("fault", FAULTS)
def test_quick_cases_catch_exactly_what_they_declare(fault, references, monkeypatch):
    apply_fault(monkeypatch, fault)
    assert failing(QUICK, references) == catching(fault, QUICK)


@pytest.mark.parametrize("fault", FAULTS)
def test_dda_verify_exits_1_under_every_fault(fault, monkeypatch, tmp_path):
    from verify.cli import main

    case = sorted(catching(fault, QUICK))[0]
    apply_fault(monkeypatch, fault)
    options = ["-o", str(tmp_path), "--no-images", "--no-convergence", "--no-refinement"]
    assert main([case, *options]) == 1


@pytest.mark.slow
@pytest.mark.parametrize("fault", FAULTS)
def test_every_case_catches_exactly_what_it_declares(fault, monkeypatch):
    apply_fault(monkeypatch, fault)
    names = sorted(CASES)
    assert failing(names, {}) == catching(fault, names)
