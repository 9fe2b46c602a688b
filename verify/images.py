"""Pictures of a verification case (pyvista, off screen) and a summary chart (matplotlib).

One PNG per case, three panels on one colour scale where it applies:

1. the DDA blocks, deformed (displacements magnified), coloured by their
   constant stress component;
2. the FEM field of the same component (P1-discontinuous projection) on the
   deformed mesh, same magnification and colour scale;
3. the per-block difference of the block averages, FEM − DDA, over the
   case's stress scale, on the undeformed blocks.

Fixed blocks are drawn in grey. The colour range of panels 1-2 spans the DDA
values and the 1st-99th percentile of the FEM field, so that the stress
concentration under a point load does not wash the rest out.
"""

from __future__ import annotations

import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import logging  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from verify import fields  # noqa: E402
from verify.cases import CaseResult  # noqa: E402
from verify.compare import block_centroid  # noqa: E402

log = logging.getLogger(__name__)

FIXED_COLOUR = "#b0b0b0"
BACKGROUND = "white"


def polygons_to_polydata(polygons: list[np.ndarray]):
    """pyvista PolyData with one polygon cell per (k, 2) array."""
    import pyvista as pv

    points = np.vstack([np.column_stack([p, np.zeros(len(p))]) for p in polygons])
    faces, start = [], 0
    for p in polygons:
        faces.extend([len(p), *range(start, start + len(p))])
        start += len(p)
    return pv.PolyData(points, faces=np.array(faces))


