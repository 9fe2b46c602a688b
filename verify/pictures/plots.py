"""Curves of the verification, drawn with matplotlib (off screen, Agg).

The histories of a dynamic case (centroid displacement and rotation of both
models, their signed differences against the tolerance band), the summary bar
chart (every case's largest error over its tolerance, per checked quantity)
and the block-refinement convergence plot (errors against k, log-log, with
slopes 1 and 2). The field pictures of static cases are pyvista's
(:mod:`verify.pictures.field_pictures`).
"""

from __future__ import annotations

import logging
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullLocator  # noqa: E402

from verify.harness.cases import CaseResult  # noqa: E402

log = logging.getLogger(__name__)


def history_picture(result: CaseResult, title: str, path: Path) -> Path:
    """Write the histories of a dynamic case and their signed differences; returns the path."""
    s = result.series
    t = s["times"]
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    ax = axes[0, 0]
    for m, c in enumerate(("ux", "uy")):
        ax.plot(t, 1e3 * s["fem_u"][:, 0, m], "-", label=f"FEM {c}")
        ax.plot(t, 1e3 * s["dda_u"][:, 0, m], "o", markersize=3, label=f"DDA {c}")
    ax.set_ylabel("centroid displacement (mm)")
    ax.set_title(f"{s['blocks'][0]}: centroid displacement", fontsize=10)
    ax = axes[0, 1]
    ax.plot(t, 1e3 * s["fem_r"][:, 0], "-", label="FEM")
    ax.plot(t, 1e3 * s["dda_r"][:, 0], "o", markersize=3, label="DDA")
    ax.set_ylabel("rotation (mrad)")
    ax.set_title("rotation", fontsize=10)
    for ax, quantity in ((axes[1, 0], "history"), (axes[1, 1], "stress_history")):
        check = result.expectation.checks.get(quantity)
        for component in sorted({r.component for r in result.rows if r.quantity == quantity}):
            rows = [r for r in result.rows if r.quantity == quantity and r.component == component]
            style = "-" if check and check.applies_to(rows[0].item, component) else ":"
            ax.plot(t, [r.signed_error for r in rows], style, label=component)
        if check:
            ax.axhspan(-check.tolerance, check.tolerance, color="#bbddbb", alpha=0.5, label="±tol")
        ax.set_ylabel("(DDA − FEM) / scale")
        ax.set_title(f"{quantity}: signed difference (dotted: not checked)", fontsize=10)
    return _finish(fig, axes, title, path)


def motion_picture(result: CaseResult, title: str, path: Path) -> Path:
    """A motion case: centroid displacement and rotation of the DDA (finest Δt) against
    the closed form, their signed differences, and the errors against Δt (log-log)."""
    s = result.series
    t, valid = s["times"], s["valid"]
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    ax = axes[0, 0]
    for m, c in enumerate(("ux", "uy")):
        ax.plot(t[valid], 1e3 * s["ref_u"][valid, m], "-", label=f"closed form {c}")
        ax.plot(t, 1e3 * s["dda_u"][:, m], "o", markersize=3, label=f"DDA {c}")
    ax.set_ylabel("centroid displacement (mm)")
    ax.set_title(f"{s['block']}: centroid displacement", fontsize=10)
    ax = axes[0, 1]
    ax.plot(t[valid], s["ref_r"][valid], "-", label="closed form")
    ax.plot(t, s["dda_r"], "o", markersize=3, label="DDA (from its vertices)")
    ax.set_ylabel("rotation (rad)")
    ax.set_title("rotation", fontsize=10)
    ax = axes[1, 0]
    check = result.expectation.checks.get("motion")
    for component in ("ux", "uy", "r"):
        rows = [r for r in result.rows if r.quantity == "motion" and r.component == component]
        times = [float(r.item.split("@")[1]) for r in rows]
        ax.plot(times, [r.signed_error for r in rows], "-", label=component)
    if check:
        ax.axhspan(-check.tolerance, check.tolerance, color="#bbddbb", alpha=0.5, label="±tol")
    ax.set_ylabel("(DDA − closed form) / scale")
    ax.set_xlabel("time (s)")
    ax.set_title("signed difference, finest Δt", fontsize=10)
    ax = axes[1, 1]
    steps = sorted(s["errors"])
    dts = np.array([s["time_steps"][f] for f in steps])
    labels = {"ux": "ux (m)", "uy": "uy (m)", "r": "r (rad)", "e": "1 − e (rebound)"}
    for component in s["errors"][steps[0]] if steps else ():
        errors = np.array([s["errors"][f][component] for f in steps])
        if np.all(errors > 0):
            order = s["orders"].get(component, float("nan"))
            label = f"{labels.get(component, component)}, order {order:.2f}"
            ax.loglog(dts, errors, "o-", label=label)
    if dts.size:
        ax.loglog(dts, dts / dts.max() * ax.get_ylim()[1] / 2, "k:", label="slope 1")
    ax.set_xlabel("time step Δt (s)")
    ax.set_ylabel("largest |DDA − closed form|")
    ax.set_title("convergence in Δt (no line: exact to round-off)", fontsize=10)
    return _finish(fig, axes, title, path, keep_x_label=axes[1, 1])


