"""Pictures of frames (PNG), drawn with matplotlib's Agg canvas (no display needed).

Blocks are filled by one per-block scalar (a stress measure, displacement,
...; see :data:`dda.io.fields.SCALARS`) and outlined in black; fixed blocks
carry no computed field and are grey. Compressive contact normal forces are
magenta segments along the contact normal, centred on the contact point,
their length proportional to the force; rock bolts are orange segments
between their end points. The picture has the scene's title,
axes in the scene's length unit, a colour bar naming the quantity and its
unit (stresses in kPa, MPa or GPa when large) with ticks that read
differently from one another, and a legend for the grey, the magenta (with
the force of the longest mark, per metre of thickness: ``kN/m``) and the orange.
Stresses that are all below 1e-6 of their unit (a free block's round-off) are drawn
as zero, and a field of one value (to round-off) in one colour with that value stated
(:mod:`dda.io.colour_scale`).

matplotlib is imported when a picture is made, never by ``import dda.io``.
"""

from __future__ import annotations

import logging
import math
import os
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dda.io.atomic import atomic_path
from dda.io.colour_scale import NEAR_CONSTANT, ColourScale, colour_scale
from dda.io.fields import SCALARS, engineering_scale, scalar_field, unit_name
from dda.io.fonts import unicode_text
from dda.result import Frame

logger = logging.getLogger(__name__)

FIXED_COLOUR = "#a9a9a9"
CONTACT_COLOUR = "magenta"
BOLT_COLOUR = "darkorange"
WATER_COLOUR = "tab:blue"
_CONTACT_LENGTH = 0.06  # longest contact segment, as a fraction of the model size ...
_CONTACT_BLOCKS = 2.0  # ... and at most this many times the blocks' median size
# lines are drawn at full width up to this many blocks, thinner as √(this / blocks) above
# (10,000 blocks at 0.8 pt outlines and 2 pt contact marks drew a black smear)
_FULL_WIDTH_BLOCKS = 400
_DPI = 100
ROUND_OFF_STRESS = 1e-6  # stresses all below this (scene units) are drawn as zero


def render_frame(
    frame: Frame,
    path: str | os.PathLike[str],
    scalars: str = "syy",
    title: str | None = None,
    show_contacts: bool = True,
    window_size: tuple[int, int] = (1200, 900),
    clim: tuple[float, float] | None = None,
    scene_title: str = "",
    units: Mapping[str, str] | None = None,
    water_table: Sequence[Sequence[float]] | None = None,
    water_follows: Sequence[str] = (),
    view: Sequence[Sequence[float]] | None = None,
) -> Path:
    """Render one frame to a PNG file.

    Parameters
    ----------
    frame
        The frame to draw.
    path
        Destination ``.png`` (written atomically).
    scalars
        Block colouring: ``sxx, syy, sxy, s1, s2, von_mises, displacement,
        velocity`` or ``rotation``.
    title
        Text above the frame; default ``"t = <time> s (step <step>)"``.
    show_contacts
        Draw contact normal forces when the frame has contacts.
    window_size
        Picture size in pixels (width, height).
    clim
        Colour range; default: the range of the frame's values.
    scene_title
        The scene's title, at the top of the picture.
    units
        The scene's ``[units]`` (``length``, ``force``, ``time``); SI where absent.
    water_table
        The scene's phreatic line (``[water] table``, its points), drawn dashed blue.
    water_follows
        The blocks that carry the line ([seismic] blocks): it is drawn moved by their
        displacement in the frame, as the run moves it with the ground.
    view
        ``[[x_min, y_min], [x_max, y_max]]``: the part of the model to show (a zoom);
        the colour range and the longest force mark then follow the blocks and contacts
        in it. Default: every block.

    Returns
    -------
    Path
        ``path``.
    """
    return render_side_by_side(
        [frame], [title], path, scalars=scalars, show_contacts=show_contacts,
        window_size=window_size, clim=clim, scene_title=scene_title, units=units,
        water_table=water_table, water_follows=water_follows, view=view,
    )  # fmt: skip


def scene_look(scene: Any) -> dict[str, Any]:
    """The keywords of :func:`render_frame` that a scene fixes: its title, its units, and
    its phreatic line with the blocks that carry it (``[seismic] blocks``), for the
    pictures a command draws from its runs (``dda fos``, ``dda ensemble``)."""
    units = scene.units
    look: dict[str, Any] = {
        "scene_title": scene.title,
        "units": {"length": units.length, "force": units.force, "time": units.time},
    }
    if scene.water is not None:
        look["water_table"] = [list(point) for point in scene.water.table]
        look["water_follows"] = tuple(scene.seismic.blocks) if scene.seismic else ()
    return look


