"""The frame of a field picture's panels: sizes, round axes, camera and colour bars.

Every panel of a case shares one view: axes from round numbers around the
scene, one tick step for x and y (equal scales), a parallel projection down
-z that puts the axes' box a fixed number of pixels from the panel's edges
(room for the panel's title above, the colour bar below), and a panel height
that follows the scene's shape within limits. Axes are pyvista rulers (VTK's
2-D axis actor), ticked in the scene's length unit; colour bars are
horizontal, labelled at given values, with their title above them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.ticker import MaxNLocator

from verify.harness.cases import CaseResult
from verify.pictures.field_meshes import pyvista, scene_bounds

HEADER = 84  # pixels of the header row (verdict and legend)
PANEL_WIDTH = 560  # pixels of one panel's width
# pixels around the axes' box in a panel: left (y labels), bottom (colour bar, its title,
# x labels and title), right, top (the panel's title, the y axis's title)
MARGINS = (70, 142, 25, 58)
BAR = (12, 42)  # pixels: the colour bar's bottom and height (its labels included)


@dataclass(frozen=True)
class Layout:
    """Sizes of the picture and the view every panel shares."""

    panel: tuple[int, int]  # pixels: width, height of one panel
    bounds: tuple[np.ndarray, np.ndarray]  # the axes' ends (round numbers around the scene)
    ticks: tuple[int, int]  # number of labels on the x and y axes
    length: str  # the scene's length unit

    @property
    def window(self) -> tuple[int, int]:
        """Pixels of the whole picture."""
        return 3 * self.panel[0], HEADER + 2 * self.panel[1]

    @property
    def box(self) -> np.ndarray:
        """Pixels: width and height of the axes' box."""
        return np.array(self.panel) - np.array(MARGINS[:2]) - np.array(MARGINS[2:])

    @property
    def pixel(self) -> float:
        """One pixel in scene units: the axes' box fits in its place (equal scales)."""
        extent = self.bounds[1] - self.bounds[0]
        return float(max(extent / self.box))

    @property
    def scale(self) -> float:
        """Half the panel's height in scene units."""
        return 0.5 * self.panel[1] * self.pixel

    @property
    def focus(self) -> np.ndarray:
        """The point at the panel's centre: the axes' box centred in its place."""
        box_centre = np.array(MARGINS[:2]) + 0.5 * self.box
        return (
            0.5 * (self.bounds[0] + self.bounds[1])
            + (0.5 * np.array(self.panel) - box_centre) * self.pixel
        )


def layout(result: CaseResult) -> Layout:
    """Axes around the scene and a panel height from its shape (within limits)."""
    bounds, ticks = axis_range(*scene_bounds(result, pad=0.01))
    width, height = bounds[1] - bounds[0]
    box_width = PANEL_WIDTH - MARGINS[0] - MARGINS[2]
    box_height = float(np.clip(box_width * height / width, 0.55 * box_width, 1.3 * box_width))
    panel_height = int(round(box_height)) + MARGINS[1] + MARGINS[3]
    return Layout((PANEL_WIDTH, panel_height), bounds, ticks, result.scene.units.length)


def axis_range(low: np.ndarray, high: np.ndarray) -> tuple[tuple, tuple[int, int]]:
    """Round axis ends around [low, high], one tick step for both axes, and the tick counts."""
    ticks = MaxNLocator(10, steps=[1, 2, 2.5, 5, 10]).tick_values(0.0, float((high - low).max()))
    step = ticks[1] - ticks[0]
    first, last = np.floor(low / step) * step, np.ceil(high / step) * step
    counts = np.rint((last - first) / step).astype(int) + 1
    return (first, last), (int(counts[0]), int(counts[1]))


BAR_CHARACTERS = 36  # the labels a colour bar holds without running into each other


def round_ticks(clim: tuple[float, float]) -> tuple[np.ndarray, str]:
    """Up to 6 round values within a colour range, and a printf format with the
    significant digits that print each as it is (a narrow range about a large value:
    -1.0002e+06 and -1.0001e+06, not -1e+06 twice). Where the labels are long, fewer
    ticks (at least 3), so that they do not run into each other.

    >>> round_ticks((-1.0003e6, -0.9999e6))
    (array([-1000300., -1000150., -1000000.]), '%.6g')
    >>> round_ticks((0.0, 100.0))[1]
    '%.3g'
    """
    candidates = [_ticks(clim, count) for count in (5, 4, 3)]
    enough = [c for c in candidates if len(c[0]) >= 3] or candidates[:1]
    for ticks, digits in enough:
        if _label_characters(ticks, digits) <= BAR_CHARACTERS:
            return ticks, f"%.{digits}g"
    ticks, digits = min(enough, key=lambda c: _label_characters(*c))
    return ticks, f"%.{digits}g"


