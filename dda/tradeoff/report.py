"""Outputs of a study: the CSV of every run, the markdown table, the Pareto plot."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from dda.io.wording import counted
from dda.tradeoff.pareto import fronts_by_method

COLUMNS = (
    "case",
    "method",
    "penalty",
    "tolerance",
    "time_step",
    "ratio",
    "status",
    "steps",
    "seconds",
    "repeats",
    "seconds_all",
    "threads",
    "host",
    "error",
    "max_penetration",
    "value",
    "reference",
)


# columns written to the last bit (repr: 17 significant digits), so that a setting's error
# can be recomputed from them: the sliding block's are ~1e-9 of the value, below the 8
# digits the other lists are written with
EXACT_COLUMNS = ("value", "reference")


def write_csv(rows: list[dict], path: Path) -> Path:
    """Every run, one line each, sorted by method then time."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, COLUMNS, extrasaction="ignore")
        writer.writeheader()
        for row in sorted(rows, key=lambda r: (r["method"], r["seconds"])):
            writer.writerow({k: _cell(row.get(k), k in EXACT_COLUMNS) for k in COLUMNS})
    return path


def _cell(value, exact: bool = False):
    """A CSV cell: a list's numbers separated by blanks; floats to 6 significant digits
    (lists to 8), or to the last bit (``repr``) when ``exact``."""
    if isinstance(value, list):
        return " ".join(repr(float(v)) if exact else f"{v:.8g}" for v in value)
    if isinstance(value, float):
        return repr(value) if exact else f"{value:.6g}"
    return value


def markdown_table(rows: list[dict], quantity: str = "") -> str:
    """The Pareto fronts, one block of rows per method."""
    lines = [
        f"Quantity: {quantity}." if quantity else "",
        "",
        "| method | penalty (×E) | tolerance (×size) | Δt | g2 "
        "| error | seconds (median) | steps | host |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for method, front in fronts_by_method(rows).items():
        for r in front:
            tol = "–" if method == "penalty" else f"{r['tolerance']:g}"
            lines.append(
                f"| {method} | {r['penalty']:g} | {tol} | {r['time_step']:g} "
                f"| {r['ratio']:g} "
                f"| {r['error']:.2e} | {r['seconds']:.2f} "
                f"| {r['steps']} | {r.get('host', '')} |"
            )
    failed = sum(r["status"] != "finished" for r in rows)
    lines.append("")
    stopped = counted(failed, "setting")
    lines.append(f"{count_line(rows)}; {stopped} stopped with a SimulationError.")
    return "\n".join(lines).lstrip("\n") + "\n"


def count_line(rows: list[dict]) -> str:
    """``"24 settings × 3 repeats = 72 runs"`` (a setting stops at its first failed run)."""
    runs = sum(r["repeats"] for r in rows)
    repeats = {r["repeats"] for r in rows}
    if len(repeats) > 1:
        return f"{counted(len(rows), 'setting')}, {counted(runs, 'run')} in all"
    return plan_line(len(rows), repeats.pop() if repeats else 0)


def plan_line(settings: int, repeats: int) -> str:
    """``"24 settings × 3 repeats = 72 runs"``."""
    runs = counted(settings * repeats, "run")
    return f"{counted(settings, 'setting')} × {counted(repeats, 'repeat')} = {runs}"


def pareto_plot(rows: list[dict], path: Path, title: str = "") -> Path:
    """Error against wall seconds, every run as a dot and each method's front as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.4, 4.4), dpi=120)
    for k, (method, front) in enumerate(fronts_by_method(rows).items()):
        colour = f"C{k}"
        runs = [r for r in rows if r["method"] == method and not math.isnan(r["error"])]
        ax.scatter(
            [r["seconds"] for r in runs],
            [max(r["error"], 1e-16) for r in runs],
            s=12,
            color=colour,
            alpha=0.35,
        )
        ax.plot(
            [r["seconds"] for r in front],
            [max(r["error"], 1e-16) for r in front],
            "o-",
            color=colour,
            label=f"{method} (front)",
        )
    ax.set_xscale("log")
    _plain_log_ticks(ax.xaxis, [r["seconds"] for r in rows if r["seconds"] > 0])
    ax.set_yscale("log")
    ax.set_xlabel("wall time of a run, median of its repeats (s)")
    ax.set_ylabel("relative error")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)  # off the dots
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def _plain_log_ticks(axis, values: list[float]) -> None:
    """Label a log axis in plain numbers (0.5, 1, 2, 5, 10), at 1, 2 and 5 of each decade
    when the ``values`` span up to 1.5 decades, at 1 and 3 up to 3, else at 1; the other
    ticks unlabelled. (A run's times often span less than a decade, where matplotlib
    labels every minor tick in powers of ten and the labels overlap.)"""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    decades = math.log10(max(values) / min(values)) if values else 0.0
    subs = (1.0, 2.0, 5.0) if decades <= 1.5 else (1.0, 3.0) if decades <= 3.0 else (1.0,)
    axis.set_major_locator(LogLocator(subs=subs))
    axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(NullFormatter())
