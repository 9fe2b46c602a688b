"""Run the verification suite and write its report and pictures."""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from verify.harness.cases import CaseError, CaseResult, discover, run_case
from verify.pictures.drawing import Painter
from verify.report import write_json, write_markdown
from verify.studies.convergence import ConvergencePoint, convergence_study
from verify.studies.refinement import Finding, RefinementPoint, findings, refinement_study

log = logging.getLogger(__name__)


# the case pictures a forked child draws while the suite goes on (verify.pictures.drawing)
PICTURES_PER_CHILD = 5


class OutputError(Exception):
    """The report's folder cannot be written (checked before any case runs)."""


@dataclass
class SuiteOutput:
    """What a suite run produced."""

    results: list[CaseResult]
    convergence: list[ConvergencePoint] = field(default_factory=list)
    refinement: Refinement | None = None
    files: list[Path] = field(default_factory=list)
    errors: list[CaseError] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every case and study ran, and every check and finding holds."""
        refined = self.refinement is None or all(f.passed for f in self.refinement.findings)
        return not self.errors and refined and all(r.passed for r in self.results)


def check_output(outdir: Path) -> None:
    """Raise :class:`OutputError` saying why ``outdir`` cannot be made or written: a file
    is made (and removed) in it, or in its nearest existing parent; nothing is left."""
    folder = next((p for p in (outdir, *outdir.absolute().parents) if p.exists()), None)
    if folder is None:
        return
    if not folder.is_dir():
        raise OutputError(f"-o {outdir}: cannot write there ({folder} is a file, not a folder)")
    for name, folder_wanted in (("images", True), ("report.md", False), ("report.json", False)):
        path = outdir / name  # what the suite writes there: a folder and two files
        if path.exists() and path.is_dir() != folder_wanted:
            what = "a file, not a folder" if folder_wanted else "a folder, not a file"
            raise OutputError(f"-o {outdir}: cannot write there ({path} is {what})")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise OutputError(f"-o {outdir}: cannot write there ({reason})") from exc


def guarded(name: str, errors: list[CaseError], work: Callable[[], object]) -> object:
    """``work()``, or None when it raises: the error goes to ``errors`` and the log.

    A case that raises (the engine's SimulationError, a failed FEM solve, any fault)
    is reported as ERROR and the suite goes on with the others.
    """
    try:
        return work()
    except Exception as exc:  # noqa: BLE001 - every fault of a case is reported, not raised
        message = f"{type(exc).__name__}: {exc}"
        log.error("%s raised %s", name, message)
        errors.append(CaseError(name, message))
        return None


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
    if outdir is not None:  # an unwritable report folder first: nothing read or run
        outdir = Path(outdir)
        check_output(outdir)
    for case in cases:  # bad input (scene, expectations) is refused before any case runs
        case.load()
    if outdir is not None:
        outdir.mkdir(parents=True, exist_ok=True)
    tell = progress or log.info
    drawing = outdir is not None and images
    folder = None if outdir is None else outdir / "images"
    painter, pictures, batch, drawn = Painter(), {}, [], []
    if drawing:
        folder.mkdir(parents=True, exist_ok=True)
    results, errors = [], []
    for number, case in enumerate(cases, 1):
        tell(f"case {number}/{len(cases)}: {case.name}")
        result = guarded(case.name, errors, partial(run_case, case))
        if result is not None:
            results.append(result)
            if drawing:
                from verify.pictures.images import case_image

                path = folder / f"verify_{case.name}.png"
                batch.append(partial(case_image, result, path))
                pictures[case.name] = f"images/{path.name}"
                drawn.append(path)
        if len(batch) == PICTURES_PER_CHILD:  # drawn while the next cases run
            painter.submit(batch)
            batch = []
    painter.submit(batch)  # the last ones while the studies run (verify.pictures.drawing)
    points = []
    if convergence:
        tell("FEM convergence study")
        points = guarded("FEM convergence study", errors, convergence_study) or []
    refined = None
    if refinement:
        work = partial(run_refinement, refinement, tell)
        refined = guarded("block refinement study", errors, work)
    output = SuiteOutput(results, points, refined, errors=errors)
    if outdir is None:
        return output
    summary = None
    if drawing:
        from verify.pictures.images import refinement_chart, summary_chart

        if refined:
            drawn.append(refinement_chart(refined.points, folder / "verify_refinement.png"))
        if results:
            drawn.append(summary_chart(results, folder / "verify_summary.png"))
            summary = "images/verify_summary.png"
        painter.wait()
        output.files += drawn
    output.files.append(
        write_markdown(results, outdir / "report.md", pictures, points, summary, refined, errors)
    )
    output.files.append(write_json(results, outdir / "report.json", points, refined, errors))
    return output
