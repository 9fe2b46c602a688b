"""``dda ensemble SCENE [--realisations N] [--seed S] [--fos] [-o OUT] [fos options]
[--workers N | --scheduler ADDRESS | --scheduler-file FILE | --serial]``."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from dda.commands.cli import EXIT_FAILURE, output_path
from dda.commands.cluster_options import add_cluster_options, count
from dda.commands.fos import EXIT_INPUT, add_fos_options, add_overwrite_option, prepare

BASE_COLUMNS = ("realisation", "seed")
OUTCOME_COLUMNS = ("failed", "speed", "limit", "fos", "steps", "seconds", "host", "status")
PICTURES = 3  # failing realisations drawn


def register(subparsers: Any) -> None:
    """Add the ``ensemble`` sub-command (entry point of group ``dda.commands``)."""
    p = subparsers.add_parser(
        "ensemble",
        help="probability of failure over realisations of random joint properties",
        description="Draw the scene's [ensemble] values for each realisation, cut, run and "
        "judge it by the [fos] criterion at F = 1 (with --fos: also search its factor of "
        "safety); P(failure) with its 95 % Wilson interval. Writes OUT/ensemble.csv (a row per "
        "realisation as it finishes: a rerun reuses them), OUT/ensemble.png, "
        "OUT/failing_K.png and OUT/ensemble.json (docs/stability.md).",
    )
    p.add_argument("scene", type=Path, help="scene file (or a shipped case's name)")
    p.add_argument(
        "-o", "--outdir", type=output_path, help="output folder (default out/ensemble_<scene>)"
    )
    p.add_argument(
        "--realisations", type=count, metavar="N", help="[ensemble] realisations (default 100)"
    )
    p.add_argument("--seed", type=int, metavar="S", help="[ensemble] seed, the root seed")
    p.add_argument(
        "--fos", action="store_true", help="give every realisation its own factor of safety"
    )
    add_overwrite_option(p, "realisations")
    add_fos_options(p)
    add_cluster_options(p)
    p.set_defaults(func=ensemble_command)


def ensemble_command(args: argparse.Namespace) -> int:
    """Run the realisations; return the exit code (0 done, 1 every realisation refused,
    2 bad input, 130 interrupted)."""
    from dda.parallel import ClusterError, Workers
    from dda.stability.store import RowStore, refuse_foreign, scene_hash

    prepared = prepare(args, "ensemble", reduced=args.fos, edit=_ensemble_overrides(args))
    if isinstance(prepared, str):
        print(prepared, file=sys.stderr)
        return EXIT_INPUT
    raw, scene, criterion, source, outdir, cluster = prepared
    if scene.ensemble is None or not scene.ensemble.vary:
        print(f"dda ensemble: {source}: ensemble.vary: the scene draws no value "
              "(add [[ensemble.vary]] tables, docs/scene.md)", file=sys.stderr)  # fmt: skip
        return EXIT_INPUT
    ensemble = scene.ensemble
    keys = [d.key for d in ensemble.vary]
    columns = (*BASE_COLUMNS, *keys, *OUTCOME_COLUMNS)
    unsized = {**raw, "ensemble": {k: v for k, v in raw["ensemble"].items() if k != "realisations"}}
    store = RowStore(outdir / "ensemble.csv", columns, scene_hash(unsized, source, args.fos))
    refused = refuse_foreign(store, "ensemble", "realisation(s)", args.overwrite)
    if refused is not None:
        print(refused, file=sys.stderr)
        return EXIT_INPUT
    try:
        with Workers(cluster) as workers:  # connected before anything is written
            args.kept_on_interrupt = (
                f"the finished realisations are in {outdir / 'ensemble.csv'}: the same "
                "command reuses them"
            )
            rows = {r["realisation"]: r for r in store.open(lambda row: _parse(row, keys))}
            for note in store.notes():
                print(f"dda ensemble: {note}", file=sys.stderr)
            rows = {k: r for k, r in rows.items() if k < ensemble.realisations}
            print(f"{source}: {ensemble.realisations} realisations (seed {ensemble.seed}; "
                  f"{len(rows)} reused), drawing " + ", ".join(keys), file=sys.stderr)  # fmt: skip
            frames = _run(raw, source, args.fos, ensemble.realisations, rows, store, workers, keys)
    except ClusterError as exc:
        print(f"dda ensemble: {exc}", file=sys.stderr)
        return EXIT_INPUT
    _finish(outdir, raw, source, scene, rows, frames, keys, args.fos)
    if rows and all(r["failed"] is None for r in rows.values()):  # no answer: say why
        first = rows[min(rows)]
        print(f"dda ensemble: {source}: every realisation was refused (realisation "
              f"{first['realisation']}: {first['status']}); no probability of failure",
              file=sys.stderr)  # fmt: skip
        return EXIT_FAILURE
    return 0


def _ensemble_overrides(args: argparse.Namespace):
    """An ``edit`` for :func:`prepare` that puts --realisations and --seed in place."""

    def edit(raw: dict) -> None:
        table = raw.get("ensemble")
        if isinstance(table, dict):
            table = raw["ensemble"] = dict(table)
            if args.realisations is not None:
                table["realisations"] = args.realisations
            if args.seed is not None:
                table["seed"] = args.seed

    return edit


def _run(raw, source, with_fos, total, rows, store, workers, keys) -> dict[int, Any]:
    """Run the missing realisations on ``workers`` (a connected
    :class:`dda.parallel.Workers`), writing each row as it finishes; the frames of the
    failing ones."""
    from dda.stability.ensemble import Realisation, run_realisation

    todo = [Realisation(raw, k, source, with_fos) for k in range(total) if k not in rows]
    frames: dict[int, Any] = {}
    for row in workers.map_unordered(run_realisation, todo):
        frame = row.pop("frame", None)
        if frame is not None and len(frames) < 4 * PICTURES:
            frames[row["realisation"]] = frame
        flat = {**row, **row.pop("values")}
        store.append(flat)
        rows[row["realisation"]] = flat
        _progress(len(rows), total, flat, keys)
    return frames


def _progress(done: int, total: int, row: dict, keys: list[str]) -> None:
    drawn = " ".join(f"{k.split('.')[-1]}={row[k]:.4g}" for k in keys)
    verdict = "refused" if row["failed"] is None else "fails " if row["failed"] else "stands"
    extra = "" if math.isnan(row["fos"]) else f" FoS {row['fos']:.4g}"
    print(
        f"[{done}/{total}] realisation {row['realisation']}: {drawn} {verdict}{extra} "
        f"({row['seconds']:.2f} s on {row['host']})",
        file=sys.stderr,
        flush=True,
    )


def _parse(row: dict[str, str], keys: list[str]) -> dict:
    from dda.stability.store import flag

    failed = flag(row["failed"], refused=True)
    return {
        "realisation": int(row["realisation"]),
        "seed": int(row["seed"]),
        **{k: float(row[k]) for k in keys},
        "failed": failed,
        "speed": float(row["speed"]),
        "limit": float(row["limit"]),
        "fos": float(row["fos"]),
        "steps": int(row["steps"]),
        "seconds": float(row["seconds"]),
        "host": row["host"],
        "status": row["status"],
    }


def _finish(outdir, raw, source, scene, rows, frames, keys, with_fos) -> None:
    """ensemble.png, failing_K.png, ensemble.json; the answer on stdout."""
    from dda.io.atomic import write_text
    from dda.stability.ensemble import wilson
    from dda.stability.report import ensemble_plot

    judged = [r for r in rows.values() if r["failed"] is not None]
    failures = sum(bool(r["failed"]) for r in judged)
    p, low, high = wilson(failures, len(judged))
    refused = len(rows) - len(judged)
    first = keys[0]
    values = [r["fos"] for r in judged] if with_fos else [r[first] for r in judged]
    label = "factor of safety" if with_fos else _label(first, scene.units)
    failed = [bool(r["failed"]) for r in judged]
    # a FoS outside the search's bounds: below them if the realisation fails at F = 1
    below = sum(not math.isfinite(v) and f for v, f in zip(values, failed, strict=True))
    outside = sum(not math.isfinite(v) for v in values) if with_fos else 0
    title = (
        f"{scene.title}\nP(failure) = {p:.3f}, 95 % Wilson interval [{low:.3f}, {high:.3f}], "
        f"n = {len(judged)}"
        + (
            f"; FoS below the search's bounds {below}, above {outside - below} (in the CDF "
            "beyond its ends, not in the histogram)"
            if outside
            else ""
        )  # fmt: skip
    )
    written = ["ensemble.csv"]
    if judged:
        keep = [(v, f) for v, f in zip(values, failed, strict=True) if math.isfinite(v)]
        if keep:
            ensemble_plot(*zip(*keep, strict=True), label, outdir / "ensemble.png", title,
                          factor_of_safety=with_fos, outside=(below, outside - below))  # fmt: skip
            written.append("ensemble.png")
    written += _failure_pictures(outdir, raw, source, scene, rows, frames, keys)
    summary = {
        "scene": source,
        "seed": scene.ensemble.seed,
        "realisations": len(rows),
        "judged": len(judged),
        "refused": refused,
        "failures": failures,
        "p_failure": p if judged else None,  # JSON has no NaN
        "interval_95": [low, high],
        "interval": "Wilson score",
    }
    if with_fos:  # the mean of the FoS found: one outside the bounds is not a number
        finite = [v for v in values if math.isfinite(v)]
        summary["fos_mean"] = sum(finite) / len(finite) if finite else None
        summary["fos_found"] = len(finite)
        summary["fos_outside_bounds"] = outside
    write_text(outdir / "ensemble.json", json.dumps(summary, indent=2) + "\n")
    written.append("ensemble.json")
    print(f"wrote {outdir}/" + ", ".join(written), file=sys.stderr)
    print(
        f"P(failure) = {p:.4g} ({failures} of {len(judged)} realisations fail), "
        f"95 % Wilson interval [{low:.4g}, {high:.4g}]"
        + (f"; {refused} refused" if refused else "")
        + (f"; {outside} with FoS outside the search's bounds" if outside else "")
    )


def _label(key: str, units) -> str:
    """An axis label for a drawn value: its key and unit."""
    return f"{key} ({_unit(key, units)})"


def _unit(key: str, units) -> str:
    """The unit of a drawn value (docs/stability.md lists them): angles in degrees,
    strengths in the scene's stress unit, the joint sets' lengths in its length unit."""
    field = key.split(".")[-1]
    if field in ("friction_angle", "dip"):
        return "°"
    if field in ("cohesion", "tensile_strength"):
        return units.stress
    return units.length


def _drawn(row: dict, keys, units) -> str:
    """The drawn values of a realisation with their units ("friction_angle = 28.1°, …")."""
    return ", ".join(f"{k.split('.')[-1]} = {_with_unit(row[k], _unit(k, units))}" for k in keys)


def _with_unit(value: float, unit: str) -> str:
    return f"{value:.4g}°" if unit == "°" else f"{value:.4g} {unit}"


def _failure_pictures(outdir, raw, source, scene, rows, frames, keys) -> list[str]:
    """The first three failing realisations at the end of their run, by displacement:
    ``failing_K.png``, K the realisation's index (as in ensemble.csv)."""
    from dda.io.images import render_frame, scene_look
    from dda.stability.ensemble import Realisation, run_realisation

    failing = sorted(k for k, r in rows.items() if r["failed"])[:PICTURES]
    names = []
    for k in failing:
        frame = frames.get(k)
        if frame is None:  # a reused realisation: run it again for its picture
            frame = run_realisation(Realisation(raw, k, source)).get("frame")
        if frame is None:
            continue
        drawn = _drawn(rows[k], keys, scene.units)
        render_frame(frame, outdir / f"failing_{k}.png", scalars="displacement",
                     title=f"realisation {k}: {drawn}", **scene_look(scene))  # fmt: skip
        names.append(f"failing_{k}.png")
    for stale in outdir.glob("failing_*.png"):  # of an earlier ensemble (another seed)
        if stale.name not in names:
            stale.unlink(missing_ok=True)
    return names
