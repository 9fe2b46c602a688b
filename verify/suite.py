"""Run the verification suite and write its report and pictures."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from verify.cases import CaseResult, discover, run_case
from verify.convergence import ConvergencePoint, convergence_study
from verify.report import write_json, write_markdown

log = logging.getLogger(__name__)


@dataclass
class SuiteOutput:
    """What a suite run produced."""

    results: list[CaseResult]
    convergence: list[ConvergencePoint] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every check is within its tolerance."""
        return all(r.passed for r in self.results)


def run_suite(
    names: list[str] | None = None,
    outdir: Path | None = None,
    quick: bool = False,
    images: bool = True,
    convergence: bool = True,
    cases_dir: Path | None = None,
) -> SuiteOutput:
    """Run the cases (all, by name, or the quick ones) and write the report to ``outdir``.

    Pictures go to ``outdir/images/verify_NAME.png`` and ``verify_summary.png``.
    """
    cases = discover(cases_dir, names, quick)
    results = [run_case(case) for case in cases]
    points = convergence_study() if convergence else []
    output = SuiteOutput(results, points)
    if outdir is None:
        return output
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    pictures, summary = {}, None
    if images:
        from verify.images import case_image, summary_chart

        for r in results:
            path = case_image(r, outdir / "images" / f"verify_{r.case.name}.png")
            pictures[r.case.name] = f"images/{path.name}"
            output.files.append(path)
        if results:
            output.files.append(summary_chart(results, outdir / "images" / "verify_summary.png"))
            summary = "images/verify_summary.png"
    output.files.append(write_markdown(results, outdir / "report.md", pictures, points, summary))
    output.files.append(write_json(results, outdir / "report.json", points))
    return output
