"""Verification cases: discover them, run the DDA and the FEM, judge the comparison.

A case is a scene file ``cases/verify/NAME.toml`` with its expectations in
``cases/verify/NAME.expect.toml`` (:mod:`verify.expect`); both ship with dda
as package data (:mod:`dda.cases`), so an installed suite finds them too.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from pathlib import Path

import numpy as np

import dda
import dda.cases
from dda.scene import Scene
from verify.compare import Row, compare, max_errors
from verify.dda_side import DdaSide
from verify.expect import Expectation, load_expectation
from verify.fem import FemOptions, FemSolution, solve_fem
from verify.interfaces import find_interfaces, joint_between, sticks, with_dda_contacts

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Case:
    """A scene file and its expectation file."""

    name: str
    scene_path: Path | Traversable
    expect_path: Path | Traversable

    def load(self) -> tuple[Scene, Expectation]:
        """The scene and its expectations."""
        return dda.load_scene(self.scene_path), load_expectation(self.expect_path)


@dataclass(frozen=True)
class Verdict:
    """One checked quantity of one case."""

    quantity: str
    error: float
    tolerance: float
    why: str

    @property
    def passed(self) -> bool:
        """Whether every check is within its tolerance."""
        return bool(np.isfinite(self.error) and self.error <= self.tolerance)


@dataclass
class CaseResult:
    """Everything one case produced."""

    case: Case
    scene: Scene
    expectation: Expectation
    dda: DdaSide
    fem: FemSolution
    rows: list[Row]
    verdicts: list[Verdict]
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether every check is within its tolerance."""
        return all(v.passed for v in self.verdicts)


def discover(
    directory: Path | Traversable | None = None,
    names: list[str] | None = None,
    quick: bool = False,
) -> list[Case]:
    """Cases in ``directory`` (default: the shipped ``cases/verify``), optionally by name or
    quick only."""
    directory = dda.cases.folder("verify") if directory is None else directory
    if isinstance(directory, str):
        directory = Path(directory)
    cases = []
    expects = [e for e in directory.iterdir() if e.name.endswith(".expect.toml")]
    for expect in sorted(expects, key=lambda e: e.name):
        name = expect.name.removesuffix(".expect.toml")
        cases.append(Case(name, directory.joinpath(f"{name}.toml"), expect))
    if names:
        known = {c.name: c for c in cases}
        missing = [n for n in names if n not in known]
        if missing:
            raise KeyError(f"unknown verification case(s): {', '.join(missing)}")
        cases = [known[n] for n in names]
    if quick:
        cases = [c for c in cases if load_expectation(c.expect_path).quick]
    return cases


def judge(rows: list[Row], expectation: Expectation) -> list[Verdict]:
    """A verdict for every check the expectation declares."""
    verdicts = []
    for name, check in expectation.checks.items():
        worst = max_errors([r for r in rows if check.applies_to(r.item)])
        verdicts.append(Verdict(name, worst.get(name, float("nan")), check.tolerance, check.why))
    return verdicts


def run_dda(scene: Scene) -> DdaSide:
    """Run the engine on the scene and collect its final state."""
    return DdaSide.from_result(dda.simulate(scene), scene)


def run_fem(scene: Scene, side: DdaSide, options: FemOptions) -> FemSolution:
    """Solve the FEM model with the interfaces the DDA closed."""
    geometric = find_interfaces(scene)
    interfaces = with_dda_contacts(geometric, side.closed_pairs())
    unmatched = set(side.closed_pairs()) - {i.pair for i in geometric}
    if unmatched:
        log.warning("DDA contacts between blocks that do not share a boundary: %s", unmatched)
    for interface in interfaces:
        a, b = scene.blocks[interface.a].name, scene.blocks[interface.b].name
        if not interface.locked and sticks(joint_between(scene, a, b)):
            log.warning(
                "%s|%s slides with friction in the DDA: the FEM treats it as "
                "frictionless (Coulomb sliding is not modelled)",
                a,
                b,
            )
    return solve_fem(scene, interfaces, options)


def run_case(case: Case, size_factor: float = 1.0) -> CaseResult:
    """Run one case: DDA, FEM, comparison and verdicts.

    ``size_factor`` scales the case's element size (2 halves the number of
    elements per length, for quick looks).
    """
    scene, expectation = case.load()
    seconds = {}
    start = time.perf_counter()
    side = run_dda(scene)
    seconds["dda"] = time.perf_counter() - start
    size = expectation.fem_size * size_factor if expectation.fem_size else None
    options = FemOptions(order=expectation.fem_order, size=size)
    start = time.perf_counter()
    fem = run_fem(scene, side, options)
    seconds["fem"] = time.perf_counter() - start
    rows = compare(side, fem, expectation.closed_form)
    verdicts = judge(rows, expectation)
    log.info(
        "%s: %s",
        case.name,
        ", ".join(f"{v.quantity} {v.error:.2e}/{v.tolerance:.0e}" for v in verdicts),
    )
    return CaseResult(case, scene, expectation, side, fem, rows, verdicts, seconds)
