"""Pictures of the verification (matplotlib, off screen): cases, summary, block refinement.

A static or fracture case: two rows of three panels. Top, the stress
component the case names (in its frame, Pa): the DDA blocks on their deformed
shape (displacements magnified), the FEM field on the deformed mesh (same
magnification and colour scale), and each block's signed difference
(DDA − FEM − predicted offset) over the stress scale. Bottom, the same for
the displacement magnitude on the undeformed shape (m), the difference panel
showing the case's checked displacement quantity (centroid, else strain).
Difference panels use a fixed scale of ± the check's tolerance (the colour
bar's ends; beyond them the colour saturates) and print every block's value;
fixed blocks are dark grey and hatched, blocks a check leaves out light grey
and dotted, so that a difference near zero (white) is never mistaken for
either. Axes are in metres: they are the length scale.

A dynamic case: the centroid displacement and rotation histories of both
models, and their signed differences against the tolerance band.
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import FuncFormatter, MaxNLocator  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

from verify import fields  # noqa: E402
from verify.cases import CaseResult  # noqa: E402
from verify.compare import STRESS, tensor_in_frame  # noqa: E402
from verify.geometry import polygon_centroid, scene_size  # noqa: E402

log = logging.getLogger(__name__)

FIXED = {"facecolor": "#4d4d4d", "hatch": "///", "edgecolor": "#222222"}
UNCHECKED = {"facecolor": "#d9d9d9", "hatch": "..", "edgecolor": "#777777"}
DIFFERENCE_MAP = "RdBu_r"  # white at zero: neither the dark fixed blocks nor the dotted grey
FIELD_MAP = "viridis"


def magnification(result: CaseResult, fraction: float = 0.06) -> float:
    """Factor that makes the largest displacement ``fraction`` of the model size."""
    largest = max(
        float(np.abs(fields.nodal_displacement(result.fem)).max()),
        max(float(np.abs(d).max()) for d in result.dda.vertex_displacement),
    )
    return fraction * scene_size(result.scene) / largest if largest > 0 else 1.0


def free_blocks(result: CaseResult) -> list[int]:
    """Scene indices of the meshed (free) blocks."""
    return list(result.fem.block_mesh.blocks)


def add_fixed(ax, result: CaseResult) -> None:
    """The fixed blocks, dark and hatched."""
    fixed = [np.asarray(b.vertices) for b in result.scene.blocks if b.fixed]
    if fixed:
        ax.add_collection(PolyCollection(fixed, **FIXED, linewidth=0.5))


def fem_triangles(result: CaseResult, mag: float) -> Triangulation:
    """The FEM's triangles, corners duplicated (a field discontinuous between elements)."""
    mesh = result.fem.block_mesh.mesh
    corners = mesh.t.T
    xy = mesh.p.T[corners] + mag * fields.nodal_displacement(result.fem)[corners]
    xy = xy.reshape(-1, 2)
    return Triangulation(xy[:, 0], xy[:, 1], np.arange(len(xy)).reshape(-1, 3))


def dda_triangles(result: CaseResult, values_at) -> tuple[Triangulation, np.ndarray]:
    """Each free DDA block triangulated, with ``values_at(block, points)`` at the corners."""
    points, triangles, values = [], [], []
    for i in free_blocks(result):
        polygon = np.asarray(result.scene.blocks[i].vertices, dtype=float)
        for tri in shapely.constrained_delaunay_triangles(shapely.Polygon(polygon)).geoms:
            corners = shapely.get_coordinates(tri)[:3]
            triangles.append(np.arange(3) + len(points) * 3)
            points.append(corners)
            values.append(values_at(i, corners))
    xy = np.concatenate(points)
    return Triangulation(xy[:, 0], xy[:, 1], np.array(triangles)), np.concatenate(values)


def dda_displacement_at(result: CaseResult, block: int, points: np.ndarray) -> np.ndarray:
    """The DDA block's affine displacement at ``points`` (fitted to its vertices)."""
    x0 = np.asarray(result.scene.blocks[block].vertices, dtype=float)
    design = np.column_stack([np.ones(len(x0)), x0])
    coefficients = np.linalg.lstsq(design, result.dda.vertex_displacement[block], rcond=None)[0]
    return np.column_stack([np.ones(len(points)), points]) @ coefficients


