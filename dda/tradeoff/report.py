"""Outputs of a study: the CSV of every run, the markdown table, the Pareto plot."""

from __future__ import annotations

import csv
import math
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

from dda.io.wording import counted
from dda.tradeoff.pareto import fronts_by_method

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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
    """Every run, one line each, sorted by method then time; the penalty method's rows
    leave the tolerance empty (it ignores it; the grid's value is no setting of theirs)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, COLUMNS, extrasaction="ignore")
        writer.writeheader()
        for row in sorted(rows, key=lambda r: (r["method"], r["seconds"])):
            cells = {k: _cell(row.get(k), k in EXACT_COLUMNS) for k in COLUMNS}
            if row.get("method") == "penalty":
                cells["tolerance"] = ""
            writer.writerow(cells)
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


TITLE_WIDTH = 90  # characters of a line of the picture's title (wrapped beyond)


def pareto_plot(rows: list[dict], path: Path, title: str = "") -> Path:
    """Write :func:`pareto_figure` of ``rows`` to the PNG file ``path`` (off screen, Agg)."""
    import matplotlib.pyplot as plt

    fig = pareto_figure(rows, title)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def pareto_figure(rows: list[dict], title: str = "") -> Figure:
    """Error against wall seconds, every run as a dot and each method's front as a line.

    Laid out by matplotlib's constrained layout so that the title (wrapped, over the
    whole picture) and the legend (under the plot, off the dots) fit the picture. An
    error of exactly 0 has no place on a log axis: such runs are drawn on a dashed floor
    a decade below the smallest error above 0 (:func:`zero_floor`), which the legend
    names. Drawn off screen (matplotlib's Agg backend); the caller closes the figure
    (``matplotlib.pyplot.close``).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    drawn = [r for r in rows if not math.isnan(r["error"])]
    floor = zero_floor([r["error"] for r in drawn])
    fig, ax = plt.subplots(figsize=(8.4, 4.6), dpi=120, layout="constrained")
    for k, (method, front) in enumerate(fronts_by_method(rows).items()):
        colour = f"C{k}"
        runs = [r for r in drawn if r["method"] == method]
        ax.scatter(
            [r["seconds"] for r in runs],
            [max(r["error"], floor) for r in runs],
            s=12,
            color=colour,
            alpha=0.35,
        )
        ax.plot(
            [r["seconds"] for r in front],
            [max(r["error"], floor) for r in front],
            "o-",
            color=colour,
            label=f"{method} (front)",
        )
    if any(r["error"] == 0 for r in drawn):
        ax.axhline(floor, color="0.5", linestyle="--", linewidth=0.8,
                   label=f"error exactly 0, drawn at {floor:.0e}")  # fmt: skip
    ax.set_xscale("log")
    _plain_log_ticks(ax.xaxis, [r["seconds"] for r in rows if r["seconds"] > 0])
    ax.set_yscale("log")
    ax.set_xlabel("wall time of a run, median of its repeats (s)")
    ax.set_ylabel("relative error")
    fig.suptitle(textwrap.fill(title, TITLE_WIDTH), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=9)
    return fig


def zero_floor(errors: list[float]) -> float:
    """Where an error of exactly 0 is drawn on the log axis: the power of ten a decade
    below the smallest error above 0 (1e-16, a double's relative precision, when there
    is none), so that it stays apart from every measured error."""
    positive = [e for e in errors if e > 0 and math.isfinite(e)]
    if not positive:
        return 1e-16
    return 10.0 ** (math.floor(math.log10(min(positive))) - 1)


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
