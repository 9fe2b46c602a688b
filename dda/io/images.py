"""Off-screen pictures of frames with pyvista (EGL; no display needed).

Blocks are filled and coloured by one per-block scalar (a stress measure,
displacement, ...; see :data:`dda.io.fields.SCALARS`) with a scalar bar,
outlined in black; compressive contact normal forces are drawn as segments
along the contact normal, centred on the contact point, with length
proportional to the force. The camera looks down ``-z`` with a parallel
projection, fitted to the blocks.

pyvista is imported lazily, after ``VTK_DEFAULT_OPENGL_WINDOW`` is set to
``vtkEGLRenderWindow`` (the X fallback is slower and warns; OSMesa crashes).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dda.io.atomic import atomic_path
from dda.io.fields import SCALARS, scalar_field
from dda.result import Frame

logger = logging.getLogger(__name__)

# fraction of the view (width, height) the blocks may use; the rest is for
# the scalar bar (bottom) and the title (top)
_FIT = (0.90, 0.70)
_CENTRE = (0.50, 0.56)  # where the blocks' centre goes, in view fractions
_CONTACT_LENGTH = 0.06  # longest contact segment, as a fraction of the model size


def _pyvista() -> Any:
    """Import pyvista for off-screen use (EGL window chosen before vtk loads)."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista

    pyvista.OFF_SCREEN = True
    return pyvista


