"""``dda fos SCENE [-o OUT] [--lower F] [--upper F] [--tolerance T] [--duration S]
[--velocity V] [--acceleration A] [--window W] [--blocks A,B] [--intact]
[--workers N | --scheduler ADDRESS | --scheduler-file FILE | --serial]``."""

from __future__ import annotations

import argparse
import copy
import json
import logging
import sys
from pathlib import Path
from typing import Any

from dda.commands.cli import output_path
from dda.commands.cluster_options import add_cluster_options, cluster_of

log = logging.getLogger(__name__)

EXIT_INPUT = 2
# the [fos] keys the command line overrides: option -> (key, type)
OVERRIDES = {
    "lower": float,
    "upper": float,
    "tolerance": float,
    "duration": float,
    "velocity": float,
    "acceleration": float,
    "window": float,
}
# what each overridden key means (docs/stability.md); argparse %-formats help texts
FOS_HELP = {
    "lower": "the smallest strength-reduction factor F tried (default 0.25)",
    "upper": "the largest F tried (default 4)",
    "tolerance": "the width of the final bracket on F (default 0.01)",
    "duration": "how long each trial runs after the reduction, in the scene's time unit "
    "(default: the scene's run)",
    "velocity": "the mean speed, in the scene's length/time units, above which a trial "
    "fails (default: acceleration x |g| x duration)",
    "acceleration": "the fraction of g that sets the default velocity (default 1e-4)",
    "window": "the fraction of the trial's duration, at its end, over which the speed is "
    "judged (default 0.2: a fraction, not seconds)",
}
COLUMNS = ("factor", "failed", "speed", "limit", "steps", "seconds", "host", "status")


def register(subparsers: Any) -> None:
    """Add the ``fos`` sub-command (entry point of group ``dda.commands``)."""
    p = subparsers.add_parser(
        "fos",
        help="factor of safety by strength reduction",
        description="Divide the joints' tan(friction angle), cohesion and tensile strength by F "
        "and find the F at which the model fails (its watched blocks do not come to rest; "
        "docs/stability.md). Writes OUT/fos.csv (a row per trial, as it finishes: a rerun "
        "reuses them), OUT/fos.png, OUT/failure.png and OUT/fos.json. Options override the "
        "scene's [fos] keys of the same name.",
    )
    p.add_argument("scene", type=Path, help="scene file (or a shipped case's name)")
    p.add_argument(
        "-o", "--outdir", type=output_path, help="output folder (default out/fos_<scene>)"
    )
    add_overwrite_option(p, "trials")
    add_fos_options(p)
    add_cluster_options(p)
    p.set_defaults(func=fos_command)


def add_overwrite_option(p: Any, rows: str) -> None:
    """``--overwrite``: replace the folder's rows of another scene, seed or option."""
    p.add_argument(
        "--overwrite",
        action="store_true",
        help=f"replace the folder's {rows} of another scene, seed or option (else refused)",
    )


def add_fos_options(p: Any) -> None:
    """The options that override the scene's ``[fos]`` keys."""
    for name, kind in OVERRIDES.items():
        p.add_argument(f"--{name}", type=kind, metavar="X", help=f"[fos] {name}: {FOS_HELP[name]}")
    p.add_argument("--blocks", metavar="A,B", help="[fos] blocks: watched blocks or groups")
    p.add_argument(
        "--intact", action="store_true", help="[fos] intact: reduce breakable materials too"
    )


def with_overrides(raw: dict, args: argparse.Namespace) -> dict:
    """The raw scene with the command line's ``[fos]`` keys put in."""
    raw = copy.deepcopy(raw)
    table = raw.get("fos", {})
    table = dict(table) if isinstance(table, dict) else table
    if isinstance(table, dict):
        for name in OVERRIDES:
            if getattr(args, name) is not None:
                table[name] = getattr(args, name)
        if args.blocks is not None:  # "" too: the scene check refuses an empty list
            table["blocks"] = [b.strip() for b in args.blocks.split(",") if b.strip()]
        if args.intact:
            table["intact"] = True
    if table:
        raw["fos"] = table
    return raw