def render_side_by_side(
    frames: Sequence[Frame],
    titles: Sequence[str | None],
    path: str | os.PathLike[str],
    scalars: str = "syy",
    show_contacts: bool = True,
    window_size: tuple[int, int] | None = None,
    clim: tuple[float, float] | None = None,
    scene_title: str = "",
    units: Mapping[str, str] | None = None,
    water_table: Sequence[Sequence[float]] | None = None,
    water_follows: Sequence[str] = (),
    view: Sequence[Sequence[float]] | None = None,
) -> Path:
    """Render frames next to each other, with one shared colour range and view.

    Parameters
    ----------
    frames
        One or more frames, drawn left to right.
    titles
        One title per frame (``None``: time and step).
    path
        Destination ``.png`` (written atomically).
    scalars
        Block colouring, as in :func:`render_frame`.
    show_contacts
        Draw contact normal forces.
    window_size
        Picture size; default 700 x 600 pixels per frame.
    clim
        Colour range; default: the range over all frames.
    scene_title, units, water_table, water_follows, view
        As in :func:`render_frame`.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        ``path`` does not end in ``.png``, or ``clim`` is not two finite numbers, the
        first below the second (a reversed range drew a colour bar without numbers)
    """
    _check_picture(path, clim)
    figure = compose(
        frames, titles, scalars, show_contacts, window_size, clim, scene_title, units,
        view=None if view is None else np.asarray(view, dtype=float),
        water_table=water_table, water_follows=water_follows,
    )  # fmt: skip
    path = Path(path)
    with unicode_text(), atomic_path(path) as tmp:
        figure.savefig(tmp, format="png", dpi=_DPI)
    logger.debug("wrote %s (%s)", path, scalars)
    return path


def compose(
    frames: Sequence[Frame],
    titles: Sequence[str | None],
    scalars: str = "syy",
    show_contacts: bool = True,
    window_size: tuple[int, int] | None = None,
    clim: tuple[float, float] | ColourScale | None = None,
    scene_title: str = "",
    units: Mapping[str, str] | None = None,
    view: np.ndarray | None = None,
    force_max: float | None = None,
    water_table: Sequence[Sequence[float]] | None = None,
    water_follows: Sequence[str] = (),
) -> Any:
    """The matplotlib ``Figure`` of :func:`render_side_by_side` (arguments as there;
    ``clim`` may also be a whole :class:`~dda.io.colour_scale.ColourScale`);
    ``view``: ``[[x_min, y_min], [x_max, y_max]]`` to show instead of the frames' extent
    (a movie keeps one view for all its frames); ``force_max``: the contact force drawn
    longest (default the largest of ``frames``; a movie keeps one scale); ``water_table``:
    the scene's phreatic line, drawn over the view (not widening it)."""
    if not frames or len(titles) != len(frames):
        raise ValueError("give one title (or None) per frame, and at least one frame")
    if any(len(f.vertices) == 0 for f in frames):
        raise ValueError("cannot draw a frame without blocks")
    # fixed blocks carry no computed field: grey (NaN), outside the colour range
    values = [np.where(f.fixed, np.nan, scalar_field(f, scalars)) for f in frames]
    info = SCALARS[scalars]
    values = [_without_round_off(v, info.dimension) for v in values]
    scale = clim if isinstance(clim, ColourScale) else None
    seen = values if view is None else [np.where(_in_view(f, view), v, np.nan)
                                        for f, v in zip(frames, values, strict=True)]  # fmt: skip
    scale = scale or colour_scale(np.concatenate(seen), info.signed, clim)
    size = window_size or (700 * len(frames), 600)
    if force_max is None:
        force_max = max((largest_force(f, view) for f in frames), default=0.0)
    with unicode_text():
        figure = _figure(size)
        axes = figure.subplots(1, len(frames), squeeze=False)[0]
        mappable = None
        length = unit_name("length", units)
        for ax, frame, title, value in zip(axes, frames, titles, values, strict=True):
            mappable = _draw_frame(ax, frame, value, scale, show_contacts, force_max)
            ax.set_title(title or default_title(frame), fontsize=11)
            ax.ticklabel_format(useOffset=False, style="plain")  # map coordinates read whole
            ax.set_xlabel(f"x ({length})")
            ax.set_ylabel(f"y ({length})")
        _share_view(axes, frames if view is None else None, view)
        if water_table is not None:
            _draw_water_table(axes, water_table, frames, water_follows)
        coloured = sum(int(np.isfinite(v).sum()) for v in values)
        _colour_bar(
            figure, mappable, axes, scale, info.label, unit_name(info.dimension, units), coloured
        )
        _legend(
            figure, frames, show_contacts, force_max, unit_name("force_per_length", units),
            water_table is not None,
        )  # fmt: skip
        if scene_title:
            figure.suptitle("\n".join(textwrap.wrap(scene_title, 90)), fontsize=13)
    return figure