def _label_characters(ticks: np.ndarray, digits: int) -> int:
    """How many characters the labels of ``ticks`` take, printed with ``digits``."""
    return sum(len(f"{t:.{digits}g}") for t in ticks)


def _ticks(clim: tuple[float, float], count: int) -> tuple[np.ndarray, int]:
    """MaxNLocator's round ticks within ``clim`` and the significant digits they need."""
    ticks = MaxNLocator(count).tick_values(*clim)
    span = clim[1] - clim[0]
    ticks = ticks[(ticks >= clim[0] - 1e-9 * span) & (ticks <= clim[1] + 1e-9 * span)]
    largest = float(np.abs(ticks).max(initial=0.0))
    if len(ticks) < 2 or largest == 0.0:
        return ticks, 3
    digits = max(_exact_digits(t) for t in ticks)
    if 1e-3 <= largest < 1e5:  # as many as keep %g from an exponent (100, not 1e+02)
        digits = max(digits, int(np.floor(np.log10(largest))) + 1)
    return ticks, max(2, digits)


def _exact_digits(value: float) -> int:
    """The fewest significant digits (at most 12) that print ``value`` as it is."""
    for digits in range(1, 13):
        if abs(float(f"{value:.{digits}g}") - value) <= 1e-12 * abs(value):
            return digits
    return 12


def colour_bar(plotter, frame: Layout, actor, title: str, ticks: np.ndarray, fmt: str) -> None:
    """A horizontal colour bar under the panel, labels at ``ticks`` below it, title above."""
    height = frame.panel[1]
    bar = plotter.add_scalar_bar(
        "", mapper=actor.mapper, vertical=False, position_x=0.12, position_y=BAR[0] / height,
        width=0.76, height=BAR[1] / height, label_font_size=16, fmt=fmt, unique_bar=True,
        color="black",
    )  # fmt: skip
    bar.SetUseCustomLabels(True)
    bar.SetCustomLabels(pyvista.convert_array(np.asarray(ticks, dtype=float)))
    bar.SetTextPositionToPrecedeScalarBar()  # the labels below the bar
    top = (BAR[0] + BAR[1] + 4) / height
    caption = plotter.add_text(title, position=(0.5, top), viewport=True, font_size=11)
    caption.GetTextProperty().SetJustificationToCentered()


def axes(plotter, frame: Layout) -> None:
    """x and y axes along the bottom and left of the view, ticked in the scene's length unit."""
    low, high = frame.bounds
    (x0, y0), (x1, y1) = low, high
    x_axis = plotter.add_ruler(
        (x0, y0, 0.0), (x1, y0, 0.0), number_labels=frame.ticks[0], title=f"x ({frame.length})",
        label_format="%.4g", font_size_factor=0.9, label_color="black", tick_color="black",
    )  # fmt: skip
    x_axis.SetRange(x0, x1)
    y_axis = plotter.add_ruler(
        (x0, y1, 0.0), (x0, y0, 0.0), number_labels=frame.ticks[1], title=" ",
        label_format="%.4g", font_size_factor=0.9, label_color="black", tick_color="black",
    )  # fmt: skip
    y_axis.SetRange(y1, y0)
    for axis in (x_axis, y_axis):
        for text in (axis.GetTitleTextProperty(), axis.GetLabelTextProperty()):
            text.SetItalic(False)
            text.SetBold(False)
            text.SetShadow(False)
    plotter.add_point_labels(
        [(x0, y1 + 12 * frame.pixel, 0.0)], [f"y ({frame.length})"], font_size=14,
        bold=False, shape=None, show_points=False, always_visible=True,
        justification_horizontal="center", justification_vertical="bottom",
    )  # fmt: skip


def fit_camera(plotter, frame: Layout) -> None:
    """Parallel projection down -z, the axes' box in its place in the panel."""
    x, y = frame.focus
    distance = 10.0 * frame.scale
    plotter.camera_position = [(x, y, distance), (x, y, 0.0), (0.0, 1.0, 0.0)]
    plotter.enable_parallel_projection()
    plotter.camera.parallel_scale = frame.scale
    plotter.reset_camera_clipping_range()
