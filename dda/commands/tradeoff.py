"""``dda tradeoff CASE [--grid SPEC] [-o DIR] [--overwrite] [--workers N | --scheduler
ADDRESS | --scheduler-file FILE | --serial] [--threads N] [--repeats N]``."""

from __future__ import annotations

import argparse
import logging
import sys
import textwrap
from pathlib import Path
from typing import Any

from dda.commands.cli import default_outdir, output_path
from dda.commands.cluster_options import (
    add_cluster_options,
    count,
    dask_missing,
    local_workers,
    scheduler_refusal,
)
from dda.io.atomic import write_text
from dda.io.output_paths import OutputError, check_output_dir

log = logging.getLogger(__name__)

WIDTH = 79  # the description's and the epilog's lines (argparse wraps the options' help)
DESCRIPTION = (
    "Run CASE (sliding_block, pushed_block, pendulum, stack, wall or a scene file) for "
    "every setting of the grid, measure the error against the closed form (or a fine run) and "
    "the median wall time of repeated runs; write DIR/CASE.csv, DIR/CASE.md and "
    "DIR/pareto_CASE.png. The client reads the case and sends scenes: workers need no files. "
    "DIR holds one study of CASE: a second one (of a study finished or interrupted) is "
    "refused unless --overwrite, which replaces it."
)
GRID_HELP = (
    "KEY=V1,V2;... with the keys method (al, penalty), penalty (x E), tolerance "
    "(x model size), time_step and ratio (g2), e.g. 'method=al;time_step=0.01,0.02'. "
    "A key given replaces the case's values; a key not given keeps the case's whole "
    "default list (below) and is swept too. Every combination is one setting, run "
    "--repeats times."
)


def register(subparsers: Any) -> None:
    """Add the ``tradeoff`` sub-command (entry point of group ``dda.commands``)."""
    p = subparsers.add_parser(
        "tradeoff",
        help="accuracy against time: sweep contact and time-step settings",
        description=textwrap.fill(DESCRIPTION, WIDTH),
        epilog=defaults_epilog(),
        formatter_class=argparse.RawDescriptionHelpFormatter,  # the epilog's lines as written
    )
    p.add_argument("case", help="built-in case name or scene file")
    p.add_argument("--grid", default="", metavar="SPEC", help=GRID_HELP)
    p.add_argument(
        "-o", "--outdir", type=output_path,
        help="directory for CASE.csv, CASE.md and pareto_CASE.png (default: out/tradeoff_CASE)",
    )  # fmt: skip
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a study of CASE in DIR (else a folder holding one, whole or "
        "interrupted, is refused)",
    )
    add_cluster_options(p)
    p.add_argument(
        "--threads", type=count, default=1, metavar="N", help="solver threads per run (default 1)"
    )
    p.add_argument(
        "--repeats",
        type=_repeats,
        default=3,
        metavar="N",
        help="runs per setting, timed by their median (at least 3; default 3)",
    )
    p.set_defaults(func=tradeoff_command)


def defaults_epilog() -> str:
    """Each case's default grid, in the --grid syntax, and its count of settings."""
    from dda.tradeoff.grid import DEFAULT_GRIDS, SCENE_FILE, default_grid, expand, spec

    said = (
        "default grids (a key not given in --grid sweeps all of its values here; the "
        "penalty method ignores the tolerance):"
    )
    lines = [textwrap.fill(said, WIDTH)]
    for case in DEFAULT_GRIDS:
        grid = default_grid(case, time_step=1.0)  # a scene file's own, for the count
        head = f"{'a scene file' if case == SCENE_FILE else case} ({len(expand(grid))} settings)"
        if case == SCENE_FILE:
            grid["time_step"] = ["the scene's"]
        lines.append(_indented(f"{head}: {spec(grid)}"))
    return "\n".join(lines)


def _indented(text: str) -> str:
    """``text`` wrapped to the help's width, its later lines indented further."""
    return textwrap.fill(
        text, WIDTH, initial_indent="  ", subsequent_indent="      ", break_on_hyphens=False
    )


def _repeats(text: str) -> int:
    from dda.tradeoff.runner import MIN_REPEATS

    value = count(text)
    if value < MIN_REPEATS:
        raise argparse.ArgumentTypeError(f"at least {MIN_REPEATS} (the time is their median)")
    return value


