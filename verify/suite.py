"""Run the verification suite and write its report and pictures."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from verify.cases import CaseResult, discover, run_case
from verify.convergence import ConvergencePoint, convergence_study
from verify.refinement import Finding, RefinementPoint, findings, refinement_study
from verify.report import write_json, write_markdown

log = logging.getLogger(__name__)


@dataclass
class SuiteOutput:
    """What a suite run produced."""

    results: list[CaseResult]
    convergence: list[ConvergencePoint] = field(default_factory=list)
    refinement: Refinement | None = None
    files: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every check of every case, and every refinement finding, holds."""
        refined = self.refinement is None or all(f.passed for f in self.refinement.findings)
        return refined and all(r.passed for r in self.results)


@dataclass
class Refinement:
    """The block-refinement study's points, references and findings."""

    points: list[RefinementPoint]
    references: dict[str, dict]
    findings: list[Finding]


def run_refinement(largest: int, progress: Callable[[str], None] | None = None) -> Refinement:
    """The block-refinement study for k = 1, 2, 4, ... up to ``largest``."""
    ks = tuple(2**n for n in range(int(np.log2(largest)) + 1))
    points, references = refinement_study(ks, progress=progress)
    return Refinement(points, references, findings(points))


def run_suite(
    names: list[str] | None = None,
    outdir: Path | None = None,
    quick: bool = False,
    images: bool = True,
    convergence: bool = True,
    cases_dir: Path | None = None,
    refinement: int = 16,
    progress: Callable[[str], None] | None = None,
) -> SuiteOutput:
    """Run the cases (all, by name, or the quick ones) and write the report to ``outdir``.

    ``refinement``: the largest k of the block-refinement study (0: none);
    ``progress``: called with a line of text as every case and study starts.
    Pictures go to ``outdir/images/verify_NAME.png``, ``verify_summary.png``
    and ``verify_refinement.png``.
    """
    cases = discover(cases_dir, names, quick)
    tell = progress or log.info
    results = []
    for number, case in enumerate(cases, 1):
        tell(f"case {number}/{len(cases)}: {case.name}")
        results.append(run_case(case))
    if convergence:
        tell("FEM convergence study")
    points = convergence_study() if convergence else []
    refined = run_refinement(refinement, tell) if refinement else None
    output = SuiteOutput(results, points, refined)
    if outdir is None:
        return output
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    pictures, summary = {}, None
    if images:
        from verify.images import case_image, refinement_chart, summary_chart

        if refined:
            path = outdir / "images" / "verify_refinement.png"
            output.files.append(refinement_chart(refined.points, path))

        for r in results:
            path = case_image(r, outdir / "images" / f"verify_{r.case.name}.png")
            pictures[r.case.name] = f"images/{path.name}"
            output.files.append(path)
        if results:
            output.files.append(summary_chart(results, outdir / "images" / "verify_summary.png"))
            summary = "images/verify_summary.png"
    output.files.append(
        write_markdown(results, outdir / "report.md", pictures, points, summary, refined)
    )
    output.files.append(write_json(results, outdir / "report.json", points, refined))
    return output
