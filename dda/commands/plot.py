"""The ``dda plot OUTDIR`` command: pictures of a run's measurement histories.

Registered as an entry point of ``dda.commands`` (pyproject.toml); the
drawing is :func:`dda.io.history_plots.plot_histories`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from dda.commands.cli import output_path

EXIT_OK, EXIT_INPUT = 0, 2


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``plot`` sub-command to the ``dda`` command line."""
    parser = subparsers.add_parser(
        "plot",
        help="draw the measurement histories of a run (one PNG per quantity)",
        description="Draw OUTDIR/history_points.csv (a run of a scene with [[measure]]): "
        "one PNG per quantity against time, in OUTDIR/plots unless -o.",
    )
    parser.add_argument("outdir", type=Path, help="output directory of dda run")
    parser.add_argument("-o", "--output", type=output_path, help="folder for the PNGs")
    parser.set_defaults(func=plot_command)
    return parser


def plot_command(args: argparse.Namespace) -> int:
    """``dda plot``: 0 with the PNGs written, 2 when OUTDIR holds no measurements."""
    from dda.io.frame_files import run_units
    from dda.io.history_plots import plot_histories
    from dda.io.output_paths import OutputError, check_output_dir
    from dda.io.tables import POINTS_NAME

    points = args.outdir / POINTS_NAME
    if not points.is_file():
        print(f"dda plot: {args.outdir}: {_no_points(args.outdir)}", file=sys.stderr)
        return EXIT_INPUT
    summary = _summary(args.outdir)
    units = run_units(summary, args.outdir, POINTS_NAME)  # not SI where it says none
    try:
        if args.output is not None:
            check_output_dir(args.output)
        written = plot_histories(args.outdir, args.output, summary.get("title") or "", units)
    except (ValueError, OutputError) as exc:
        print(f"dda plot: {exc}", file=sys.stderr)
        return EXIT_INPUT
    for path in written:
        print(path)
    return EXIT_OK


def _no_points(outdir: Path) -> str:
    """Why ``outdir`` gives no measurements to draw."""
    from dda.io.tables import POINTS_NAME

    if outdir.is_file():
        return "is a file; give the run's output folder (the one that holds it)"
    if not outdir.is_dir():
        return "no such directory"
    return f"has no {POINTS_NAME} (does the scene have [[measure]]?)"


def _summary(outdir: Path) -> dict:
    try:
        summary = json.loads((outdir / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return summary if isinstance(summary, dict) else {}
