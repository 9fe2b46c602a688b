"""``dda tradeoff CASE [--grid SPEC] [-o DIR] [--scheduler ADDRESS] [--serial]``."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

from dda.io.output_paths import OutputError, check_output_dir
from dda.tradeoff.cases import fine_setting, get_case
from dda.tradeoff.grid import expand, parse_grid
from dda.tradeoff.report import markdown_table, pareto_plot, write_csv
from dda.tradeoff.runner import add_errors, run_one, sweep

log = logging.getLogger(__name__)


def register(subparsers: Any) -> None:
    """Add the ``tradeoff`` sub-command (entry point of group ``dda.commands``)."""
    p = subparsers.add_parser(
        "tradeoff",
        help="accuracy against time: sweep contact and time-step settings",
        description="Run CASE (sliding_block, pushed_block, stack, wall or a scene file) for every "
        "setting of the grid, measure the error against the closed form (or a fine run) and "
        "the wall time; write DIR/CASE.csv, DIR/CASE.md and DIR/pareto_CASE.png.",
    )
    p.add_argument("case", help="built-in case name or scene file")
    p.add_argument(
        "--grid",
        default="",
        metavar="SPEC",
        help="e.g. 'method=al,penalty;penalty=1,10;tolerance=1e-4;time_step=0.01;"
        "ratio=0.01;state_band=1e-9,1e-7' (keys not given keep the case's defaults)",
    )
    p.add_argument("-o", "--outdir", type=Path, default=Path("out/tradeoff"))
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask scheduler (default: a local cluster of 2 workers)",
    )
    p.add_argument("--serial", action="store_true", help="run in this process (debugging)")
    p.set_defaults(func=tradeoff_command)


def tradeoff_command(args: argparse.Namespace) -> int:
    """Run the study; return the exit code (0 ok, 2 bad input)."""
    try:
        check_output_dir(args.outdir)
        case = get_case(args.case)
        grid = parse_grid(args.grid, case.grid)
    except OutputError as exc:
        print(f"dda tradeoff: -o {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"dda tradeoff: {exc}", file=sys.stderr)
        return 2
    settings = expand(grid)
    reference = case.reference
    if reference is None:
        fine = run_one(args.case, fine_setting(grid))
        if fine["value"] is None:
            print("dda tradeoff: the fine reference run failed", file=sys.stderr)
            return 3
        reference = fine["value"]
    print(f"{case.name}: {len(settings)} runs", file=sys.stderr)
    rows = sweep(
        args.case, settings, scheduler=args.scheduler, serial=args.serial, progress=_progress
    )
    add_errors(rows, args.case, reference)
    outdir = args.outdir
    write_csv(rows, outdir / f"{case.name}.csv")
    (outdir / f"{case.name}.md").write_text(markdown_table(rows, case.quantity))
    pareto_plot(rows, outdir / f"pareto_{case.name}.png", title=case.name)
    print(markdown_table(rows, case.quantity))
    print(f"wrote {outdir}/{case.name}.csv, .md and pareto_{case.name}.png", file=sys.stderr)
    return 0


def _progress(done: int, total: int, row: dict) -> None:
    print(
        f"[{done}/{total}] {row['method']:<22} p={row['penalty']:<6g} "
        f"dt={row['time_step']:<7g} band={row['state_band']:<6g} "
        f"{row['seconds']:6.2f} s {row['status']}",
        file=sys.stderr,
        flush=True,
    )