def prepare(args: argparse.Namespace, command: str, reduced: bool = True, edit=None):
    """(raw scene with overrides, loaded scene, criterion, source, output folder, cluster)
    or an error line. The output folder (``-o``, else ``out/<command>_<scene>``) and the
    cluster options are checked first, before the scene is read or cut; ``reduced``: the
    strengths will be reduced (something must be reducible); ``edit``: more overrides,
    ``edit(raw)`` in place."""
    import dda
    from dda.commands.cli import default_outdir, load_with_progress, scene_source
    from dda.scene import read_scene_file
    from dda.scene.limits import check_run_size
    from dda.stability.criterion import criterion_of
    from dda.stability.fos import check_reducible
    from dda.stability.trial import trial_scene

    try:
        path = scene_source(args.scene)
    except dda.SceneError as exc:
        return f"dda {command}: {exc}"
    where = output_and_cluster(args, command, args.outdir or default_outdir(command, path))
    if isinstance(where, str):
        return where
    try:
        written = read_scene_file(path)
        raw = with_overrides(written, args)
        if edit is not None:
            edit(raw)
        if _replaced(written, raw):  # the scene's own values are checked too (docs/scene.md)
            load_with_progress(written, source=str(path))
    except dda.SceneError as exc:
        return f"dda {command}: {exc}"
    try:
        scene = load_with_progress(raw, source=str(path))  # a bar while a long cut runs
        criterion = criterion_of(scene)
        if reduced:
            check_reducible(scene)
        check_run_size(trial_scene(scene, 1.0))  # before any row is written
    except dda.SceneError as exc:
        option = _option_of(exc.key, args)
        if option is not None:  # the option's value, not the file's
            return f"dda {command}: argument {option}: {exc.reason}"
        return f"dda {command}: {exc}"
    return (raw, scene, criterion, str(path), *where)


def _option_of(key: str, args: argparse.Namespace) -> str | None:
    """The command-line option whose value the scene key ``key`` took (``fos.upper`` from
    ``--upper``, ``ensemble.seed`` from ``--seed``), or None: a value refused is then
    said of the option, not of the scene file the user did not change (an audit)."""
    section, _, name = key.partition(".")
    name = name.split("[")[0].split(".")[0]
    given = {"fos": [*OVERRIDES, "blocks", "intact"], "ensemble": ["realisations", "seed"]}
    value = getattr(args, name, None)
    if name not in given.get(section, ()) or value is None or value is False:
        return None
    return f"--{name}"


def _replaced(written: dict, raw: dict) -> bool:
    """True when the options replaced a value the scene's ``[fos]`` or ``[ensemble]``
    table gives (a value ``dda run`` would refuse must not pass unseen)."""
    for section in ("fos", "ensemble"):
        given, used = written.get(section), raw.get(section)
        if isinstance(given, dict) and isinstance(used, dict):
            if any(key in used and used[key] != value for key, value in given.items()):
                return True
    return False


def output_and_cluster(args: argparse.Namespace, command: str, outdir: Path):
    """(output folder, cluster or None) for ``command``, or its one-line refusal: the
    folder ``outdir`` must be writable, and the cluster options must be usable."""
    from dda.io.output_paths import OutputError, check_output_dir

    try:
        check_output_dir(outdir)
    except OutputError as exc:
        return f"dda {command}: -o {exc}"
    cluster = cluster_of(args, command)
    return cluster if isinstance(cluster, str) else (outdir, cluster)


def fos_command(args: argparse.Namespace) -> int:
    """Run the search; return the exit code (0 done, 2 bad input, 130 interrupted)."""
    from dda.parallel import ClusterError, Workers
    from dda.stability.search import search
    from dda.stability.store import RowStore, refuse_foreign, scene_hash
    from dda.stability.strength_reduction import brittle_note

    prepared = prepare(args, "fos")
    if isinstance(prepared, str):
        print(prepared, file=sys.stderr)
        return EXIT_INPUT
    raw, scene, criterion, source, outdir, cluster = prepared
    store = RowStore(outdir / "fos.csv", COLUMNS, scene_hash(raw, source))
    refused = refuse_foreign(store, "fos", "trial(s)", args.overwrite)
    if refused is not None:
        print(refused, file=sys.stderr)
        return EXIT_INPUT
    fos = scene.fos
    print(
        f"{source}: strength reduction F in [{fos.lower:g}, {fos.upper:g}] to {fos.tolerance:g}; "
        f"a trial fails above {criterion.velocity:.3g} {scene.units.velocity} in its last "
        f"{criterion.window * criterion.duration:g} {scene.units.time}",
        file=sys.stderr,
    )
    note = brittle_note(scene)
    if note is not None:
        print(note, file=sys.stderr)
    try:
        with Workers(cluster) as workers:  # connected before anything is written
            args.kept_on_interrupt = (
                f"the finished trials are in {outdir / 'fos.csv'}: the same command reuses them"
            )
            runner = _Runner(raw, source, store, scene.units.velocity)
            runner.workers = workers
            outcome = search(runner.run, fos.lower, fos.upper, fos.tolerance, workers.size)
    except ClusterError as exc:
        print(f"dda fos: {exc}", file=sys.stderr)
        return EXIT_INPUT
    _finish(outdir, runner, outcome, scene, criterion)
    print(outcome.describe())
    return 0


