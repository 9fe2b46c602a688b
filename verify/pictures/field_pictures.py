"""The field picture of a static or fracture case, rendered off screen with pyvista.

One pyvista ``Plotter`` of three rows: a header with the case's verdict and
the legend, then two rows of three panels. Top, the stress component the case
names (in its frame): the DDA blocks coloured by their one constant stress on
their deformed shape (displacements magnified), the FEM field on its deformed
mesh (same magnification, same colour scale), and each block's signed
difference (DDA − FEM − predicted offset) over the stress scale. Bottom, the
displacement magnitude on the undeformed shape (the DDA block's affine field,
the FEM's nodal field), and the signed difference of the case's checked
displacement quantity (centroid, else strain).

Difference panels have a fixed scale of ± the check's tolerance (the colour
bar's ends, the tolerance in its title; beyond them the colour saturates) and
print every block's value. Fixed blocks are dark grey and hatched, blocks a
check leaves out light grey and dotted, so that a difference near zero (white)
is never mistaken for either. Every panel has x and y axes in the scene's
length unit (its length scale) and a colour bar with quantity and unit.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from verify.comparison.compare import STRESS, tensor_in_frame
from verify.fem import fields
from verify.fem.geometry import scene_size
from verify.harness.cases import CaseResult
from verify.pictures.field_layout import (
    HEADER,
    Layout,
    axes,
    colour_bar,
    fit_camera,
    layout,
    round_ticks,
)
from verify.pictures.field_meshes import (
    ROUND_OFF,
    block_polygons,
    dda_displacement_at,
    dots,
    fem_mesh,
    fem_nodes,
    fixed_polygons,
    free_blocks,
    hatching,
    label_point,
    magnification,
    moved_blocks,
    on_plane,
    outlines,
    pyvista,
    triangles,
)

log = logging.getLogger(__name__)

FIXED = "#4d4d4d"  # fixed blocks: dark grey, hatched in HATCH
HATCH = "#a6a6a6"
UNCHECKED = "#d9d9d9"  # blocks a check leaves out: light grey, dotted in DOT
DOT = "#666666"
DIFFERENCE_MAP = "RdBu_r"  # white at zero: neither the dark fixed blocks nor the dotted grey
STRESS_MAP = "viridis"
DISPLACEMENT_MAP = "magma_r"
MOST_LABELS = 24  # difference panels print each block's value up to this many blocks


def state_picture(result: CaseResult, title: str, path: Path) -> Path:
    """Render the two rows of three panels of a static or fracture case to ``path`` (PNG)."""
    frame = layout(result)
    plotter = pyvista.Plotter(
        off_screen=True, shape=(3, 3), groups=[(0, np.s_[:])],
        row_weights=[HEADER, frame.panel[1], frame.panel[1]],
        window_size=list(frame.window), border=False, theme=pyvista.themes.DocumentTheme(),
    )  # fmt: skip
    try:
        header(plotter, title, frame.window[0], bool(fixed_polygons(result)))
        mag = magnification(result)
        stress_panels(plotter, result, frame, mag)
        displacement_panels(plotter, result, frame)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        plotter.screenshot(str(path))
    finally:
        plotter.close()
    log.info("wrote %s", path)
    return path


def header(plotter, title: str, width: int, has_fixed: bool) -> None:
    """The case's verdict (left) and what the grey blocks are (right), drawn as they are below."""
    plotter.subplot(0, 0)
    lines = title.count("\n")
    if lines < 2:
        plotter.add_text(title, position=(12, HEADER // 2 - 10 - 11 * lines), font_size=14)
    else:  # three lines or more (a fracture case's onsets): smaller, from the bottom up
        plotter.add_text(title, position=(12, 4), font_size=11)
    swatch = np.array([[0.0, 0.0], [40.0, 0.0], [40.0, 22.0], [0.0, 22.0]])
    left = width - 240
    if has_fixed:
        draw_hatched(plotter, [swatch + (left, HEADER / 2 + 5)], spacing=7.0, z=1.0)
        plotter.add_text("fixed block", position=(left + 52, HEADER / 2 + 7), font_size=12)
    draw_dotted(plotter, [swatch + (left, HEADER / 2 - 29)], spacing=6.0, z=1.0)
    plotter.add_text("not checked", position=(left + 52, HEADER / 2 - 27), font_size=12)
    centre = (width / 2, HEADER / 2)
    plotter.camera_position = [(*centre, 100.0), (*centre, 0.0), (0.0, 1.0, 0.0)]
    plotter.enable_parallel_projection()
    plotter.camera.parallel_scale = HEADER / 2


def stress_panels(plotter, result: CaseResult, frame: Layout, mag: float) -> None:
    """Top row: the named stress component, DDA and FEM on the deformed shapes, difference."""
    name = result.expectation.component
    k = STRESS.index(name)
    angle = result.expectation.frame
    fem_values = tensor_in_frame(np.moveaxis(fields.stress_field(result.fem), 0, -1), angle)
    fem_values = fem_values[..., k]
    dda_values = tensor_in_frame(result.dda.stresses[free_blocks(result)], angle)[:, k]
    clim = stress_range(fem_values, dda_values)
    label = f"{name}{chr(39) if angle else ''}"
    unit = f"{label} ({result.scene.units.stress})"
    moved = moved_blocks(result, mag)
    deformed = f"displacements x{mag:.3g}" if mag != 1.0 else "displacements as computed"
    plotter.subplot(1, 0)
    dda = triangles(moved, cell_values=dda_values)
    field(plotter, frame, dda, STRESS_MAP, clim, f"DDA {unit}")
    draw_outlines(plotter, result, moved)
    finish(plotter, result, frame, f"DDA {unit}, {deformed}")
    plotter.subplot(1, 1)
    field(plotter, frame, fem_mesh(result, mag, fem_values), STRESS_MAP, clim, f"FEM {unit}")
    draw_outlines(plotter, result, fem_outline(result, mag))
    finish(plotter, result, frame, f"FEM {unit}, {deformed}")
    plotter.subplot(1, 2)
    difference_panel(plotter, frame, result, "stress", name)
    finish(plotter, result, frame, f"difference, stress {label}")


# a stress colour range spans at least this fraction of its largest value: fields that
# differ by less (a uniform field, and its FEM twin within round-off) take nearly one colour
NARROWEST = 0.1


def stress_range(fem_values: np.ndarray, dda_values: np.ndarray) -> tuple[float, float]:
    """The shared colour range: the FEM's 1st to 99th percentile, widened to the DDA's
    values, and about its middle to :data:`NARROWEST` of its largest value.

    The percentiles keep a point load's singular stress from washing the rest out.

    >>> stress_range(np.full(3, -1e6), np.full(2, -1.0004e6))
    (-1050220.0, -950180.0)
    """
    low, high = np.percentile(fem_values, [1, 99])
    low, high = min(low, dda_values.min()), max(high, dda_values.max())
    half = 0.5 * max(NARROWEST * max(abs(low), abs(high)), 2.0)
    middle = 0.5 * (low + high)
    low, high = min(low, middle - half), max(high, middle + half)
    return float(low), float(high)


def fem_outline(result: CaseResult, mag: float) -> Any:
    """The boundary edges of the FEM's deformed mesh (every block's outline)."""
    mesh = result.fem.block_mesh.mesh
    xy = mesh.p.T + mag * fields.nodal_displacement(result.fem)
    surface = pyvista.PolyData.from_regular_faces(on_plane(xy), mesh.t.T)
    edges = surface.extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False
    )
    edges.points[:, 2] = lift(result)
    return edges


def displacement_panels(plotter, result: CaseResult, frame: Layout) -> None:
    """Bottom row: |u| on the undeformed shape (DDA, FEM), the checked displacement difference."""
    free = free_blocks(result)
    polygons = block_polygons(result, free)
    fem_u = np.linalg.norm(fields.nodal_displacement(result.fem), axis=1)
    dda = triangles(
        polygons,
        values_at=lambda k, p: np.linalg.norm(dda_displacement_at(result, free[k], p), axis=1),
    )
    # the 99th percentile: a point load's singular displacement does not wash the rest out
    # ... and at least round-off's (ROUND_OFF of the model): 1e-20 m of noise reads as none
    high = max(float(np.percentile(fem_u, 99)), float(dda["value"].max()))
    high = max(high, ROUND_OFF * scene_size(result.scene))
    unit = f"displacement magnitude ({frame.length})"
    for column, who, mesh in ((0, "DDA", dda), (1, "FEM", fem_nodes(result, fem_u))):
        plotter.subplot(2, column)
        field(plotter, frame, mesh, DISPLACEMENT_MAP, (0.0, high), f"{who} {unit}")
        draw_outlines(plotter, result, polygons)
        finish(plotter, result, frame, f"{who} {unit}")
    quantity = "centroid" if "centroid" in result.expectation.checks else "strain"
    plotter.subplot(2, 2)
    difference_panel(plotter, frame, result, quantity, None)
    finish(plotter, result, frame, f"difference, {quantity} (worst component)")


def field(plotter, frame: Layout, mesh, cmap: str, clim: tuple[float, float], title: str) -> None:
    """A mesh coloured by its ``"value"`` array, with a colour bar of nice round ticks."""
    actor = plotter.add_mesh(
        mesh, scalars="value", cmap=cmap, clim=clim, lighting=False,
        interpolate_before_map=True, show_scalar_bar=False,
    )  # fmt: skip
    ticks, fmt = round_ticks(clim)
    colour_bar(plotter, frame, actor, title, ticks, fmt)


def difference_panel(
    plotter, frame: Layout, result: CaseResult, quantity: str, component: str | None
) -> None:
    """Blocks coloured by their signed difference on a fixed ± tolerance scale."""
    differences = block_differences(result, quantity, component)
    check = next((c for _, c in differences.values() if c is not None), None)
    tolerance = check.tolerance if check else 1.0
    free = free_blocks(result)
    names = [result.scene.blocks[i].name for i in free]
    values = [differences.get(n, (None, None))[0] for n in names]
    polygons = block_polygons(result, free)
    checked = [k for k, v in enumerate(values) if v is not None]
    unchecked = [polygons[k] for k, v in enumerate(values) if v is None]
    if checked:
        mesh = triangles([polygons[k] for k in checked], cell_values=[values[k] for k in checked])
        actor = plotter.add_mesh(
            mesh, scalars="value", cmap=DIFFERENCE_MAP, clim=(-tolerance, tolerance),
            lighting=False, show_scalar_bar=False,
        )  # fmt: skip
        title = f"(DDA - FEM - predicted) / scale, tolerance {tolerance:.2g}"
        ticks = np.array([-tolerance, 0.0, tolerance])
        colour_bar(plotter, frame, actor, title, ticks, "%.2g")
    else:
        caption = plotter.add_text(
            f"no block checked ({quantity})", position=(0.5, 0.03), viewport=True, font_size=11
        )
        caption.GetTextProperty().SetJustificationToCentered()
    if unchecked:
        draw_dotted(plotter, unchecked, 0.03 * scene_size(result.scene), lift(result))
    draw_outlines(plotter, result, polygons)
    if checked and len(free) <= MOST_LABELS:
        points = np.array([label_point(polygons[k]) for k in checked])
        plotter.add_point_labels(
            on_plane(points, 3 * lift(result)), [f"{values[k]:+.1e}" for k in checked],
            font_size=15, bold=False, shape=None, show_points=False, always_visible=True,
            justification_horizontal="center", justification_vertical="center",
        )  # fmt: skip


def block_differences(result: CaseResult, quantity: str, component: str | None) -> dict:
    """Signed difference per block name of one quantity (worst component when None).

    A block none of whose rows a check applies to maps to ``(None, check)``.
    """
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


def lift(result: CaseResult) -> float:
    """Height above the blocks at which lines are drawn (so that they stay on top)."""
    return 1e-3 * scene_size(result.scene)


def draw_outlines(plotter, result: CaseResult, polygons_or_edges) -> None:
    """Black block outlines (polygons, or a line dataset already made)."""
    if isinstance(polygons_or_edges, list):
        polygons_or_edges = outlines(polygons_or_edges, lift(result))
    plotter.add_mesh(polygons_or_edges, color="black", line_width=2.0, lighting=False)


def draw_fixed(plotter, result: CaseResult) -> None:
    """The fixed blocks: dark grey, hatched."""
    polygons = fixed_polygons(result)
    if polygons:
        draw_hatched(plotter, polygons, 0.04 * scene_size(result.scene), lift(result))


def draw_hatched(plotter, polygons: list[np.ndarray], spacing: float, z: float) -> None:
    """Polygons dark grey, hatched ``spacing`` apart and outlined (the look of a fixed block)."""
    lines = hatching(polygons, spacing, 2 * z)
    draw_marked(plotter, polygons, FIXED, lines, z, color=HATCH, line_width=1.0)


def draw_dotted(plotter, polygons: list[np.ndarray], spacing: float, z: float) -> None:
    """Polygons light grey, dotted ``spacing`` apart and outlined (a block not checked)."""
    points = dots(polygons, spacing, 2 * z)
    draw_marked(plotter, polygons, UNCHECKED, points, z, color=DOT, point_size=2.5)


def draw_marked(plotter, polygons: list[np.ndarray], fill: str, marks, z: float, **style) -> None:
    """Polygons filled with ``fill``, ``marks`` (lines or points, or None) drawn on them."""
    plotter.add_mesh(triangles(polygons), color=fill, lighting=False)
    if marks is not None:
        plotter.add_mesh(marks, lighting=False, **style)
    plotter.add_mesh(outlines(polygons, z), color="black", line_width=2.0, lighting=False)


def finish(plotter, result: CaseResult, frame: Layout, title: str) -> None:
    """Fixed blocks, the panel's title, x and y axes in the length unit, the camera."""
    draw_fixed(plotter, result)
    plotter.add_text(title, position="upper_edge", font_size=11)
    axes(plotter, frame)
    fit_camera(plotter, frame)
