"""A picture of cut blocks: fill by material, edges coloured by joint set or drawing layer,
blocks a stage removes hatched (matplotlib, Agg)."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from dda.geometry import next_vertex_index
from dda.scene.rockmass.expand import CutRockMass

FILLS = ("#e8dcc8", "#cfd8dc", "#d7ccc8", "#dcedc8", "#f0e0e8")
JOINT_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2")
FIXED_FILL = "#9e9e9e"
REMOVED_HATCH = "#5d4037"  # the hatching of blocks a stage excavates


def draw_cut(
    cut: CutRockMass,
    path: str | Path,
    title: str = "",
    dpi: int = 150,
    removed: Collection[str] = (),
    drawn: Sequence[Mapping] = (),
    length_unit: str = "m",
) -> Path:
    """Write a PNG of :func:`cut_figure`; returns the path written."""
    fig = cut_figure(cut, title, removed, drawn, length_unit)
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    return path


def cut_figure(
    cut: CutRockMass,
    title: str = "",
    removed: Collection[str] = (),
    drawn: Sequence[Mapping] = (),
    length_unit: str = "m",
) -> Figure:
    """The cut blocks (``removed``: the names of blocks a stage excavates, drawn hatched)
    and the blocks the scene draws itself beside them (``drawn``: its ``[[blocks]]``
    tables, edges black), axes in ``length_unit``."""
    fig = Figure(figsize=(8, 6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    handles = _fill_blocks(ax, cut, drawn) + _hatch_removed(ax, cut, removed, drawn)
    handles += _draw_edges(ax, cut, drawn)
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncols=min(len(handles), 4),
        fontsize="small",
        frameon=False,
    )
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.ticklabel_format(useOffset=False, style="plain")  # map coordinates read whole
    ax.set_xlabel(f"x ({length_unit})")
    ax.set_ylabel(f"y ({length_unit})")
    ax.set_title(title or f"{len(cut.names) + len(drawn)} blocks")
    return fig


def _fill_blocks(ax, cut: CutRockMass, drawn: Sequence[Mapping]) -> list:
    kinds = [*zip(cut.materials, cut.fixed, strict=True)]
    kinds += [(block["material"], bool(block.get("fixed", False))) for block in drawn]
    materials = sorted({m for m, fixed in kinds if not fixed})
    fill = {m: FILLS[i % len(FILLS)] for i, m in enumerate(materials)}
    colours = [FIXED_FILL if fixed else fill[m] for m, fixed in kinds]
    polygons = [cut.blocks.polygon(i) for i in range(len(cut.names))]
    polygons += [np.asarray(block["vertices"], float) for block in drawn]
    ax.add_collection(PolyCollection(polygons, facecolors=colours, edgecolors="none"))
    handles = [Patch(facecolor=fill[m], label=m) for m in materials]
    if any(fixed for _, fixed in kinds):
        handles.append(Patch(facecolor=FIXED_FILL, label="fixed"))
    return handles


def _hatch_removed(
    ax, cut: CutRockMass, removed: Collection[str], drawn: Sequence[Mapping] = ()
) -> list:
    """Hatching over the blocks a stage removes (cut or drawn), and its legend entry."""
    gone = set(removed)
    polygons = [cut.blocks.polygon(i) for i, name in enumerate(cut.names) if name in gone]
    polygons += [np.asarray(b["vertices"], float) for b in drawn if b.get("name") in gone]
    if not polygons:
        return []
    ax.add_collection(
        PolyCollection(polygons, facecolors="none", edgecolors=REMOVED_HATCH, hatch="////",
                       linewidths=0.0)
    )  # fmt: skip
    return [Patch(facecolor="white", edgecolor=REMOVED_HATCH, hatch="////",
                  label="excavated by a stage")]  # fmt: skip


def _draw_edges(ax, cut: CutRockMass, drawn: Sequence[Mapping]) -> list:
    """Block edges: black on boundaries and around the blocks the scene draws itself, in
    one colour per joint set, joint line name or drawing layer (traces of one name share
    it)."""
    b = cut.blocks
    segments = np.stack([b.vertices, b.vertices[next_vertex_index(b.offsets)]], axis=1)
    handles = []
    boundary = b.edge_source < 0
    ax.add_collection(LineCollection(segments[boundary], colors="black", linewidths=0.6))
    outlines = [np.vstack([v, v[:1]]) for v in (np.asarray(k["vertices"], float) for k in drawn)]
    ax.add_collection(LineCollection(outlines, colors="black", linewidths=0.6))
    handles.append(Line2D([], [], color="black", lw=0.8, label="boundary / default"))
    names = list(dict.fromkeys(cut.traces.names))  # in order, once each
    for k, name in enumerate(names):
        sources = [i for i, n in enumerate(cut.traces.names) if n == name]
        on = np.isin(b.edge_source, sources)
        if not on.any():
            continue
        colour = JOINT_COLOURS[k % len(JOINT_COLOURS)]
        ax.add_collection(LineCollection(segments[on], colors=colour, linewidths=1.0))
        joints = sorted({cut.traces.joints[i] or "default" for i in sources})
        handles.append(Line2D([], [], color=colour, lw=1.2, label=_trace_label(name, joints)))
    return handles


def _trace_label(name: str, joints: list[str]) -> str:
    """A joint set's legend entry: its name and the joint (its properties) it is cut
    with, said once where they are the same ('bedding', not 'bedding (bedding)').

    >>> _trace_label("set1", ["default"])
    'set1 (joint: default)'
    >>> _trace_label("bedding", ["bedding"])
    'bedding'
    """
    if joints == [name]:
        return name
    return f"{name} (joint: {', '.join(joints)})"
