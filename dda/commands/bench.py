"""``dda bench``: run the wall benchmark at several sizes and print the table."""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Any

from dda.bench.scenes import METHODS, STARTS
from dda.commands.cli import positive_float, positive_int

log = logging.getLogger(__name__)

DEFAULT_SIZES = (5, 10, 20, 30, 50, 100)


def register(subparsers: Any) -> None:
    """Add ``dda bench`` to the ``dda`` command's sub-commands."""
    parser = subparsers.add_parser(
        "bench",
        help="performance benchmark (wall of blocks on a base)",
        description="Time the engine on an n x n wall of unit blocks on a fixed base, "
        "each size in its own process (peak memory per size). The table's columns: "
        "docs/benchmarks.md (factorisations: a count over the run; '<stage> ms/step': "
        "ms a step in that stage).",
    )
    parser.add_argument(
        "--sizes",
        type=positive_int,
        nargs="+",
        default=list(DEFAULT_SIZES),
        metavar="N",
        help="wall sizes N (an N x N wall of blocks); default: %(default)s",
    )
    parser.add_argument(
        "--method",
        choices=[*METHODS, "both"],
        default="both",
        help="contact method (default: both)",
    )
    parser.add_argument("--steps", type=positive_int, default=100, help="time steps (default: 100)")
    parser.add_argument(
        "--start",
        choices=STARTS,
        default="equilibrium",
        help="how the walls start: the engine's default equilibrium start (what users run; "
        "its seconds and Newton iterations are reported), or Shi's unloaded start without "
        "material damping, as the C code's (the comparison with it); default: %(default)s",
    )
    parser.add_argument(
        "--repeat",
        type=positive_int,
        default=1,
        metavar="N",
        help="run each size N times (each in its own process) and keep the fastest: "
        "on a shared machine the minimum is the figure least disturbed by other work "
        "(default: 1)",
    )
    parser.add_argument(
        "--max-memory",
        type=positive_float,
        metavar="GB",
        help="refuse a size whose wall is estimated to need more memory than GB gigabytes "
        "(27 KiB a block; default: the memory available on this machine)",
    )
    parser.set_defaults(func=run_command)


def run_command(args: argparse.Namespace) -> int:
    """Measure every (size, method) and print the Markdown table; 0 on success."""
    from dda.bench.report import machine_line, table
    from dda.bench.run import measure_in_subprocess

    methods = METHODS if args.method == "both" else (args.method,)
    refusal = _refusal(args, methods)
    if refusal:
        print(f"dda bench: {refusal}", file=sys.stderr)
        return 2
    results = []
    for size in args.sizes:
        for method in methods:
            log.info("wall %dx%d, %s, %d steps", size, size, method, args.steps)
            try:
                runs = [
                    measure_in_subprocess(size, method, args.steps, start=args.start)
                    for _ in range(args.repeat)
                ]
            except RuntimeError as exc:
                log.error("%dx%d %s: %s", size, size, method, exc)
                return 1
            finished = [run for run in runs if run.status == "finished"] or runs
            m = min(finished, key=lambda run: run.ms_per_step)
            results.append(m)
            print(table([m]).splitlines()[-1] if len(results) > 1 else table([m]), flush=True)
    print(f"\nmachine: {machine_line()}")
    print(
        f"command: dda bench --sizes {' '.join(map(str, args.sizes))} "
        f"--method {args.method} --steps {args.steps} --start {args.start}"
        + (f" --repeat {args.repeat} (fastest of {args.repeat} runs)" if args.repeat > 1 else "")
    )
    return 0 if all(m.status == "finished" for m in results) else 3


def _refusal(args: argparse.Namespace, methods: tuple[str, ...]) -> str | None:
    """Why the walls asked for cannot run (one line naming the option), or None: each
    size's memory against --max-memory (default: the memory available now) and its
    scene through the checks of its run, before any warm-up."""
    from dda.bench.limits import BenchError, available_memory_bytes, check_walls

    if args.max_memory is not None:
        bound, said = args.max_memory * 1e9, f"--max-memory {args.max_memory:g} GB"
    else:
        bound = available_memory_bytes()
        gigabytes = f"{bound / 1e9:.3g} GB" if bound else ""
        said = f"the {gigabytes} of memory available on this machine (--max-memory)"
    try:
        for method in methods:
            check_walls(args.sizes, method, args.steps, args.start, bound, said)
    except BenchError as exc:
        return str(exc)
    return None