def fem_polydata(result: CaseResult, component: int, magnification: float):
    """Triangles of the FEM mesh, deformed, with the projected stress at their corners."""
    import pyvista as pv

    fem = result.fem
    mesh = fem.block_mesh.mesh
    corners = mesh.t.T  # (M, 3)
    u = fields.nodal_displacement(fem)
    xy = mesh.p.T[corners] + magnification * u[corners]  # (M, 3, 2)
    points = np.concatenate([xy.reshape(-1, 2), np.zeros((xy.size // 2, 1))], axis=1)
    faces = np.column_stack([np.full(len(corners), 3), np.arange(3 * len(corners)).reshape(-1, 3)])
    grid = pv.PolyData(points, faces=faces.ravel())
    grid.point_data["stress"] = fields.stress_field(fem)[component].ravel()
    return grid


def fem_outlines(result: CaseResult, magnification: float):
    """Boundary edges of every meshed block, deformed (lines)."""
    import pyvista as pv

    fem = result.fem
    mesh = fem.block_mesh.mesh
    facets = mesh.facets[:, mesh.boundary_facets()].T  # (f, 2)
    xy = mesh.p.T + magnification * fields.nodal_displacement(fem)
    points = np.column_stack([xy, np.full(len(xy), 1e-6)])
    lines = np.column_stack([np.full(len(facets), 2), facets]).ravel()
    return pv.PolyData(points, lines=lines)


def dda_polygons(result: CaseResult, magnification: float) -> list[np.ndarray]:
    """DDA blocks in scene order, displacements magnified."""
    return [
        np.asarray(b.vertices) + magnification * du
        for b, du in zip(result.scene.blocks, result.dda.vertex_displacement, strict=True)
    ]


def auto_magnification(result: CaseResult, fraction: float = 0.06) -> float:
    """Factor that makes the largest displacement ``fraction`` of the model size."""
    from verify.geometry import scene_size

    largest = max(
        float(np.abs(fields.nodal_displacement(result.fem)).max()),
        max(float(np.abs(d).max()) for d in result.dda.vertex_displacement),
    )
    return fraction * scene_size(result.scene) / largest if largest > 0 else 1.0


def colour_range(result: CaseResult, component: int) -> tuple[float, float]:
    """Shared range of panels 1-2 (see the module notes)."""
    free = list(result.fem.block_mesh.blocks)
    field = fields.stress_field(result.fem)[component].ravel()
    low, high = np.percentile(field, [1, 99])
    dda = result.dda.stresses[free, component]
    low, high = min(low, dda.min()), max(high, dda.max())
    if high - low < 1e-12 * max(abs(low), abs(high), 1.0):
        pad = max(abs(high), 1.0) * 0.05
        low, high = low - pad, high + pad
    return float(low), float(high)


def _leave_room_for_the_bar(camera, fraction: float = 0.16) -> None:
    """Parallel view, zoomed out and moved so the scene sits above the colour bar."""
    camera.parallel_projection = True
    camera.parallel_scale *= 1.0 + fraction
    shift = fraction * camera.parallel_scale
    (fx, fy, fz), (px, py, pz) = camera.focal_point, camera.position
    camera.focal_point = (fx, fy - shift, fz)
    camera.position = (px, py - shift, pz)


def _add_fixed(plotter, result: CaseResult) -> None:
    fixed = [np.asarray(b.vertices) for b in result.scene.blocks if b.fixed]
    if fixed:
        plotter.add_mesh(polygons_to_polydata(fixed), color=FIXED_COLOUR, show_edges=True)


def case_image(
    result: CaseResult,
    path: Path,
    component: str | None = None,
    magnification: float | None = None,
    size: tuple[int, int] = (1800, 620),
) -> Path:
    """Write the three-panel picture of one case; returns the path."""
    import pyvista as pv

    name = component or result.expectation.component
    k = fields.COMPONENTS.index(name)
    mag = auto_magnification(result) if magnification is None else magnification
    clim = colour_range(result, k)
    free = list(result.fem.block_mesh.blocks)
    plotter = pv.Plotter(off_screen=True, shape=(1, 3), window_size=list(size), border=False)
    plotter.set_background(BACKGROUND)
    bar = {
        "n_labels": 3,
        "fmt": "%.3g",
        "color": "black",
        "title_font_size": 14,
        "label_font_size": 13,
        "position_x": 0.15,
        "position_y": 0.08,
        "width": 0.7,
        "height": 0.07,
    }

    plotter.subplot(0, 0)
    dda = polygons_to_polydata([dda_polygons(result, mag)[i] for i in free])
    dda.cell_data["stress"] = result.dda.stresses[free, k]
    plotter.add_mesh(
        dda,
        scalars="stress",
        clim=clim,
        cmap="viridis",
        show_edges=True,
        scalar_bar_args={**bar, "title": f"DDA {name} (Pa)"},
    )
    _add_fixed(plotter, result)
    plotter.add_text(f"DDA, x{mag:.3g}", font_size=10, color="black")
    plotter.view_xy()

    plotter.subplot(0, 1)
    plotter.add_mesh(
        fem_polydata(result, k, mag),
        scalars="stress",
        clim=clim,
        cmap="viridis",
        scalar_bar_args={**bar, "title": f"FEM {name} (Pa)"},
    )
    _add_fixed(plotter, result)
    plotter.add_text(
        f"FEM P{result.fem.basis.elem.elem.maxdeg}, x{mag:.3g}", font_size=10, color="black"
    )
    plotter.view_xy()

    plotter.subplot(0, 2)
    rows = {r.item: r for r in result.rows if r.quantity == "stress" and r.component == name}
    names = [result.scene.blocks[i].name for i in free]
    diff = np.array(
        [(rows[n].fem - rows[n].dda) / rows[n].scale if rows[n].scale else 0.0 for n in names]
    )
    span = max(float(np.abs(diff).max()), 1e-12)
    blocks = polygons_to_polydata([np.asarray(result.scene.blocks[i].vertices) for i in free])
    blocks.cell_data["difference"] = diff
    plotter.add_mesh(
        blocks,
        scalars="difference",
        clim=(-span, span),
        cmap="coolwarm",
        show_edges=True,
        scalar_bar_args={**bar, "title": f"difference / stress scale, {name}", "fmt": "%.1e"},
    )
    _add_fixed(plotter, result)
    centres = np.array([block_centroid(np.asarray(result.scene.blocks[i].vertices)) for i in free])
    plotter.add_point_labels(
        np.column_stack([centres, np.full(len(free), 1e-3)]),
        [f"{d:+.1e}" for d in diff],
        font_size=14,
        point_size=1,
        shape_opacity=0.6,
        always_visible=True,
    )
    plotter.add_text("FEM - DDA, block averages", font_size=10, color="black")
    plotter.view_xy()

    for actor in plotter.scalar_bars.values():
        actor.SetTextPositionToPrecedeScalarBar()  # labels under the bar, title above
    for index in range(3):
        plotter.subplot(0, index)
        _leave_room_for_the_bar(plotter.camera)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(path))
    plotter.close()
    log.info("wrote %s", path)
    return path


def summary_chart(results: list[CaseResult], path: Path) -> Path:
    """Bar chart of the largest error per case and checked quantity, with tolerances."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quantities = sorted({v.quantity for r in results for v in r.verdicts})
    width = 0.8 / max(len(quantities), 1)
    fig, ax = plt.subplots(figsize=(max(6, 1.6 * len(results)), 4.5))
    x = np.arange(len(results))
    for j, quantity in enumerate(quantities):
        errors, tolerances = [], []
        for r in results:
            verdict = {v.quantity: v for v in r.verdicts}.get(quantity)
            errors.append(max(verdict.error, 1e-16) if verdict else np.nan)
            tolerances.append(verdict.tolerance if verdict else np.nan)
        offset = x - 0.4 + width * (j + 0.5)
        ax.bar(offset, errors, width, label=quantity)
        ax.plot(offset, tolerances, "k_", markersize=12)
    ax.set_yscale("log")
    ax.set_xticks(x, [r.case.name for r in results], rotation=20, ha="right")
    ax.set_ylabel("largest error / scale (black: tolerance)")
    ax.set_title("DDA against FEM")
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