def block_differences(result: CaseResult, quantity: str, component: str | None) -> dict:
    """Signed difference per block name of one quantity (worst component when None)."""
    check = result.expectation.checks.get(quantity)
    out = {}
    for row in result.rows:
        if row.quantity != quantity or (component and row.component != component):
            continue
        name = row.item.split("[")[0]
        applies = check is not None and check.applies_to(row.item, row.component)
        current = out.get(name)
        if current is None or (applies and abs(row.signed_error) > abs(current[0] or 0)):
            out[name] = (row.signed_error if applies else None, check)
    return out


def difference_panel(ax, fig, result: CaseResult, quantity: str, component: str | None, title):
    """Blocks coloured by their signed difference on a fixed ± tolerance scale."""
    differences = block_differences(result, quantity, component)
    check = next((c for _, c in differences.values() if c is not None), None)
    tolerance = check.tolerance if check else 1.0
    names = [b.name for b in result.scene.blocks]
    checked, values, unchecked = [], [], []
    for i in free_blocks(result):
        polygon = np.asarray(result.scene.blocks[i].vertices)
        value = differences.get(names[i], (None, None))[0]
        (unchecked if value is None else checked).append(polygon)
        if value is not None:
            values.append(value)
            if len(free_blocks(result)) <= 24:
                x, y = polygon_centroid(polygon)
                ax.text(x, y, f"{value:+.1e}", ha="center", va="center", fontsize=7)
    cells = PolyCollection(checked, cmap=DIFFERENCE_MAP, edgecolor="black", linewidth=0.5)
    cells.set_array(np.array(values))
    cells.set_clim(-tolerance, tolerance)
    ax.add_collection(cells)
    if unchecked:
        ax.add_collection(PolyCollection(unchecked, **UNCHECKED, linewidth=0.5))
    add_fixed(ax, result)
    bar = fig.colorbar(cells, ax=ax, orientation="horizontal", pad=0.12, shrink=0.9)
    bar.set_ticks([-tolerance, 0.0, tolerance])
    bar.set_ticklabels([f"−tol {tolerance:.0e}", "0", f"+tol {tolerance:.0e}"])
    bar.set_label("(DDA − FEM − predicted) / scale")
    ax.set_title(title, fontsize=10)


def field_panels(axes, fig, result: CaseResult, mag: float) -> None:
    """Top row: stress component (DDA, FEM, difference)."""
    name = result.expectation.component
    k = STRESS.index(name)
    frame = result.expectation.frame
    free = free_blocks(result)
    fem_values = tensor_in_frame(np.moveaxis(fields.stress_field(result.fem), 0, -1), frame)
    fem_values = fem_values[..., k].ravel()
    dda_values = tensor_in_frame(result.dda.stresses[free], frame)[:, k]
    low, high = np.percentile(fem_values, [1, 99])
    low, high = min(low, dda_values.min()), max(high, dda_values.max())
    if high - low < 1e-12 * max(abs(low), abs(high), 1.0):
        low, high = low - 1.0, high + 1.0
    moved = [
        np.asarray(result.scene.blocks[i].vertices) + mag * result.dda.vertex_displacement[i]
        for i in free
    ]
    blocks = PolyCollection(moved, cmap=FIELD_MAP, edgecolor="black", linewidth=0.5)
    blocks.set_array(dda_values)
    blocks.set_clim(low, high)
    axes[0].add_collection(blocks)
    image = axes[1].tripcolor(
        fem_triangles(result, mag),
        fem_values,
        shading="gouraud",
        cmap=FIELD_MAP,
        vmin=low,
        vmax=high,
    )
    unit = f"{name}{chr(39) if frame else ''} (Pa)"
    for ax, mappable, who in ((axes[0], blocks, "DDA"), (axes[1], image, "FEM")):
        add_fixed(ax, result)
        fig.colorbar(mappable, ax=ax, orientation="horizontal", pad=0.12, shrink=0.9).set_label(
            unit
        )
        ax.set_title(f"{who} {unit}, displacements x{mag:.3g}", fontsize=10)
    difference_panel(axes[2], fig, result, "stress", name, f"difference, stress {unit[:-5]}")