def picture_pixels(figure: Any) -> np.ndarray:
    """The figure drawn by Agg: (height, width, 3) uint8 RGB."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(figure)
    with unicode_text():
        canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def extent(frames: Sequence[Frame]) -> np.ndarray:
    """``[[x_min, y_min], [x_max, y_max]]`` of the blocks of all ``frames``."""
    points = np.concatenate([np.concatenate(f.vertices) for f in frames])
    return np.array([points.min(axis=0), points.max(axis=0)])


def _without_round_off(values: np.ndarray, dimension: str) -> np.ndarray:
    """Stresses all below ``ROUND_OFF_STRESS`` (in the scene's unit) are round-off of
    zero (a free block): drawn as 0, so the colour bar does not span ±8e-10."""
    finite = values[np.isfinite(values)]
    if dimension == "stress" and finite.size and np.abs(finite).max() < ROUND_OFF_STRESS:
        return np.where(np.isfinite(values), 0.0, values)
    return values


def largest_force(frame: Frame, view: np.ndarray | None = None) -> float:
    """The largest compressive contact normal force of ``frame`` (0 without any); with
    ``view``, of the contacts whose point lies in it."""
    force = np.asarray(frame.contacts.normal_force, dtype=float)
    keep = np.isfinite(force) & (force > 0.0)
    if view is not None and len(force):
        points = np.asarray(frame.contacts.points, dtype=float)
        keep &= np.all((points >= view[0]) & (points <= view[1]), axis=1)
    force = force[keep]
    return float(force.max()) if force.size else 0.0


def _in_view(frame: Frame, view: np.ndarray) -> np.ndarray:
    """Which blocks of ``frame`` reach into ``view`` (their bounding box meets it)."""
    starts = np.cumsum([0] + [len(v) for v in frame.vertices[:-1]])
    points = np.concatenate(frame.vertices)
    low, high = np.minimum.reduceat(points, starts), np.maximum.reduceat(points, starts)
    return np.all((high >= view[0]) & (low <= view[1]), axis=1)


def default_title(frame: Frame) -> str:
    """``"t = 0.5 s (step 500)"``, or ``"step 500"`` when the time is unknown."""
    if np.isfinite(frame.time):
        return f"t = {frame.time:.6g} s (step {frame.step})"
    return f"step {frame.step}"


def distinct_labels(ticks: Sequence[float], max_digits: int = 12) -> list[str]:
    """Tick labels with the fewest significant digits (3 at least) that tell them apart.

    >>> distinct_labels([-322.4, -322.2, -322.0])
    ['-322.4', '-322.2', '-322']
    """
    ticks = [float(t) for t in ticks]
    for digits in range(3, max_digits + 1):
        labels = [_format(t, digits, ticks) for t in ticks]
        if len(set(labels)) == len(labels):
            return labels
    return [repr(t) for t in ticks]


def _format(value: float, digits: int, ticks: Sequence[float]) -> str:
    span = max(abs(t) for t in ticks) if ticks else 0.0
    if value == 0.0 or (span and abs(value) < span * 1e-12):
        return "0"
    return f"{value:.{digits}g}"


def _figure(size: tuple[int, int]) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI, layout="constrained")


def _draw_frame(
    ax, frame: Frame, values: np.ndarray, scale: ColourScale, show_contacts: bool,
    force_max: float,
) -> Any:  # fmt: skip
    """Blocks (coloured or grey), outlines and contact forces on ``ax``; the colour mapping."""
    from matplotlib.collections import LineCollection, PolyCollection

    polygons = [np.asarray(v, dtype=float) for v in frame.vertices]
    thin = line_scale(len(polygons))
    coloured = PolyCollection(
        [p for p, v in zip(polygons, values, strict=True) if np.isfinite(v)],
        array=values[np.isfinite(values)], cmap=_colour_map(scale), clim=scale.clim,
        edgecolors="black", linewidths=0.8 * thin,
    )  # fmt: skip
    ax.add_collection(coloured)
    fixed = [p for p, v in zip(polygons, values, strict=True) if not np.isfinite(v)]
    if fixed:
        grey = PolyCollection(
            fixed, facecolors=FIXED_COLOUR, edgecolors="black", linewidths=0.8 * thin
        )
        ax.add_collection(grey)
    segments = contact_segments(frame, longest_contact_mark(frame), force_max)
    if show_contacts and segments is not None:
        widths = 2.0 * thin
        ax.add_collection(LineCollection(segments, colors=CONTACT_COLOUR, linewidths=widths))
    if frame.bolts is not None and len(frame.bolts):
        ax.add_collection(LineCollection(frame.bolts, colors=BOLT_COLOUR, linewidths=2.5))
        ends = frame.bolts.reshape(-1, 2)
        ax.plot(ends[:, 0], ends[:, 1], "o", color=BOLT_COLOUR, markersize=3)
    ax.set_aspect("equal", adjustable="datalim")  # the axes fill their box
    return coloured


def _share_view(axes, frames: Sequence[Frame] | None, view: np.ndarray | None = None) -> None:
    """One view for all frames (motion between them shows), with a margin: the frames'
    extent, or ``view`` (which may be a part of them: a zoom)."""
    if view is None:
        for ax in axes:
            ax.update_datalim(extent(frames))
            ax.margins(0.05)
            ax.autoscale_view()
        return
    for ax in axes:  # the data limits are the view: what lies beyond it is cut off
        ax.dataLim.set_points(np.asarray(view, dtype=float))
        ax.margins(0.05)
        ax.autoscale_view()


def _colour_map(scale: ColourScale) -> Any:
    """The scale's colour map; one colour (the map's middle) for a field of one value."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap

    named = colormaps[scale.cmap]
    return named if scale.constant is None else ListedColormap([named(0.5)])