def momentum_picture(result: CaseResult, title: str, path: Path) -> Path:
    """A ``momentum`` case: the total momentum and the centre of mass of the DDA against
    their conservation, and the largest overlap of two blocks."""
    s = result.series
    t = s["times"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    ax = axes[0]
    for m, c in enumerate(("px", "py")):
        ax.plot(t, s["momentum"][:, m] - s["ref_momentum"][m], "o-", markersize=3, label=c)
    ax.set_ylabel("Σ m v − P0 (N s)")
    ax.set_title(f"total momentum, P0 = {s['ref_momentum']} N s", fontsize=10)
    ax = axes[1]
    for m, c in enumerate(("ux", "uy")):
        ax.plot(t, 1e3 * s["ref_u"][:, m], "-", label=f"P0 t / M, {c}")
        ax.plot(t, 1e3 * s["dda_u"][:, m], "o", markersize=3, label=f"DDA {c}")
    ax.set_ylabel("displacement (mm)")
    ax.set_title("centre of mass", fontsize=10)
    ax = axes[2]
    ax.plot(t, s["overlap"], "o-", markersize=3, label="DDA")
    check = result.expectation.checks.get("overlap")
    if check:
        ax.axhline(check.tolerance, color="r", linestyle=":", label="tolerance")
    ax.set_ylabel("overlap area / smaller block's area")
    ax.set_title("largest overlap of two blocks", fontsize=10)
    return _finish(fig, axes, title, path)


# the summary's columns: checked quantities in groups, in this order (others at the end)
QUANTITY_GROUPS = {
    "stress and strain": ("stress", "strain", "stress_history"),
    "position and shape": ("centroid", "vertex", "area", "history", "motion", "closed_form",
                           "order", "momentum", "ground"),
    "contact": ("contact_force", "contact_state", "penetration", "al_updates", "overlap",
                "contact_time", "impact_time", "impact_speed", "rebound"),
    "energy and fracture": ("energy", "dissipation", "onset", "children", "crack"),
}  # fmt: skip
RATIO_DECADES = (-8, 1)  # the colour scale of error / tolerance: 1e-8 ... 10
FAIL_COLOUR = "#d7301f"  # a check beyond its tolerance


SUMMARY_MIN_WIDTH = 8.0  # inches: the colour bar's ten decade labels side by side
# characters of a group's label a column holds (0.62 inch at 9 pt, bold): a longer label
# wraps (two one-column groups side by side printed over each other)
GROUP_CHARACTERS = 8


def summary_chart(results: list[CaseResult], path: Path) -> Path:
    """Largest error over its tolerance of every case (rows) and checked quantity
    (columns, in groups): a cell per check, coloured by decade from dark green (far
    within the tolerance) to pale yellow (near it), red beyond it, and labelled with the
    ratio; blank where a case does
    not check the quantity. Readable at 100 %: a row per case, the numbers written."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    columns, groups = _summary_columns(results)
    ratios = np.full((len(results), len(columns)), np.nan)
    for i, r in enumerate(results):
        for v in r.verdicts:
            ratios[i, columns.index(v.quantity)] = v.error / v.tolerance if v.tolerance else np.nan
    low, high = RATIO_DECADES
    edges = np.arange(low, high + 1)
    within = plt.get_cmap("YlGn_r")(np.linspace(0.0, 0.9, -low))  # dark: far within
    cmap = ListedColormap([*within, *[FAIL_COLOUR] * high])  # above 1: the check fails
    norm = BoundaryNorm(edges, cmap.N)
    shown = np.log10(np.clip(ratios, 10.0**low, 10.0 ** (high - 1e-9)))
    width = max(SUMMARY_MIN_WIDTH, 3.2 + 0.62 * len(columns))  # the colour bar's labels fit
    height = 2.6 + 0.3 * len(results)
    fig, ax = plt.subplots(figsize=(width, height))
    image = ax.imshow(np.ma.masked_invalid(shown), cmap=cmap, norm=norm, aspect="auto")
    for (i, j), ratio in np.ndenumerate(ratios):
        if np.isfinite(ratio):
            dark = shown[i, j] >= 0.0 or shown[i, j] < low + 4
            ax.text(j, i, _ratio_text(ratio), ha="center", va="center", fontsize=8,
                    color="white" if dark else "black")  # fmt: skip
    ax.set_yticks(range(len(results)), [_case_label(r) for r in results], fontsize=9)
    ax.set_xticks(range(len(columns)), columns, rotation=50, ha="left", fontsize=9)
    ax.xaxis.tick_top()
    ax.set_xticks(np.arange(-0.5, len(columns)), minor=True)
    ax.set_yticks(np.arange(-0.5, len(results)), minor=True)
    ax.grid(which="minor", color="white", linewidth=1.5)
    ax.tick_params(which="minor", length=0)
    start, lines = 0, 1
    for name, count in groups:
        if start:
            ax.axvline(start - 0.5, color="black", linewidth=1.5)
        label = textwrap.fill(name, max(GROUP_CHARACTERS, GROUP_CHARACTERS * count))
        lines = max(lines, label.count("\n") + 1)  # a group of one column: a word a line
        ax.text(start + count / 2 - 0.5, len(results) - 0.2, label, ha="center", va="top",
                fontsize=9, fontweight="bold")  # fmt: skip
        start += count
    ax.set_ylim(len(results) + 0.4 + 0.6 * lines, -0.5)
    ax.set_title("DDA against FEM or a closed form: every check of every case", pad=12)
    # the colour bar in its own strip under the table: 0.25 inch thick and 0.6 of the
    # figure long whatever the rows (beside the table, one row made it a sliver of
    # squashed labels)
    strip = 0.9 / height  # the bar, its labels and its title
    fig.tight_layout(rect=(0.0, strip, 1.0, 1.0))
    cax = fig.add_axes((0.2, 0.55 * strip, 0.6, 0.25 / height))
    bar = fig.colorbar(image, cax=cax, orientation="horizontal", ticks=edges)
    bar.ax.set_xticklabels([f"1e{e}" if e else "1" for e in edges])
    bar.set_label("largest error / tolerance (above 1: the check fails; blank: not checked)")
    return save(fig, path, dpi=100)


def _summary_columns(results: list[CaseResult]) -> tuple[list[str], list[tuple[str, int]]]:
    """The checked quantities in :data:`QUANTITY_GROUPS` order, and (group, columns) pairs."""
    checked = {v.quantity for r in results for v in r.verdicts}
    known = {q for members in QUANTITY_GROUPS.values() for q in members}
    columns, groups = [], []
    grouped = {**QUANTITY_GROUPS, "other": tuple(sorted(checked - known))}
    for name, members in grouped.items():
        present = [q for q in members if q in checked]
        if present:
            columns += present
            groups.append((name, len(present)))
    return columns, groups


def _ratio_text(ratio: float) -> str:
    """A ratio in one or two significant digits: ``3e-04``, ``0.31``, ``1.2``."""
    if ratio == 0.0:
        return "0"
    return f"{ratio:.2g}" if ratio >= 0.01 else f"{ratio:.0e}"


def _case_label(result: CaseResult) -> str:
    return f"{result.case.name}  {'PASS' if result.passed else 'FAIL'}"


def save(fig, path: Path, dpi: int) -> Path:
    """Write a figure (folders made as needed) and close it; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    log.info("wrote %s", path)
    return path


def refinement_chart(points, path: Path) -> Path:
    """Errors against k for every body and series, log-log, with slopes 1 and 2."""
    bodies = sorted({p.body for p in points})
    fig, axes = plt.subplots(len(bodies), 2, figsize=(12, 4.8 * len(bodies)), squeeze=False)
    for row, body in enumerate(bodies):
        for col, quantity in enumerate(("displacement", "stress")):
            ax = axes[row, col]
            names = sorted({p.series for p in points if p.body == body})
            for series in sorted(names, key=lambda n: n.startswith("P1")):  # P1 drawn on top
                run = sorted(
                    (p for p in points if (p.body, p.series) == (body, series)), key=lambda p: p.k
                )
                style = {"linestyle": "--", "color": "black", "linewidth": 1}
                style = style if series.startswith("P1") else {"marker": "o"}
                ax.loglog(
                    [p.k for p in run], [getattr(p, quantity) for p in run], **style, label=series
                )
            ks = np.array(sorted({p.k for p in points}), dtype=float)
            for order in (1, 2):
                ax.loglog(ks, 0.5 * (ks / ks[0]) ** -order, ":", color="grey", linewidth=1)
                ax.annotate(
                    f"order {order}", (ks[-1], 0.5 * (ks[-1] / ks[0]) ** -order), fontsize=8
                )
            ax.set_xticks(ks, [f"{k:g}" for k in ks])
            ax.xaxis.set_minor_locator(NullLocator())  # the y axis keeps its minor labels:
            # errors within a decade had no tick label but one 10^x
            ax.set_xlabel("k (blocks per metre each way)")
            ax.set_ylabel(f"relative L² {quantity} error")
            ax.set_title(f"{body}: {quantity} against the continuum", fontsize=10)
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=8)
    fig.suptitle("Block refinement: DDA blocks with locked joints against the FEM continuum")
    fig.tight_layout()
    return save(fig, path, dpi=100)


def _finish(fig, axes, title: str, path, keep_x_label=None):
    """Time on the x axes (but ``keep_x_label``'s), legends, grids and the title; saved."""
    for ax in axes.ravel():
        if ax is not keep_x_label:
            ax.set_xlabel("time (s)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return save(fig, path, dpi=90)
