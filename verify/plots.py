"""Curves of the verification, drawn with matplotlib (off screen, Agg).

The histories of a dynamic case (centroid displacement and rotation of both
models, their signed differences against the tolerance band), the summary bar
chart (every case's largest error over its tolerance, per checked quantity)
and the block-refinement convergence plot (errors against k, log-log, with
slopes 1 and 2). The field pictures of static cases are pyvista's
(:mod:`verify.field_pictures`).
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from verify.cases import CaseResult  # noqa: E402

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


def summary_chart(results: list[CaseResult], path: Path) -> Path:
    """Largest error over its tolerance, per case and checked quantity (1: the limit)."""
    quantities = sorted({v.quantity for r in results for v in r.verdicts})
    width = 0.8 / max(len(quantities), 1)
    fig, ax = plt.subplots(figsize=(max(7, 1.1 * len(results)), 5))
    x = np.arange(len(results))
    for j, quantity in enumerate(quantities):
        ratios = []
        for r in results:
            verdict = {v.quantity: v for v in r.verdicts}.get(quantity)
            ratios.append(max(verdict.error / verdict.tolerance, 1e-8) if verdict else np.nan)
        ax.bar(x - 0.4 + width * (j + 0.5), ratios, width, label=quantity)
    ax.axhline(1.0, color="black", linewidth=1)
    ax.set_yscale("log")
    ax.set_xticks(x, [r.case.name for r in results], rotation=30, ha="right")
    ax.set_ylabel("largest error / tolerance (1: the limit)")
    ax.set_title("DDA against FEM or a closed form: every check, every case")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return save(fig, path, dpi=100)


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
            ax.minorticks_off()
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
