"""``dda verify [CASES...] [-o DIR] [--quick]``: the FEM verification suite.

Registered with the ``dda`` command through the ``dda.commands`` entry point
(``verify = "verify.cli:register"``); also ``python -m verify``.
Exit status 0 when every case is within its stated tolerances, 1 when a check
fails, 2 on bad input (an unknown case, a scene or expectation refused, an output
folder that cannot be written: all checked before any case runs), 3 when a case or
study raised (it is ERROR in the report; the other cases still run).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_ERRORS = 0, 1, 2, 3
DESCRIPTION = (
    "The FEM verification suite: re-solve each case's blocks with finite elements "
    "(scikit-fem) and compare stresses, displacements and contact states with the DDA run. "
    "Exit status 0 when every case is within its stated tolerances, 1 when a check fails, "
    "2 on bad input, 3 when a case raised (ERROR in the report)."
)


def _output_path(text: str) -> Path:
    """argparse type: a folder name, not empty (``-o ""`` would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; give a folder name")
    return Path(text)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the verify command."""
    parser.add_argument("cases", nargs="*", help="case names (default: all in cases/verify)")
    parser.add_argument(
        "-o",
        "--output",
        type=_output_path,
        default=Path("out/verify"),
        help="output directory (default: out/verify)",
    )
    parser.add_argument("--quick", action="store_true", help="only the quick cases")
    parser.add_argument("--no-images", action="store_true", help="skip the pictures")
    parser.add_argument(
        "--no-convergence", action="store_true", help="skip the FEM convergence study"
    )
    parser.add_argument(
        "--no-refinement", action="store_true", help="skip the block-refinement study"
    )
    parser.add_argument(
        "--refinement-max",
        type=int,
        default=None,
        metavar="K",
        help="largest k of the block-refinement study, a power of 2 (default 16; --quick: 4)",
    )
    parser.add_argument(
        "--cases-dir",
        type=Path,
        default=None,
        help="directory of NAME.toml + NAME.expect.toml (default: cases/verify)",
    )


def register(subparsers) -> None:
    """Add ``verify`` to the ``dda`` command's sub-parsers."""
    parser = subparsers.add_parser(
        "verify",
        help="compare DDA with FEM (scikit-fem) on the verification cases",
        description=DESCRIPTION,
    )
    add_arguments(parser)
    parser.set_defaults(func=run_verify)


def run_verify(args: argparse.Namespace) -> int:
    """Run the suite, print the table, write the report; non-zero when a check fails."""
    from dda import SceneError
    from verify.comparison.expect import ExpectationError
    from verify.report import format_console
    from verify.suite import OutputError, run_suite

    problem = _cases_dir_problem(args.cases_dir)
    if problem:
        print(f"dda verify: --cases-dir {args.cases_dir}: {problem}", file=sys.stderr)
        return EXIT_INPUT
    default = 4 if args.quick else 16
    largest = default if args.refinement_max is None else args.refinement_max
    if largest < 1 or largest & (largest - 1):
        print(f"dda verify: --refinement-max: {largest} is not a power of 2", file=sys.stderr)
        return EXIT_INPUT
    try:
        output = run_suite(
            names=args.cases or None,
            outdir=args.output,
            quick=args.quick,
            images=not args.no_images,
            convergence=not args.no_convergence,
            cases_dir=args.cases_dir,
            refinement=0 if args.no_refinement else largest,
            progress=lambda line: print(f"dda verify: {line}", file=sys.stderr, flush=True),
        )
    except KeyError as exc:  # an unknown case name
        print(f"dda verify: {exc.args[0]}", file=sys.stderr)
        return EXIT_INPUT
    except (ExpectationError, SceneError, OutputError) as exc:  # they name file and key
        print(f"dda verify: {exc}", file=sys.stderr)
        return EXIT_INPUT
    print(format_console(output.results, output.errors))
    if output.refinement:
        print(format_findings(output.refinement.findings))
    print(f"report: {Path(args.output) / 'report.md'}")
    if output.errors:
        return EXIT_ERRORS
    return EXIT_OK if output.passed else EXIT_FAILED


def _cases_dir_problem(cases_dir: str | None) -> str | None:
    """Why ``--cases-dir`` cannot be used (no such folder, no case in it), or None (a
    folder without cases passed as "0/0 cases within their tolerances")."""
    if cases_dir is None:
        return None
    folder = Path(cases_dir)
    if folder.exists() and not folder.is_dir():
        return "is a file, not a folder of cases"
    if not folder.is_dir():
        return "no such folder"
    if not any(folder.glob("*.expect.toml")):
        return "no NAME.expect.toml in it"
    return None


def format_findings(findings) -> str:
    """The block-refinement study's findings, one line each."""
    lines = ["block refinement:"]
    for f in findings:
        verdict = "PASS" if f.passed else "FAIL"
        lines.append(f"  {f.body:10s} {f.claim}: {f.value:.3g} (limit {f.limit:.3g}) {verdict}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m verify``."""
    parser = argparse.ArgumentParser(prog="python -m verify", description=DESCRIPTION)
    add_arguments(parser)
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress")
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    return run_verify(args)