class _Runner:
    """Runs a round of trials, reusing stored ones, writing each row as it finishes."""

    def __init__(self, raw: dict, source: str, store, speed_unit: str) -> None:
        from dda.stability.search import DIGITS

        self.raw, self.source, self.store, self.unit = raw, source, store, speed_unit
        self.rows: dict[float, dict] = {}
        for parsed in store.open(_parse_row):
            self.rows[round(parsed["factor"], DIGITS)] = parsed
        for note in store.notes():
            print(f"dda fos: {note}", file=sys.stderr)
        self.frames: dict[float, Any] = {}
        self.moving: dict[float, list[dict]] = {}  # the blocks faster than the limit
        self.workers = None
        self.done = 0

    def run(self, factors: list[float]):
        from dda.stability.trial import Trial, run_trial

        todo = [f for f in factors if f not in self.rows]
        for factor in factors:
            if factor in self.rows:
                self._progress(self.rows[factor], "reused")
                yield factor, self.rows[factor]["failed"]
        trials = [Trial(self.raw, f, self.source) for f in todo]
        for row in self.workers.map_unordered(run_trial, trials):
            frame, self.moving[row["factor"]] = row.pop("frame"), row.pop("moving")
            if frame is not None:
                self.frames[row["factor"]] = frame
            self.store.append(row)
            self.rows[row["factor"]] = row
            self._progress(row, f"{row['seconds']:.2f} s on {row['host']}")
            yield row["factor"], row["failed"]

    def _progress(self, row: dict, where: str) -> None:
        self.done += 1
        verdict = "fails " if row["failed"] else "stands"
        print(
            f"[trial {self.done}] F = {row['factor']:<10.6g} {verdict} mean speed "
            f"{row['speed']:.3g} {self.unit} (limit {row['limit']:.3g})  {where}",
            file=sys.stderr,
            flush=True,
        )


def _parse_row(row: dict[str, str]) -> dict:
    from dda.stability.store import flag

    return {
        "factor": float(row["factor"]),
        "failed": flag(row["failed"]),
        "speed": float(row["speed"]),
        "limit": float(row["limit"]),
        "steps": int(row["steps"]),
        "seconds": float(row["seconds"]),
        "host": row["host"],
        "status": row["status"],
    }


def _finish(outdir: Path, runner: _Runner, outcome, scene, criterion) -> None:
    """fos.png, failure.png (the first failing trial, blocks by displacement), fos.json
    (with the blocks that move at the first failing F)."""
    from dda.io.atomic import write_text
    from dda.io.images import render_frame, scene_look
    from dda.stability.criterion import criterion_record
    from dda.stability.report import fos_plot
    from dda.stability.trial import Trial, run_trial

    rows = sorted(runner.rows.values(), key=lambda r: r["factor"])
    fos_plot(rows, outcome, criterion.velocity, outdir / "fos.png", scene.title,
             scene.units.velocity)  # fmt: skip
    written = ["fos.csv", "fos.png"]
    moving = None
    if outcome.fails is not None:
        frame, moving = runner.frames.get(outcome.fails), runner.moving.get(outcome.fails)
        if frame is None or moving is None:  # a reused trial: run it again for its picture
            again = run_trial(Trial(runner.raw, outcome.fails, runner.source))
            frame, moving = again["frame"], again["moving"]
        if frame is not None:
            render_frame(
                frame, outdir / "failure.png", scalars="displacement",
                title=f"first failing trial: F = {outcome.fails:.6g}, t = {frame.time:.4g} "
                f"{scene.units.time}", **scene_look(scene),
            )  # fmt: skip
            written.append("failure.png")
    summary = {
        "scene": runner.source,
        "fos": outcome.fos,
        "stands": outcome.stands,
        "fails": outcome.fails,
        "verdict": outcome.verdict,
        "tolerance": scene.fos.tolerance,
        "criterion": criterion_record(criterion, scene),
        "trials": len(rows),
        # at the first failing F: the watched blocks whose mean speed exceeds the limit
        "moving_blocks": moving,
    }
    write_text(outdir / "fos.json", json.dumps(summary, indent=2) + "\n")
    written.append("fos.json")
    print(f"wrote {outdir}/" + ", ".join(written), file=sys.stderr)
