"""Verification cases: discover them, run the DDA and the FEM, judge the comparison.

A case is a scene file ``cases/verify/NAME.toml`` with its expectations in
``cases/verify/NAME.expect.toml`` (:mod:`verify.comparison.expect`); both ship with dda
as package data (:mod:`dda.cases`), so an installed suite finds them too.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.resources.abc import Traversable
from pathlib import Path

import numpy as np

import dda
import dda.cases
from dda import Scene
from verify.comparison.compare import Row, max_errors
from verify.comparison.dda_side import DdaSide
from verify.comparison.expect import Expectation, ExpectationError, load_expectation
from verify.fem.in_situ import excavated
from verify.fem.statics import FemOptions, FemSolution
from verify.fem.turn import turned_scene
from verify.harness.runners import RUNNERS

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
    """Everything one case produced.

    ``dda`` and ``fem`` are the frame and the FEM solution the pictures show
    (static: the final state; dynamic: the last step; fracture: the frame
    before the break). ``reference`` is the FEM side of the case as
    :func:`run_case` can take it back (it depends on the scene alone);
    ``series`` holds what a case has beyond one state (histories, onsets).
    """

    case: Case
    scene: Scene
    expectation: Expectation
    dda: DdaSide
    fem: FemSolution
    rows: list[Row]
    verdicts: list[Verdict]
    seconds: dict[str, float] = field(default_factory=dict)
    reference: object = None
    series: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether every check is within its tolerance."""
        return all(v.passed for v in self.verdicts)


@dataclass(frozen=True)
class CaseError:
    """A case (or a study) that raised instead of giving verdicts: ERROR in the report."""

    name: str
    message: str  # "ExceptionType: message"


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
            raise KeyError(
                f"unknown verification case(s): {', '.join(missing)}; the cases are "
                + ", ".join(sorted(known))
            )
        cases = [known[n] for n in names]
    if quick:
        cases = [c for c in cases if load_expectation(c.expect_path).quick]
    return cases


def judge(rows: list[Row], expectation: Expectation) -> list[Verdict]:
    """A verdict for every check the expectation declares."""
    verdicts = []
    for name, check in expectation.checks.items():
        chosen = [r for r in rows if r.quantity == name and check.applies_to(r.item, r.component)]
        worst = max_errors(chosen)
        verdicts.append(Verdict(name, worst.get(name, float("nan")), check.tolerance, check.why))
    return verdicts


def fem_options(expectation: Expectation) -> FemOptions:
    """The case's element order and size."""
    return FemOptions(order=expectation.fem_order, size=expectation.fem_size)


@contextmanager
def engine_environment(variables: dict[str, str]) -> Iterator[None]:
    """The case's ``DDA_*`` variables set while it runs, the previous values restored."""
    before = {name: os.environ.get(name) for name in variables}
    os.environ.update(variables)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def run_case(case: Case, reference=None) -> CaseResult:
    """Run one case: DDA, FEM, comparison and verdicts.

    ``reference``: the FEM side of an earlier run of this case
    (``CaseResult.reference``) to reuse: it depends on the scene alone, so it
    can be kept while the engine changes.
    """
    scene, expectation = case.load()
    with engine_environment(expectation.environment):
        result = RUNNERS[expectation.kind](scene, expectation, fem_options(expectation), reference)
    unknown = set(expectation.offsets) - {r.key for r in result.rows}
    if unknown:
        raise ExpectationError(
            f"{case.expect_path}: offsets: no such rows: {', '.join(sorted(unknown))}"
        )
    verdicts = judge(result.rows, expectation)
    # a case compared in a turned state (verify.fem.turn) is drawn there, after its stages
    scene = turned_scene(excavated(scene), expectation.fem_turn, expectation.fem_about)
    log.info(
        "%s: %s",
        case.name,
        ", ".join(f"{v.quantity} {v.error:.2e}/{v.tolerance:.0e}" for v in verdicts),
    )
    return CaseResult(
        case,
        scene,
        expectation,
        result.dda,
        result.fem,
        result.rows,
        verdicts,
        result.seconds,
        result.reference,
        result.series,
    )