def _colour_bar(
    figure, mappable, axes, scale: ColourScale, label: str, unit: str, blocks: int
) -> None:
    """A horizontal colour bar; stresses in kPa, MPa or GPa when their numbers are large.
    A field of one value gets a bar of one colour with that value as its one tick."""
    from matplotlib.ticker import FixedFormatter, FixedLocator, MaxNLocator

    clim = scale.clim
    divisor, unit = engineering_scale(max(abs(clim[0]), abs(clim[1])), unit)
    bar = figure.colorbar(
        mappable, ax=list(axes), orientation="horizontal", shrink=0.7, extend=scale.extend
    )
    text = f"{label} ({unit})"
    if scale.constant is not None:
        ticks, labels = [scale.constant], [f"{scale.constant / divisor:.7g}"]
        if blocks > 1:
            share = format(NEAR_CONSTANT, ".0e").replace("e-0", "e-")  # 1e-4
            text += f", one value: the blocks differ by less than {share} of it"
    else:
        ticks = [t for t in MaxNLocator(6).tick_values(*clim) if clim[0] <= t <= clim[1]]
        labels = distinct_labels([t / divisor for t in ticks])
    bar.locator = FixedLocator(ticks)
    bar.formatter = FixedFormatter(labels)
    bar.update_ticks()
    bar.set_label(text)


def _draw_water_table(
    axes, table: Sequence[Sequence[float]], frames: Sequence[Frame], follows: Sequence[str]
) -> None:
    """The phreatic line on each of ``axes``, within the view they show; level beyond
    its ends, as the water loads take it (docs/engineering.md, Water); moved in each
    frame by the mean displacement of the blocks that carry it (``follows``: the
    [seismic] ground's, which moves the water with it)."""
    drawn = np.asarray(table, dtype=float).reshape(-1, 2)
    for ax, frame in zip(axes, frames, strict=True):
        carried = np.isin(np.asarray(frame.names), list(follows))
        points = drawn + (frame.displacements[carried].mean(axis=0) if carried.any() else 0.0)
        low, high = ax.get_xlim()
        low, high = low - (high - low), high + (high - low)  # past the view as laid out
        left = [[min(low, points[0, 0]), points[0, 1]]]
        right = [[max(high, points[-1, 0]), points[-1, 1]]]
        line = np.concatenate([left, points, right])
        ax.plot(*line.T, color=WATER_COLOUR, lw=1.5, ls="--", scalex=False, scaley=False)