def render_frame(
    frame: Frame,
    path: str | os.PathLike[str],
    scalars: str = "syy",
    title: str | None = None,
    show_contacts: bool = True,
    window_size: tuple[int, int] = (1200, 900),
    clim: tuple[float, float] | None = None,
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
        Text above the picture; default ``"t = <time> s (step <step>)"``.
    show_contacts
        Draw contact normal forces when the frame has contacts.
    window_size
        Picture size in pixels (width, height).
    clim
        Colour range; default: the range of the frame's values.

    Returns
    -------
    Path
        ``path``.
    """
    return render_side_by_side(
        [frame], [title], path, scalars=scalars, show_contacts=show_contacts,
        window_size=window_size, clim=clim,
    )  # fmt: skip


def render_side_by_side(
    frames: Sequence[Frame],
    titles: Sequence[str | None],
    path: str | os.PathLike[str],
    scalars: str = "syy",
    show_contacts: bool = True,
    window_size: tuple[int, int] | None = None,
    clim: tuple[float, float] | None = None,
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

    Returns
    -------
    Path
        ``path``.
    """
    if not frames or len(titles) != len(frames):
        raise ValueError("give one title (or None) per frame, and at least one frame")
    if any(len(f.vertices) == 0 for f in frames):
        raise ValueError("cannot draw a frame without blocks")
    # fixed blocks carry no computed field: grey (NaN), outside the colour range
    values = [np.where(f.fixed, np.nan, scalar_field(f, scalars)) for f in frames]
    info = SCALARS[scalars]
    clim, cmap = color_range(np.concatenate(values), info.signed, clim)
    size = window_size or (700 * len(frames), 600)
    bounds = _bounds(frames)  # one view for all: motion between frames shows
    pv = _pyvista()
    plotter = pv.Plotter(
        off_screen=True, shape=(1, len(frames)), window_size=list(size),
        border=False, theme=pv.themes.DocumentTheme(),
    )  # fmt: skip
    try:
        for k, (frame, title, value) in enumerate(zip(frames, titles, values, strict=True)):
            plotter.subplot(0, k)
            last = k == len(frames) - 1
            _draw_frame(plotter, frame, value, clim, cmap, info.label, show_contacts, last)
            plotter.add_text(title or default_title(frame), position="upper_edge", font_size=12)
            _fit_camera(plotter, bounds, aspect=size[0] / len(frames) / size[1])
        path = Path(path)
        with atomic_path(path) as tmp:
            plotter.screenshot(str(tmp))
    finally:
        plotter.close()
    logger.debug("wrote %s (%s, range %.4g..%.4g)", path, scalars, *clim)
    return path


def default_title(frame: Frame) -> str:
    """``"t = 0.5 s (step 500)"``, or ``"step 500"`` when the time is unknown."""
    if np.isfinite(frame.time):
        return f"t = {frame.time:.6g} s (step {frame.step})"
    return f"step {frame.step}"


def color_range(
    values: np.ndarray, signed: bool, clim: tuple[float, float] | None = None
) -> tuple[tuple[float, float], str]:
    """Colour range and colour map for some values.

    A signed quantity whose values straddle zero gets a range symmetric about
    zero and a diverging map (white at zero); anything else its own range and
    a sequential map. A constant value gets a small range around it.

    Parameters
    ----------
    values
        All values that share the range.
    signed
        Whether the quantity has a meaningful sign (stress components).
    clim
        A range chosen by the caller, kept as given.

    Returns
    -------
    (low, high), colour map name
    """
    finite = values[np.isfinite(values)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    diverging = signed and low < 0.0 < high
    if clim is None:
        if diverging:
            bound = max(-low, high)
            low, high = -bound, bound
        if high - low <= 1e-12 * max(abs(low), abs(high), 1.0):
            pad = max(abs(low) * 1e-3, 1e-9)
            low, high = low - pad, high + pad
        clim = (low, high)
    return (float(clim[0]), float(clim[1])), ("coolwarm" if diverging else "viridis")


def _draw_frame(plotter, frame, values, clim, cmap, label, show_contacts, scalar_bar) -> None:
    size = _model_size(frame)
    blocks = blocks_polydata(frame, values)
    plotter.add_mesh(
        blocks.triangulate(), scalars="value", cmap=cmap, clim=clim, show_edges=False,
        lighting=False, show_scalar_bar=scalar_bar,
        scalar_bar_args={
            "title": label, "vertical": False, "position_x": 0.2, "position_y": 0.055,
            "width": 0.6, "height": 0.1, "fmt": "%.3g", "title_font_size": 14,
            "label_font_size": 12, "n_labels": 5,
        },
    )  # fmt: skip
    if scalar_bar:  # the bar's own title would overlap its labels: caption below instead
        plotter.scalar_bar.SetTitle("")
        caption = plotter.add_text(label, position=(0.5, 0.012), viewport=True, font_size=10)
        caption.GetTextProperty().SetJustificationToCentered()
    plotter.add_mesh(outlines_polydata(frame, z=1e-3 * size), color="black", line_width=1.5)
    contacts = contact_segments(frame, _CONTACT_LENGTH * size, z=2e-3 * size)
    if show_contacts and contacts is not None:
        plotter.add_mesh(contacts, color="magenta", line_width=3)


def _bounds(frames: Sequence[Frame]) -> tuple[np.ndarray, np.ndarray]:
    points = np.concatenate([np.concatenate(f.vertices) for f in frames])
    return points.min(axis=0), points.max(axis=0)


def _fit_camera(plotter, bounds: tuple[np.ndarray, np.ndarray], aspect: float) -> None:
    """Parallel projection down -z, ``bounds`` in the part of the view left for blocks."""
    low, high = bounds
    extent = np.maximum(high - low, 1e-9 * max(float(np.abs([low, high]).max()), 1.0))
    scale = max(extent[1] / (2 * _FIT[1]), extent[0] / (2 * _FIT[0] * aspect))
    view = np.array([2 * scale * aspect, 2 * scale])
    focus = 0.5 * (low + high) + (0.5 - np.array(_CENTRE)) * view
    distance = 10.0 * float(max(extent.max(), scale))
    plotter.camera_position = [(*focus, distance), (*focus, 0.0), (0.0, 1.0, 0.0)]
    plotter.enable_parallel_projection()
    plotter.camera.parallel_scale = scale
    plotter.reset_camera_clipping_range()


def _model_size(frame: Frame) -> float:
    points = np.concatenate(frame.vertices)
    return float(np.ptp(points, axis=0).max()) or 1.0


def _vertex_layout(frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = np.array([len(v) for v in frame.vertices], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    points = np.column_stack([np.concatenate(frame.vertices), np.zeros(counts.sum())])
    return counts, starts, points


def blocks_polydata(frame: Frame, values: np.ndarray | None = None) -> Any:
    """The blocks as a ``pyvista.PolyData`` of polygons, one cell per block.

    Parameters
    ----------
    frame
        The frame.
    values
        Optional ``(n,)`` cell values, stored as cell array ``"value"``.

    Returns
    -------
    pyvista.PolyData
        Polygons in frame row order (concave ones are fine after
        ``triangulate()``).
    """
    counts, starts, points = _vertex_layout(frame)
    faces = np.empty(counts.sum() + len(counts), dtype=np.int64)
    headers = starts + np.arange(len(counts))
    is_header = np.zeros(len(faces), dtype=bool)
    is_header[headers] = True
    faces[headers] = counts
    faces[~is_header] = np.arange(counts.sum())
    mesh = _pyvista().PolyData(points, faces=faces)
    if values is not None:
        mesh.cell_data["value"] = np.asarray(values, dtype=float)
    return mesh


def outlines_polydata(frame: Frame, z: float = 0.0) -> Any:
    """Closed block outlines as a ``pyvista.PolyData`` of poly-lines at height ``z``."""
    counts, starts, points = _vertex_layout(frame)
    points[:, 2] = z
    offsets = np.concatenate([[0], np.cumsum(counts + 2)[:-1]])
    lines = np.empty(int((counts + 2).sum()), dtype=np.int64)
    lines[offsets] = counts + 1
    lines[np.arange(counts.sum()) + np.repeat(offsets + 1 - starts, counts)] = np.arange(
        counts.sum()
    )
    lines[offsets + 1 + counts] = starts
    return _pyvista().PolyData(points, lines=lines)


def contact_segments(frame: Frame, length: float, z: float = 0.0) -> Any | None:
    """Compressive contact forces as segments along the normals (``None`` if there are none).

    Parameters
    ----------
    frame
        The frame.
    length
        Length of the segment of the largest normal force.
    z
        Height of the segments (above the blocks, so they stay visible).

    Returns
    -------
    pyvista.PolyData or None
        One line per contact with a positive normal force.
    """
    c = frame.contacts
    force = np.asarray(c.normal_force, dtype=float)
    keep = np.isfinite(force) & (force > 0.0)
    if not keep.any():
        return None
    half = 0.5 * length * (force[keep] / force[keep].max())[:, None] * c.normals[keep]
    ends = np.concatenate([c.points[keep] - half, c.points[keep] + half])
    m = int(keep.sum())
    points = np.column_stack([ends, np.full(2 * m, z)])
    lines = np.column_stack([np.full(m, 2), np.arange(m), np.arange(m) + m]).ravel()
    return _pyvista().PolyData(points, lines=lines)