def tradeoff_command(args: argparse.Namespace) -> int:
    """Run the study; return the exit code (0 ok, 2 bad input, 3 the reference run failed)."""
    from dda.parallel import ClusterError
    from dda.tradeoff.outputs import remove_earlier_study
    from dda.tradeoff.report import markdown_table, pareto_plot, plan_line, write_csv
    from dda.tradeoff.runner import Cluster, SweepInterrupted, add_errors, sweep

    args.outdir = args.outdir or default_outdir("tradeoff", args.case)
    prepared = _prepare(args)
    if isinstance(prepared, str):
        print(f"dda tradeoff: {prepared}", file=sys.stderr)
        return 2
    case, grid, tasks, reference, longest = prepared
    cluster = Cluster(
        args.scheduler, args.scheduler_file, local_workers(args), getattr(args, "verbose", 0) > 0
    )
    print(
        f"{case.name}: {plan_line(len(tasks), args.repeats)}"
        + (", and 1 fine reference run" if reference else ""),
        file=sys.stderr,
    )
    print(_grid_line(grid, args.grid), file=sys.stderr)
    if longest is not None:  # a run's own progress is not shown: say what the longest takes
        steps, setting = longest
        print(f"the longest run: {steps:,} steps ({setting.label})", file=sys.stderr)
    try:
        rows, fine_row = sweep(tasks, reference, cluster, serial=args.serial, progress=_progress)
    except SweepInterrupted as stopped:
        return _write_interrupted(stopped, case, reference, args.outdir)
    except ClusterError as exc:  # nothing is written before the sweep
        print(f"dda tradeoff: {exc}", file=sys.stderr)
        return 2
    if reference is not None and (fine_row is None or fine_row["value"] is None):
        print("dda tradeoff: the fine reference run failed", file=sys.stderr)
        return 3
    add_errors(rows, case, case.reference if reference is None else fine_row["value"])
    outdir = args.outdir
    remove_earlier_study(outdir, case.name)  # an interrupted one's too (--overwrite)
    write_csv(rows, outdir / f"{case.name}.csv")
    write_text(outdir / f"{case.name}.md", markdown_table(rows, case.quantity))
    against = "a closed form" if reference is None else "a fine run (not itself converged)"
    title = f"{case.name}: {case.quantity}, against {against}"
    pareto_plot(rows, outdir / f"pareto_{case.name}.png", title=title)
    print(markdown_table(rows, case.quantity))
    print(f"wrote {outdir}/{case.name}.csv, .md and pareto_{case.name}.png", file=sys.stderr)
    return 0


def _prepare(args: argparse.Namespace):
    """(case, grid, tasks, the fine reference task or None), every setting's scene checked
    as its run will check it; or the one-line reason the study is refused (nothing run or
    written then)."""
    from dda.tradeoff.cases import case_name, fine_setting, get_case
    from dda.tradeoff.checks import check_settings
    from dda.tradeoff.grid import expand, parse_grid
    from dda.tradeoff.outputs import check_study_folder
    from dda.tradeoff.runner import Task, make_tasks

    try:
        check_output_dir(args.outdir)
        check_study_folder(args.outdir, case_name(args.case), args.overwrite)
    except OutputError as exc:
        return f"-o {exc}"
    try:
        case = get_case(args.case)
        grid = parse_grid(args.grid, case.grid)
        settings = expand(grid)
        fine = fine_setting(grid) if case.reference is None else None
        longest = check_settings(case, settings, fine)
    except ValueError as exc:  # a SceneError of a scene file, a GridError
        return str(exc)
    if not (args.serial or _has_dask()):
        return dask_missing("tradeoff").removeprefix("dda tradeoff: ")
    refused = scheduler_refusal(args)
    if refused:
        return refused
    tasks = make_tasks(case, settings, args.threads, args.repeats)
    reference = None
    if fine is not None:
        reference = Task(case.name, case.scene(fine), case.measure, fine, args.threads, 1)
    return case, grid, tasks, reference, longest


def _grid_line(grid: dict[str, list], text: str) -> str:
    """The grid swept, naming the keys --grid left at the case's defaults."""
    from dda.tradeoff.grid import KEYS, given_keys, spec

    defaulted = [key for key in KEYS if key not in given_keys(text)]
    said = f" ({', '.join(defaulted)}: the case's defaults)" if defaulted else ""
    return f"grid: {spec(grid)}{said}"


def _write_interrupted(stopped, case, reference, outdir: Path) -> int:
    """Ctrl-C: keep the settings that finished (CSV and table, errors where the closed
    form gives them; a case measured against a fine run has none then); exit 130."""
    from dda.tradeoff.outputs import remove_earlier_study
    from dda.tradeoff.report import markdown_table, write_csv
    from dda.tradeoff.runner import add_errors

    rows = stopped.rows
    print(f"\ndda tradeoff: {stopped}", file=sys.stderr)
    if not rows:
        return 130
    add_errors(rows, case, case.reference if reference is None else None)
    remove_earlier_study(outdir, case.name)  # (--overwrite) not left beside this one
    name = f"{case.name}_partial"
    write_csv(rows, outdir / f"{name}.csv")
    write_text(outdir / f"{name}.md", markdown_table(rows, case.quantity))
    print(
        f"wrote the {len(rows)} finished settings to {outdir}/{name}.csv and .md", file=sys.stderr
    )
    return 130


def _has_dask() -> bool:
    """True when dask.distributed (the ``tradeoff`` extra) can be imported."""
    from dda.parallel import has_dask

    return has_dask()


def _progress(done: int, total: int, row: dict) -> None:
    """One line a finished setting: all its keys (g2 and the tolerance too: two settings
    that differ only there are two lines that read differently), time, status, host."""
    from dda.tradeoff.grid import KEYS, Setting

    setting = Setting(**{key: row[key] for key in KEYS}).label
    print(
        f"[{done}/{total}] {setting:<52} "
        f"{row['seconds']:6.2f} s (median of {row['repeats']}) {row['status']} on {row['host']}",
        file=sys.stderr,
        flush=True,
    )