def _legend(
    figure, frames: Sequence[Frame], show_contacts: bool, force_max: float, force_unit: str,
    water: bool = False,
) -> None:  # fmt: skip
    """Fixed blocks, contact forces with the force of the longest mark, bolts, the
    phreatic line."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = []
    if any(np.any(f.fixed) for f in frames):
        handles.append(Patch(facecolor=FIXED_COLOUR, edgecolor="black", label="fixed block"))
    if show_contacts and force_max > 0.0:
        scale, unit = engineering_scale(force_max, force_unit)
        shown = force_max / scale  # 3 digits, without an exponent below a million
        number = f"{shown:.0f}" if 1e3 <= shown < 1e6 else f"{shown:.3g}"
        label = f"contact normal force (length ∝ force; longest {number} {unit})"
        handles.append(Line2D([], [], color=CONTACT_COLOUR, lw=2, label=label))
    if any(f.bolts is not None and len(f.bolts) for f in frames):
        handles.append(Line2D([], [], color=BOLT_COLOUR, lw=2.5, marker="o", label="rock bolt"))
    if water:
        handles.append(Line2D([], [], color=WATER_COLOUR, lw=1.5, ls="--", label="phreatic line"))
    if handles:
        figure.legend(handles=handles, loc="outside lower center", ncols=3, fontsize=9)


def line_scale(blocks: int) -> float:
    """The width of the outlines and contact marks, as a fraction of their width in a
    model of up to ``_FULL_WIDTH_BLOCKS`` blocks: √(_FULL_WIDTH_BLOCKS / blocks) above."""
    return float(min(1.0, np.sqrt(_FULL_WIDTH_BLOCKS / max(blocks, 1))))


def longest_contact_mark(frame: Frame) -> float:
    """The length of the largest force's mark: ``_CONTACT_LENGTH`` of the model's size, at
    most ``_CONTACT_BLOCKS`` times the blocks' median size (√ of the median area), so
    that the marks of a model of thousands of blocks stay among their blocks."""
    areas = np.asarray(frame.areas, dtype=float)
    block = float(np.sqrt(np.median(areas))) if len(areas) else np.inf
    return min(_CONTACT_LENGTH * _model_size(frame), _CONTACT_BLOCKS * block)


def _model_size(frame: Frame) -> float:
    points = np.concatenate(frame.vertices)
    return float(np.ptp(points, axis=0).max()) or 1.0


def contact_segments(
    frame: Frame, length: float, force_max: float | None = None
) -> np.ndarray | None:
    """Compressive contact forces as segments along the normals (``None`` if there are none).

    Parameters
    ----------
    frame
        The frame.
    length
        Length of the segment of the force ``force_max``.
    force_max
        The force drawn ``length`` long; default the frame's largest normal force
        (frames side by side share the largest of them all).

    Returns
    -------
    numpy.ndarray or None
        ``(m, 2, 2)``: the two ends of one segment per contact with a positive
        normal force.
    """
    c = frame.contacts
    force = np.asarray(c.normal_force, dtype=float)
    keep = np.isfinite(force) & (force > 0.0)
    if not keep.any():
        return None
    reference = force_max or force[keep].max()
    half = 0.5 * length * (force[keep] / reference)[:, None] * c.normals[keep]
    return np.stack([c.points[keep] - half, c.points[keep] + half], axis=1)


def png_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` is no name for a picture (pictures are PNG files), or None."""
    suffix = Path(path).suffix
    if suffix.lower() == ".png":
        return None
    given = f", not {suffix}" if suffix else ""
    return f"a picture is written as .png{given}; give a file name ending in .png"


def range_problem(low: float, high: float) -> str | None:
    """Why (``low``, ``high``) is no colour range, or None."""
    if not (math.isfinite(low) and math.isfinite(high)):
        return "give finite numbers"
    if not low < high:
        return "the first number must be below the second"
    return None


def _check_picture(path: str | os.PathLike[str], clim: tuple[float, float] | None) -> None:
    """A ValueError unless ``path`` names a PNG and ``clim`` (when given) is a range."""
    problem = png_problem(path)
    if problem:
        raise ValueError(f"{path}: {problem}")
    problem = None if clim is None else range_problem(*(float(x) for x in clim))
    if problem:
        raise ValueError(f"clim {tuple(clim)!r}: {problem}")