def displacement_panels(axes, fig, result: CaseResult) -> None:
    """Bottom row: displacement magnitude (DDA, FEM) and the checked displacement difference."""
    mesh = result.fem.block_mesh.mesh
    fem_u = np.linalg.norm(fields.nodal_displacement(result.fem), axis=1)
    triangulation, dda_u = dda_triangles(
        result, lambda i, p: np.linalg.norm(dda_displacement_at(result, i, p), axis=1)
    )
    # the 99th percentile: a point load's singular displacement does not wash the rest out
    low, high = 0.0, max(float(np.percentile(fem_u, 99)), float(dda_u.max()), 1e-30)
    panels = (
        (axes[0], triangulation, dda_u, "DDA"),
        (axes[1], Triangulation(mesh.p[0], mesh.p[1], mesh.t.T), fem_u, "FEM"),
    )
    for ax, tri, values, who in panels:
        image = ax.tripcolor(tri, values, shading="gouraud", cmap="magma_r", vmin=low, vmax=high)
        add_fixed(ax, result)
        bar = fig.colorbar(image, ax=ax, orientation="horizontal", pad=0.12, shrink=0.9)
        bar.set_label("|u| (m)")
        bar.ax.xaxis.set_major_locator(MaxNLocator(4))
        bar.ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.2g}"))
        ax.set_title(f"{who} displacement |u| (m)", fontsize=10)
    checks = result.expectation.checks
    quantity = "centroid" if "centroid" in checks else "strain"
    difference_panel(
        axes[2], fig, result, quantity, None, f"difference, {quantity} (worst component)"
    )


def finish_axes(axes, result: CaseResult) -> None:
    """Equal aspect, metres, the whole scene in view."""
    points = np.concatenate([np.asarray(b.vertices) for b in result.scene.blocks])
    pad = 0.05 * scene_size(result.scene)
    for ax in np.ravel(axes):
        ax.set_xlim(points[:, 0].min() - pad, points[:, 0].max() + pad)
        ax.set_ylim(points[:, 1].min() - pad, points[:, 1].max() + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.tick_params(labelsize=8)


def state_figure(result: CaseResult):
    """The two rows of three panels of a static or fracture case."""
    fig, axes = plt.subplots(2, 3, figsize=(16, 10.5))
    field_panels(axes[0], fig, result, magnification(result))
    displacement_panels(axes[1], fig, result)
    finish_axes(axes, result)
    handles = [
        Patch(**FIXED, label="fixed block"),
        Patch(**UNCHECKED, label="not checked"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=9)
    return fig


def history_figure(result: CaseResult):
    """Histories of a dynamic case and their signed differences."""
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
    for ax in axes.ravel():
        ax.set_xlabel("time (s)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return fig


def case_image(result: CaseResult, path: Path) -> Path:
    """Write the picture of one case; returns the path."""
    kind = result.expectation.kind
    fig = history_figure(result) if kind == "dynamic" else state_figure(result)
    title = f"{result.case.name}: {'PASS' if result.passed else 'FAIL'}"
    if kind == "fracture":
        onset, broke = result.series["onset"], result.series["broke"]
        title += ", onset factor " + ", ".join(
            f"{n}: FEM {f:.4g}, DDA broke at {broke.get(n, float('nan')):.4g}"
            for n, f in onset.items()
        )
        title += f" (state before the break, factor {result.series['factor_before']:.4g})"
    if result.expectation.frame:
        title += f"; components along a frame at {result.expectation.frame:g}°"
    fig.suptitle(title, fontsize=12)
    fig.tight_layout(rect=(0, 0.03, 1, 0.97))
    return save(fig, path, dpi=90)


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
    ax.set_title("DDA against FEM: every check, every case")
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
