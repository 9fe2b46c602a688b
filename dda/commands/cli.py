"""The ``dda`` command: ``dda run``, ``dda render`` and plugin sub-commands.

Sub-commands other than ``run`` and ``render`` come from entry points in the
group ``dda.commands``: each names a ``register(subparsers)`` function that
adds its parser and sets ``func`` (``func(args) -> int``) with
``set_defaults``. A plugin that cannot be imported is skipped with a logged
warning, so a broken or absent optional package never breaks ``dda run``.
``dda run`` and ``dda render`` do not load the plugins at all (reading the entry
points and importing the eight command modules cost about 40 ms of a run's start).

Exit codes: 0 success, 1 other failure, 2 bad input (scene refused, missing
file, an argument or output path that cannot be used), 3 the simulation
failed, 130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM. Every error ends
in one line on stderr naming the file, key or argument and the reason; a
traceback only with ``-v``.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import logging
import os
import re
import signal
import sys
import warnings
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

import dda
from dda.commands import compile_helper
from dda.io.fields import SCALARS
from dda.io.wording import counted

logger = logging.getLogger(__name__)

PLUGIN_GROUP = "dda.commands"
BUILT_IN = ("run", "render")  # the sub-commands of this module; the others are plugins
EXIT_OK, EXIT_FAILURE, EXIT_INPUT, EXIT_SIMULATION, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
CHECKPOINT_MINUTES = 1.0  # default wall time between checkpoints of ``dda run``
MAX_OUTPUT_GB = 20.0  # ``dda run`` refuses runs estimated to write more, unless told


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (and exit code 2)."""

    commands: dict[str, argparse.ArgumentParser]  # the sub-commands' parsers (``dda``'s)

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_INPUT, f"{self.prog}: {message} (see {self.prog} -h)\n")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``dda`` command line.

    Parameters
    ----------
    argv
        Arguments without the program name; default ``sys.argv[1:]`` (the program
        itself, which exits next: its objects are then frozen out of the cyclic garbage
        collector, whose passes over them at exit cost 0.1-0.15 s, and Ctrl-C is ignored:
        the command has ended, and one more would break the clean-up at exit, a dask
        cluster's close in its atexit hook, with a traceback).

    Returns
    -------
    int
        The exit code.
    """
    try:
        return _main(list(sys.argv[1:] if argv is None else argv))
    finally:
        if argv is None:
            gc.freeze()
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def _main(argv: list[str]) -> int:
    verbosity = _verbosity(argv)
    configure_logging(verbosity)
    if not verbosity:
        warnings.formatwarning = _one_line_warning
    parser = build_parser(plugins=_command_of(argv) not in BUILT_IN)
    try:
        args, unknown = parser.parse_known_args(_plain_negative_numbers(argv))
        if unknown:  # named by the sub-command's parser: "dda run: ...", not "dda: ..."
            _command_parser(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    except SystemExit as exc:  # a refused argument (one line written), or --help
        return exc.code if isinstance(exc.code, int) else EXIT_INPUT
    if not hasattr(args, "func"):
        parser.print_help(sys.stderr)
        return EXIT_INPUT
    from dda.solve.policy import StepPolicy

    try:
        StepPolicy.from_environment()  # DDA_THREADS, DDA_SOLVER, DDA_SYSTEMS
    except ValueError as exc:
        print(f"dda: {exc}", file=sys.stderr)
        return EXIT_INPUT
    label = f"dda {args.command}" if getattr(args, "command", None) else "dda"
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        kept = getattr(args, "kept_on_interrupt", "")  # what a command keeps, and how to go on
        print(f"\n{label}: interrupted{'; ' + kept if kept else ''}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # the last resort: one line, the traceback with -v
        if verbosity:
            raise
        print(f"{label}: {_one_line(exc)} (dda -v {args.command} ... shows where)", file=sys.stderr)
        return EXIT_FAILURE


# a negative number in scientific notation, which argparse takes for an option ("-2e6")
_NEGATIVE_SCIENTIFIC = re.compile(r"^-(\d+\.?\d*|\.\d+)[eE][+-]?\d+$")


def _plain_negative_numbers(argv: list[str]) -> list[str]:
    """``argv`` with each negative number in scientific notation written out in plain
    digits (-2e6 as -2000000: the same float), which argparse reads as a value
    (``--range -2e6 0``, the help's own example) and not as an unknown option."""
    return [
        np.format_float_positional(float(a), trim="-") if _NEGATIVE_SCIENTIFIC.match(a) else a
        for a in argv
    ]


def _command_parser(parser: argparse.ArgumentParser, args: argparse.Namespace):
    """The parser of the sub-command ``args`` is for (``parser`` itself without one)."""
    return parser.commands.get(getattr(args, "command", None), parser)


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A Python warning (numpy's overflow in a run of absurd numbers, ...) as one line,
    ``dda: warning: Category: message (file.py:line)``, not the source line under it
    (``dda -v`` keeps Python's own form)."""
    text = " ".join(str(message).split())
    return f"dda: warning: {category.__name__}: {text} ({Path(filename).name}:{lineno})\n"


def _one_line(exc: BaseException) -> str:
    """``TypeName: message`` of an exception on one line (OSError: file and reason)."""
    if isinstance(exc, OSError) and exc.strerror:
        where = f"{exc.filename}: " if exc.filename else ""
        return f"{where}{exc.strerror}"
    text = " ".join(str(exc).split()) or "no message"
    return f"{type(exc).__name__}: {text}"


def build_parser(plugins: bool = True) -> argparse.ArgumentParser:
    """The argument parser with the built-in and (``plugins``) the plugin sub-commands."""
    description = "2-D Discontinuous Deformation Analysis of blocky rock."
    parser = Parser(prog="dda", description=description)
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-v info, -vv debug)"
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {dda.__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND", dest="command")
    parser.commands = subparsers.choices  # each sub-command's parser, by name
    _add_run(subparsers)
    _add_render(subparsers)
    if plugins:
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


def _command_of(argv: Sequence[str]) -> str | None:
    """The sub-command named in ``argv``: its first argument that is not an option."""
    for arg in argv:
        if arg == "--":
            return None
        if not arg.startswith("-"):
            return arg
    return None


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
        description="Run CASE.toml; write OUTDIR/blocks.pvd and contacts.pvd (and bolts.pvd "
        "with [[bolts]]) with their frames/*.vtu, history.csv (and history_points.csv with "
        "[[measure]]), summary.json, checkpoints and final.png (not with --no-picture). "
        "OUTDIR belongs to one run: a second run into it is refused unless --overwrite "
        "(replace it) or --resume (continue it). "
        "SIGINT or SIGTERM stops after the current step with a checkpoint.",
    )
    p.add_argument(
        "case", type=Path,
        help="scene file (TOML), or the name of a shipped case (sliding_block, tunnel, ...)",
    )  # fmt: skip
    p.add_argument(
        "-o", "--outdir", type=output_path, help="output directory (default out/run_<case>)"
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    p.add_argument(
        "--save-every", type=positive_int, metavar="N",
        help="keep every N-th step (overrides analysis.save_every)",
    )  # fmt: skip
    p.add_argument("--scalars", choices=sorted(SCALARS), default="syy", help="final.png colour")
    p.add_argument(
        "--no-picture", action="store_true",
        help="do not draw final.png (dda render draws it later; saves importing matplotlib)",
    )  # fmt: skip
    again = p.add_mutually_exclusive_group()
    again.add_argument(
        "--overwrite", action="store_true", help="replace the outputs of a run in OUTDIR"
    )
    again.add_argument(
        "--resume", action="store_true", help="continue the run in OUTDIR from its checkpoint"
    )
    p.add_argument(
        "--checkpoint-every",
        type=positive_int,
        metavar="STEPS",
        help="write a checkpoint every STEPS steps (overrides analysis.checkpoint_every)",
    )
    p.add_argument(
        "--checkpoint-minutes",
        type=non_negative_float,
        metavar="M",
        default=CHECKPOINT_MINUTES,
        help="and every M minutes of wall time (default %(default)g; 0: not by time)",
    )
    p.add_argument(
        "--max-steps",
        type=positive_int,
        metavar="N",
        help="refuse (and stop) a run of more than N steps; overrides analysis.max_steps "
        "(to run fewer steps, set analysis.steps or analysis.duration)",
    )
    p.add_argument(
        "--max-output",
        type=non_negative_float,
        metavar="GB",
        default=MAX_OUTPUT_GB,
        help="refuse a run estimated to write more than GB gigabytes (default %(default)g)",
    )
    p.set_defaults(func=run_command)


def positive_int(text: str) -> int:
    """argparse type: an integer of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {value}")
    return value


# the largest side of a picture, in pixels (16384: VTK's and most GPUs' texture limit; a
# 100000-pixel side was a MemoryError of 40 GB)
MAX_PICTURE_SIDE = 16384


def picture_side(text: str) -> int:
    """argparse type: a picture's side in pixels, 1 to :data:`MAX_PICTURE_SIDE`."""
    value = positive_int(text)
    if value > MAX_PICTURE_SIDE:
        raise argparse.ArgumentTypeError(f"at most {MAX_PICTURE_SIDE} pixels, got {value}")
    return value


def output_path(text: str) -> Path:
    """argparse type: a file or folder name, not empty (``-o ""`` would mean the current
    folder, where a run's files would mix with everything else)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; give a file or folder name")
    return Path(text)


def default_outdir(command: str, scene: str | os.PathLike[str] | None = None) -> Path:
    """Where ``command`` writes when given no ``-o``: ``out/<command>_<scene>``, the scene
    (or case) file's name without its suffix, or ``out/<command>`` for a command of no
    scene (docs/api.md, "Where the output goes")."""
    return Path("out") / (f"{command}_{Path(scene).stem}" if scene else command)


def positive_float(text: str) -> float:
    """argparse type: a finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """argparse type: a finite number of at least 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def run_command(args: argparse.Namespace) -> int:
    """``dda run``: load, claim OUTDIR, simulate with live output and checkpoints, summarise."""
    from dda.io.output_paths import OutputError, check_output_dir
    from dda.io.run_folder import RunFolder
    from dda.run.checkpoint import CheckpointError

    outdir = args.outdir or default_outdir("run", args.case)
    try:
        check_output_dir(outdir)  # before the scene is read or cut
    except OutputError as exc:
        print(f"dda run: -o {exc}", file=sys.stderr)
        return EXIT_INPUT
    mode = "resume" if args.resume else "overwrite" if args.overwrite else "new"
    try:  # an occupied folder is refused before the scene is read or cut
        folder = RunFolder(outdir, mode)
    except OutputError as exc:
        print(f"dda run: -o {exc}", file=sys.stderr)
        return EXIT_INPUT
    with folder:
        try:
            scene = _run_scene(args)
        except dda.SceneError as exc:
            folder.abandon()
            print(f"dda run: {exc}", file=sys.stderr)
            return EXIT_INPUT
        except BaseException:
            folder.abandon()
            raise
        try:
            return _run_in(folder, scene, args)
        except CheckpointError as exc:
            print(f"dda run: {exc}", file=sys.stderr)
            return EXIT_INPUT


def _run_scene(args: argparse.Namespace):
    """The scene with the command line's overrides, checked for its size."""
    from dda.scene.limits import check_run_size

    _refuse_a_drawing(args.case)
    scene = load_with_progress(scene_source(args.case), args.quiet)
    overrides = {
        "save_every": args.save_every,
        "checkpoint_every": args.checkpoint_every,
        "max_steps": args.max_steps,
    }
    overrides = {k: v for k, v in overrides.items() if v is not None}
    if overrides:
        analysis = dataclasses.replace(scene.analysis, **overrides)
        scene = dataclasses.replace(scene, analysis=analysis)
    check_run_size(scene)
    _check_output_size(scene, args)
    return scene


def load_with_progress(scene, quiet: bool = False, source: str | None = None):
    """``dda.load_scene(scene, source)``, with a progress bar on stderr while a long
    rock-mass cut runs (:mod:`dda.run.cut_bar`; none with ``quiet``). ``scene``: a path,
    or a scene read into a dict from the file ``source``."""
    from dda.run.cut_bar import CutBar

    with CutBar(Path(source or scene).name, quiet=quiet) as bar:
        loaded = dda.load_scene(scene, source, progress=bar)
        bar.finish()
    return loaded


def _refuse_a_drawing(case: Path) -> None:
    """A SceneError for ``dda run DRAWING.dxf``, pointing to the drawing's scene (it was
    read as TOML: "Expected '=' after a key")."""
    if case.suffix.lower() == ".dxf":
        beside = case.with_suffix(".toml")
        hint = f"dda run {beside}" if beside.is_file() else "dda run SCENE.toml"
        raise dda.SceneError(
            str(case), "<file>", f"a drawing runs through the scene of its materials and "
            f"joints, whose [drawing] file names it: {hint} (docs/rock_masses.md, Drawings); "
            "dda cut draws its blocks",
        )  # fmt: skip


def scene_source(case: Path):
    """The scene file ``case``, or the shipped case of that name (``dda.cases``) when no
    such file exists: ``dda run sliding_block`` works from any folder, and from one that
    holds a folder of that name (its own output, ``-o sliding_block``). Neither: a
    SceneError that names both."""
    import dda.cases

    if case.is_file() or case.suffix or (case.exists() and str(case) not in dda.cases.names()):
        return case
    if str(case) in dda.cases.names():
        return dda.cases.folder().joinpath(f"{case}.toml")
    shipped = ", ".join(dda.cases.names())
    raise dda.SceneError(
        str(case), "<file>", f"no such file, and no shipped case of that name ({shipped})"
    )


def _check_output_size(scene, args: argparse.Namespace) -> None:
    """Refuse a run whose frames would take more than ``--max-output``; warn beyond free space."""
    from dda.scene.limits import estimated_frames, estimated_output_bytes

    size = estimated_output_bytes(scene)
    if size > args.max_output * 1e9:
        raise dda.SceneError(
            scene.source,
            "analysis.save_every",
            f"about {estimated_frames(scene):,} frames, {size / 1e9:.3g} GB on disk, more than "
            f"--max-output {args.max_output:g} GB; keep fewer frames (analysis.save_every, "
            "--save-every) or raise --max-output",
        )


def _run_in(folder, scene, args: argparse.Namespace) -> int:
    """Run ``scene`` into the claimed ``folder`` (new, overwritten or resumed)."""
    from dda.io.disk_space import check_disk_space
    from dda.io.output_paths import OutputError
    from dda.io.run_writer import RunWriter, check_outputs_reach
    from dda.run.checkpoint import check_scene, differing_sections, read_checkpoint

    checkpoint = None
    if args.resume:
        if folder.previous.status == "finished":
            stored = folder.previous.fingerprint
            differ = [] if stored is None else differing_sections(stored, scene)
            if differ:
                print(f"dda run: {folder.outdir / 'summary.json'}: the finished run there is "
                      f"of another scene ({', '.join(differ)} differ from {scene.source}); "
                      "--overwrite replaces it", file=sys.stderr)  # fmt: skip
                folder.abandon()
                return EXIT_INPUT
            print(f"dda run: {folder.outdir}: the run finished already; nothing to resume")
            return EXIT_OK
        checkpoint = read_checkpoint(folder.checkpoint_path)
        check_scene(checkpoint, scene)
    try:  # nothing written yet: a refusal gives the directory up as it was
        if checkpoint is not None:
            check_outputs_reach(folder.outdir, checkpoint.step, bool(scene.measure))
        check_disk_space(scene, folder.outdir, folder.reclaimable_bytes())
    except OutputError as exc:
        folder.abandon()
        print(f"dda run: -o {exc}", file=sys.stderr)
        return EXIT_INPUT
    resume_step = None if checkpoint is None else checkpoint.step
    writer = RunWriter(
        folder, scalars=args.scalars, image=not args.no_picture, resume_step=resume_step,
        scene=scene,
    )  # fmt: skip
    writer.picture = _picture_helper(args)
    _offer_compile_helper(args)
    try:
        return _run_with(writer, folder, scene, args, checkpoint)
    finally:  # a run that ends before its picture (an error, a signal) ends the helpers too
        compile_helper.withdraw()
        if writer.picture is not None:
            writer.picture.cancel()


def _run_with(writer, folder, scene, args: argparse.Namespace, checkpoint) -> int:
    """The run of :func:`_run_in` into ``writer``: frames as they come, then the summary.

    A signal stops the run after the step under way; the summary and the picture follow
    while the signals are still caught, so a second signal (which stops at once) lands in
    :func:`_stopped_at_once` and the summary still says ``"interrupted"``."""
    from dda.run.checkpoint import CheckpointPlan
    from dda.run.stop import StopOnSignal

    minutes = args.checkpoint_minutes
    plan = CheckpointPlan(
        folder.checkpoint_path, scene.analysis.checkpoint_every,
        minutes * 60 if minutes else None, at_start=True,
    )  # fmt: skip
    logger.info("running %s into %s (run %s)", args.case, folder.outdir, writer.run_id)
    result = None  # until the engine returns one
    with StopOnSignal("dda run") as stop:
        try:
            result = dda.simulate(
                scene, progress=not args.quiet, on_frame=writer.add_frame, keep_frames=False,
                stop=stop, checkpoints=plan, resume=checkpoint,
            )  # fmt: skip
            summary = writer.finish(result, scene)
        except dda.SimulationError as exc:
            print(f"dda run: simulation failed: {exc}", file=sys.stderr)
            writer.finish(getattr(exc, "result", None), scene, status="failed", error=str(exc))
            print(
                f"partial output in {folder.outdir} (a new run into it needs --overwrite)",
                file=sys.stderr,
            )
            return EXIT_SIMULATION
        except KeyboardInterrupt:
            return _stopped_at_once(writer, scene, folder, args, stop, result)
        except OSError as exc:  # a full disk, a file system gone read-only, ...
            return _write_failed(exc, writer, scene, folder, args)
        except Exception as exc:  # an error of the engine's own: the folder left whole
            return _crashed(exc, writer, scene, folder, args)
    if summary["status"] == "interrupted":
        print(_stopped_sentence(summary, stop.name, args, folder), file=sys.stderr)
        return stop.exit_code
    if not args.quiet:
        print(summary_paragraph(summary, folder.outdir, scene.label))
    said = set(scene.load_warnings)  # logged as the scene loaded: not twice
    for text in summary.get("warnings") or ():  # quiet or not: the user should know
        if text not in said:
            print(f"dda run: warning: {text}", file=sys.stderr)
    return EXIT_OK


def _stopped_sentence(summary: dict, signal_name: str, args: argparse.Namespace, folder) -> str:
    """What a run stopped by a signal says: the step and the command that continues it, or,
    stopped in its equilibrium start, that there is nothing to continue."""
    from dda.run.simulation import INTERRUPTED_START

    if summary.get("start") == INTERRUPTED_START:
        return (
            f"dda run: stopped during the equilibrium start, before step 1 ({signal_name}), "
            f"no checkpoint; run again with: dda run {args.case} -o {folder.outdir} --overwrite"
        )
    return (
        f"dda run: stopped at step {summary.get('steps')} ({signal_name}); continue with: "
        f"{_resume_command(args, folder)}"
    )


def _stopped_at_once(writer, scene, folder, args: argparse.Namespace, stop, result) -> int:
    """A second signal stopped the run at once: its summary is written while further
    signals are ignored, without the picture (``dda render`` draws it later): the
    ``result``'s status when the engine had returned (the signal came as the picture was
    drawn), else ``"interrupted"``; then the command that continues the run."""
    from dda.run.checkpoint import CheckpointError, read_checkpoint

    with stop.ignoring():
        if not writer.done:  # (a summary written before the signal stays)
            writer.image = False
            status = None if result is not None else "interrupted"
            writer.finish(result, scene, status=status, error=status and "stopped by a signal")
        try:
            step = read_checkpoint(folder.checkpoint_path).step
        except CheckpointError:  # none left: the run had finished
            step = None
    print(f"\ndda run: stopped at once ({stop.name} again); output in {folder.outdir}, "
          f"no final.png (dda render {folder.outdir} draws it)", file=sys.stderr)  # fmt: skip
    if step is not None:
        again = _resume_command(args, folder)
        print(f"its checkpoint of step {step} is kept; continue with: {again}", file=sys.stderr)
    elif result is None:
        print("no checkpoint was written yet: run again with --overwrite", file=sys.stderr)
    return stop.exit_code


def _resume_command(args: argparse.Namespace, folder) -> str:
    """The command that continues the run in ``folder``."""
    return f"dda run {args.case} -o {folder.outdir} --resume"


def _picture_helper(args: argparse.Namespace):
    """A helper process importing matplotlib beside the run (:mod:`dda.io.picture_process`)
    when the run draws and may have a second core: the solver would get two threads
    (``DDA_THREADS``, else the cores the other processes leave idle); else None."""
    from dda.io.picture_process import PictureProcess
    from dda.solve.policy import current_policy

    if args.no_picture or current_policy().solver_threads() < 2:
        return None
    return PictureProcess.start()


def _offer_compile_helper(args: argparse.Namespace) -> None:
    """Let the run start a helper process that compiles the step's kernels beside it when
    they are not in numba's cache yet and a second core is free
    (:mod:`dda.commands.compile_helper`)."""
    from dda.solve.policy import current_policy

    compile_helper.offer(scene_source(args.case), current_policy().solver_threads() >= 2)


def _crashed(exc: Exception, writer, scene, folder, args: argparse.Namespace) -> int:
    """An error the engine did not expect stopped the run: its summary says "failed" and
    why, the folder's lock is given up, and the run says so in one line (with -v, the
    traceback follows)."""
    what = _one_line(exc)
    writer.image = False
    writer.finish(None, scene, status="failed", error=f"internal error: {what}")
    print(
        f"dda run: internal error: {what} (dda -v run ... shows where); partial output in "
        f"{folder.outdir} (a new run into it needs --overwrite)",
        file=sys.stderr,
    )
    if getattr(args, "verbose", 0):
        raise exc
    return EXIT_FAILURE


def _write_failed(exc: OSError, writer, scene, folder, args: argparse.Namespace) -> int:
    """A write failed mid-run: say which file and why, mark the summary "failed" (if it
    can still be written; else the last summary stays), keep the last checkpoint."""
    from dda.run.checkpoint import read_checkpoint

    what = _one_line(exc)
    writer.image = False  # no picture on a full disk
    try:
        writer.finish(None, scene, status="failed", error=f"cannot write {what}")
    except OSError as again:
        writer.folder.release()
        logger.info("summary.json not updated: %s", _one_line(again))
    print(f"dda run: cannot write {what}; the run stopped", file=sys.stderr)
    try:
        step = read_checkpoint(folder.checkpoint_path).step
    except ValueError:
        print(f"partial output in {folder.outdir}; no checkpoint to resume from", file=sys.stderr)
        return EXIT_FAILURE
    print(
        f"its checkpoint of step {step} is kept: free space, then continue with: "
        f"{_resume_command(args, folder)}",
        file=sys.stderr,
    )
    return EXIT_FAILURE


def summary_paragraph(summary: dict[str, Any], outdir: Path, label: str = "run") -> str:
    """A few lines for the terminal: what ran, how long, how well, where the files are.

    Parameters
    ----------
    summary
        The run summary (see :class:`dda.Result`).
    outdir
        The output directory.
    label
        What the run is called where its scene has no title (:attr:`Scene.label`).

    Returns
    -------
    str
        The paragraph.
    """
    title = summary.get("title") or label
    parts = [
        f"{title}: {summary.get('status', 'finished')} after "
        f"{counted(summary.get('steps', '?'), 'step')}",
        f"to t = {_number(summary.get('time'))} s",
        f"in {_number(summary.get('wall_seconds'), '.3g')} s wall time",
    ]
    compiling = summary.get("compile_seconds") or 0.0
    if compiling >= 1.0:  # the first run after installing: numba compiled its kernels
        parts.append(f"({compiling:.3g} s of it compiling kernels, once per installation)")
    text = " ".join(parts) + "."
    from dda.io.fields import unit_name

    units = summary.get("units")
    if summary.get("max_penetration") is not None:
        length = unit_name("length", units)
        text += f" Largest penetration {_number(summary['max_penetration'])} {length}."
    text += _start_sentence(summary)
    if summary.get("cut_steps"):
        shortest = _number(summary.get("smallest_cut_time_step"), ".3g")
        text += (
            f" Δt cut at {counted(summary['cut_steps'], 'step')} (to {shortest} s at the least)."
        )
    if summary.get("iterations") is not None:
        text += f" {counted(summary['iterations'], 'solve')}"
        newton = summary.get("newton_iterations")
        text += "." if newton is None else f" ({counted(newton, 'Newton iteration')})."
    if summary.get("friction_dissipation"):
        energy = unit_name("energy", units)
        text += f" Friction dissipated {_number(summary['friction_dissipation'], '.3g')} {energy}."
    events = summary.get("fracture_events") or 0
    count = events if isinstance(events, int) else len(events)
    if count:
        text += f" {counted(count, 'fracture event')}."
    if summary.get("stages_done"):
        text += f" {counted(summary['stages_done'], 'stage')} applied."
    if summary.get("bolts") is not None:
        broke = len(summary.get("bolt_events") or ())
        text += f" {broke} of {counted(summary['bolts'], 'bolt')} broke."
    return text + f"\nOutput ({counted(summary.get('frames_written', 0), 'frame')}): {outdir}"


def _start_sentence(summary: dict[str, Any]) -> str:
    """How the run started: the equilibrium start's cost, or that it did not settle and
    the run started unloaded (:mod:`dda.run.equilibrium_start`); nothing for a run that
    asked for the unloaded start or resumed."""
    start = summary.get("start")
    if start == "equilibrium":
        newton = summary.get("start_newton_iterations")
        seconds = _number(summary.get("start_seconds"), ".3g")
        method = summary.get("start_method")
        compiling = summary.get("start_compile_seconds") or 0.0
        aside = f" ({compiling:.3g} s of it compiling kernels)" if compiling >= 1.0 else ""
        text = f" Equilibrium start: {counted(newton, 'Newton iteration')}, {seconds} s{aside}."
        if method == "continuation":  # the interior point did not settle it
            text += " Its interior-point solve did not settle: it went on by continuation."
        return text
    if start is not None and start.startswith("unloaded ("):
        newton, seconds = summary.get("start_newton_iterations"), summary.get("start_seconds")
        spent = ""  # a summary.json written before the start's cost was kept says none
        if newton and seconds is not None:
            spent = f" after {counted(newton, 'Newton iteration')} and {seconds:.3g} s"
        return f" The equilibrium start did not settle{spent}: the run started unloaded."
    return ""


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
    p.add_argument(
        "-o", "--output", type=output_path,
        help="PNG file (default: in the run's output directory, named after the frame and "
        "the scalars)",
    )  # fmt: skip
    p.add_argument("--scalars", choices=sorted(SCALARS), default="syy", help="block colour")
    add_range_option(p)
    p.add_argument("--step", type=int, help="step of the frame (OUTDIR only; default last)")
    p.add_argument("--no-contacts", action="store_true", help="do not draw contact forces")
    p.add_argument(
        "--size", type=picture_side, nargs=2, default=(1200, 900), metavar=("W", "H"),
        help="picture size in pixels (default: 1200 900)",
    )  # fmt: skip
    p.add_argument(
        "--view", type=float, nargs=4, metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
        help="show this part of the model (a zoom, in its length unit); the colour range "
        "and the force marks follow the blocks and contacts in it (default: every block)",
    )  # fmt: skip
    p.set_defaults(func=render_command)


def add_range_option(parser: argparse.ArgumentParser) -> None:
    """``--range MIN MAX``: the colour range, in the scene's unit of the quantity."""
    parser.add_argument(
        "--range", type=float, nargs=2, metavar=("MIN", "MAX"),
        help="colour range in the scene's unit of the quantity (Pa, not kPa: "
        "--range -2e6 0); values beyond it take the end colours (default: the values')",
    )  # fmt: skip


def checked_range(args: argparse.Namespace) -> tuple[float, float] | None:
    """``args.range``, or a ValueError naming it when it is no range."""
    if args.range is None:
        return None
    from dda.io.images import range_problem

    low, high = args.range
    problem = range_problem(low, high)
    if problem:
        raise ValueError(f"--range {low:g} {high:g}: {problem}")
    return float(low), float(high)


def render_command(args: argparse.Namespace) -> int:
    """``dda render``: read a frame back from VTU and draw it."""
    from dda.io.frame_files import find_frame, frame_file, read_found_frame
    from dda.io.output_paths import OutputError, check_output_file

    try:
        clim = checked_range(args)
        view = checked_view(args.view)
        if args.step is not None and Path(args.source).is_file():
            raise ValueError(
                f"--step {args.step}: a VTU file is one frame (its own step); give the "
                "output directory to choose a step"
            )
        found = find_frame(args.source, args.step)
        output = args.output or found.default_png(args.scalars)
        check_png(output)
        check_output_file(output)
        frame = read_found_frame(found)
        if view is not None:
            from dda.io.images import extent

            low, high = extent([frame])
            if np.any(view[1] < low) or np.any(view[0] > high):
                raise ValueError(
                    f"--view {' '.join(f'{v:g}' for v in args.view)}: holds no block (the "
                    f"blocks lie in x {low[0]:g} to {high[0]:g}, y {low[1]:g} to {high[1]:g})"
                )
    except (FileNotFoundError, ValueError, OutputError) as exc:
        print(f"dda render: {exc}", file=sys.stderr)
        return EXIT_INPUT
    from dda.io.images import render_frame

    Path(output).parent.mkdir(parents=True, exist_ok=True)
    if found.contacts is None and not args.no_contacts:
        logger.warning(
            "%s: no contacts file beside it (%s): drawn without contact forces",
            found.blocks.name, frame_file(found.blocks, "contacts_").name,
        )  # fmt: skip
    run = found.summary()  # the run's title and units, when its summary.json is there
    render_frame(
        frame, output, scalars=args.scalars, show_contacts=not args.no_contacts,
        window_size=tuple(args.size), scene_title=run.get("title") or "",
        units=found.units(run), clim=clim, water_table=run.get("water_table"),
        water_follows=run.get("water_follows") or (), view=view,
    )  # fmt: skip
    logger.info("wrote %s", output)
    print(output)
    return EXIT_OK


def checked_view(view: Sequence[float] | None) -> np.ndarray | None:
    """``--view XMIN YMIN XMAX YMAX`` as ``[[xmin, ymin], [xmax, ymax]]``, or a ValueError
    naming it when it is not a finite box with its minima below its maxima."""
    if view is None:
        return None
    box = np.asarray(view, dtype=float).reshape(2, 2)
    if not np.isfinite(box).all() or np.any(box[0] >= box[1]):
        raise ValueError(
            f"--view {' '.join(f'{v:g}' for v in view)}: give XMIN YMIN XMAX YMAX, finite, "
            "each minimum below its maximum"
        )
    return box


def check_png(output: Path | str, option: str = "-o") -> None:
    """A ValueError saying what to give when ``option output`` does not end in .png."""
    from dda.io.images import png_problem

    problem = png_problem(output)
    if problem:
        raise ValueError(f"{option} {output}: {problem}")


if __name__ == "__main__":
    sys.exit(main())
