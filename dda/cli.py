"""The ``dda`` command: ``dda run``, ``dda render`` and plugin sub-commands.

Sub-commands other than ``run`` and ``render`` come from entry points in the
group ``dda.commands``: each names a ``register(subparsers)`` function that
adds its parser and sets ``func`` (``func(args) -> int``) with
``set_defaults``. A plugin that cannot be imported is skipped with a logged
warning, so a broken or absent optional package never breaks ``dda run``.

Exit codes: 0 success, 1 other failure, 2 bad input (scene refused, missing
file), 3 the simulation failed, 130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
import time
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import dda
from dda.io.fields import SCALARS

logger = logging.getLogger(__name__)

PLUGIN_GROUP = "dda.commands"
EXIT_OK, EXIT_FAILURE, EXIT_INPUT, EXIT_SIMULATION, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``dda`` command line.

    Parameters
    ----------
    argv
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit code.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    configure_logging(_verbosity(argv))
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help(sys.stderr)
        return EXIT_INPUT
    from dda.linsolve import solver_threads

    try:
        solver_threads()
    except ValueError as exc:
        print(f"dda: {exc}", file=sys.stderr)
        return EXIT_INPUT
    return int(args.func(args) or 0)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with the built-in and the plugin sub-commands."""
    parser = argparse.ArgumentParser(
        prog="dda", description="2-D Discontinuous Deformation Analysis of blocky rock."
    )
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-v info, -vv debug)"
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {dda.__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND")
    _add_run(subparsers)
    _add_render(subparsers)
    load_plugins(subparsers)
    return parser


def configure_logging(verbosity: int) -> None:
    """Log to stderr: warnings by default, info with ``-v``, debug with ``-vv``."""
    level = {0: logging.WARNING, 1: logging.INFO}.get(verbosity, logging.DEBUG)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    logging.getLogger().setLevel(level)


def _verbosity(argv: Sequence[str]) -> int:
    """Count ``-v`` flags before parsing, so plugin loading is logged at that level."""
    count = 0
    for arg in argv:
        if arg == "--":
            break
        if arg == "--verbose":
            count += 1
        elif arg.startswith("-") and not arg.startswith("--") and set(arg[1:]) == {"v"}:
            count += len(arg) - 1
    return count


def load_plugins(subparsers: Any, group: str = PLUGIN_GROUP) -> list[str]:
    """Let every entry point of ``group`` register its sub-command.

    Parameters
    ----------
    subparsers
        The object returned by ``ArgumentParser.add_subparsers``.
    group
        Entry point group.

    Returns
    -------
    list of str
        Names of the entry points that registered.
    """
    loaded = []
    for entry in metadata.entry_points(group=group):
        try:
            register = entry.load()
        except Exception as exc:  # ImportError, or an error while importing it
            logger.warning("skipping command %r (%s): %s", entry.name, entry.value, exc)
            continue
        try:
            register(subparsers)
        except Exception as exc:  # e.g. a name that is already taken
            logger.warning("command %r could not register: %s", entry.name, exc)
            continue
        loaded.append(entry.name)
    return loaded


# ---------------------------------------------------------------- dda run


def _add_run(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "run",
        help="run a scene and write VTU/PVD, CSV, JSON and a picture",
        description="Run CASE.toml; write OUTDIR/blocks.pvd, frames/*.vtu, history.csv, "
        "summary.json and final.png.",
    )
    p.add_argument("case", type=Path, help="scene file (TOML)")
    p.add_argument("-o", "--outdir", type=Path, help="output directory (default out/<case>)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.add_argument(
        "--save-every", type=_positive_int, metavar="N", help="keep every N-th step (overrides)"
    )
    p.add_argument("--scalars", choices=sorted(SCALARS), default="syy", help="final.png colour")
    p.set_defaults(func=run_command)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1")
    return value


def run_command(args: argparse.Namespace) -> int:
    """``dda run``: load, simulate with live output, summarise."""
    from dda.io.run_writer import RunWriter

    try:
        scene = dda.load_scene(args.case)
    except dda.SceneError as exc:
        print(f"dda run: {exc}", file=sys.stderr)
        return EXIT_INPUT
    if args.save_every:
        analysis = dataclasses.replace(scene.analysis, save_every=args.save_every)
        scene = dataclasses.replace(scene, analysis=analysis)
    outdir = args.outdir or Path("out") / args.case.stem
    writer = RunWriter(outdir, scalars=args.scalars)
    logger.info("running %s into %s", args.case, outdir)
    start = time.perf_counter()
    try:
        result = dda.simulate(scene, progress=not args.quiet, on_frame=writer.add_frame)
    except dda.SimulationError as exc:
        print(f"dda run: simulation failed: {exc}", file=sys.stderr)
        writer.finish(getattr(exc, "result", None), scene, status="failed", error=str(exc))
        print(f"partial output in {outdir}", file=sys.stderr)
        return EXIT_SIMULATION
    except KeyboardInterrupt:
        writer.finish(None, scene, status="interrupted", error="interrupted by the user")
        print(f"\ndda run: interrupted; partial output in {outdir}", file=sys.stderr)
        return EXIT_INTERRUPTED
    summary = writer.finish(result, scene)
    summary.setdefault("wall_seconds", time.perf_counter() - start)
    if not args.quiet:
        print(summary_paragraph(summary, outdir))
    return EXIT_OK


def summary_paragraph(summary: dict[str, Any], outdir: Path) -> str:
    """A few lines for the terminal: what ran, how long, how well, where the files are.

    Parameters
    ----------
    summary
        The run summary (see :class:`dda.Result`).
    outdir
        The output directory.

    Returns
    -------
    str
        The paragraph.
    """
    title = summary.get("title") or "run"
    parts = [
        f"{title}: {summary.get('status', 'finished')} after {summary.get('steps', '?')} steps",
        f"to t = {_number(summary.get('time'))} s",
        f"in {_number(summary.get('wall_seconds'), '.3g')} s wall time",
    ]
    text = " ".join(parts) + "."
    if summary.get("max_penetration") is not None:
        text += f" Largest penetration {_number(summary['max_penetration'])}."
    if summary.get("iterations") is not None:
        text += f" {summary['iterations']} solves."
    if summary.get("friction_dissipation"):
        text += f" Friction dissipated {_number(summary['friction_dissipation'], '.3g')}."
    events = summary.get("fracture_events") or 0
    count = events if isinstance(events, int) else len(events)
    if count:
        text += f" {count} fracture events."
    return text + f"\nOutput ({summary.get('frames_written', 0)} frames): {outdir}"


def _number(value: Any, fmt: str = ".6g") -> str:
    try:
        return format(float(value), fmt)
    except (TypeError, ValueError):
        return "?"


# ---------------------------------------------------------------- dda render


def _add_render(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "render",
        help="draw a written frame to PNG",
        description="Draw a frame written by `dda run`: OUTDIR (its last frame, or --step) "
        "or a frames/blocks_*.vtu file.",
    )
    p.add_argument("source", type=Path, help="output directory or blocks VTU file")
    p.add_argument("-o", "--output", type=Path, help="PNG file (default: beside the source)")
    p.add_argument("--scalars", choices=sorted(SCALARS), default="syy", help="block colour")
    p.add_argument("--step", type=int, help="step of the frame (OUTDIR only; default last)")
    p.add_argument("--no-contacts", action="store_true", help="do not draw contact forces")
    p.add_argument("--size", type=int, nargs=2, default=(1200, 900), metavar=("W", "H"))
    p.set_defaults(func=render_command)


def render_command(args: argparse.Namespace) -> int:
    """``dda render``: read a frame back from VTU and draw it."""
    from dda.io.frame_files import find_frame

    try:
        found = find_frame(args.source, args.step)
    except (FileNotFoundError, ValueError) as exc:
        print(f"dda render: {exc}", file=sys.stderr)
        return EXIT_INPUT
    from dda.io.images import render_frame
    from dda.io.vtu import read_frame

    frame = read_frame(found.blocks, found.contacts, time=found.time, step=found.step)
    output = args.output or found.default_png(args.scalars)
    run = found.summary()  # the run's title and units, when its summary.json is there
    render_frame(
        frame, output, scalars=args.scalars, show_contacts=not args.no_contacts,
        window_size=tuple(args.size), scene_title=run.get("title") or "",
        units=run.get("units"),
    )  # fmt: skip
    logger.info("wrote %s", output)
    print(output)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
