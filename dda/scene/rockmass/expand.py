"""``expand_rock_mass``: a scene with regions and joints -> a scene with explicit blocks.

The pipeline (Shi's block cutting):

0. a ``[drawing]``: its DXF file read into those keys (:mod:`~dda.scene.rockmass.drawing`);
1. validate the rock-mass keys (:mod:`~dda.scene.rockmass.parse`);
2. regions minus excavations (:mod:`~dda.scene.rockmass.domain`);
3. joint traces (:mod:`~dda.scene.rockmass.traces`);
4. node and polygonize (:mod:`~dda.scene.rockmass.cutting`); dangling joints cut nothing;
5. split blocks with holes, merge slivers (:mod:`~dda.scene.rockmass.holes`,
   :mod:`~dda.scene.rockmass.merging`);
6. name blocks bottom-up, tag each edge with its joint, drop straight-line
   vertices (:mod:`~dda.scene.rockmass.edges`);
7. fixed blocks and groups (:mod:`~dda.scene.rockmass.selection`).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely

from dda.errors import SceneError
from dda.geometry import polygon_moments
from dda.scene.rockmass.cutting import cut_faces
from dda.scene.rockmass.domain import Domain, build_domain
from dda.scene.rockmass.edges import COLLINEAR, PackedBlocks, drop_collinear, pack_faces, tag_edges
from dda.scene.rockmass.estimate import check_block_count
from dda.scene.rockmass.holes import split_holes
from dda.scene.rockmass.merging import merge_small
from dda.scene.rockmass.parse import parse_rock_mass
from dda.scene.rockmass.progress import CutProgress, Progress
from dda.scene.rockmass.selection import check_names, select_blocks
from dda.scene.rockmass.set_frame import LARGE, densest_set, set_turn
from dda.scene.rockmass.spec import RockMass, Selector
from dda.scene.rockmass.traces import Traces, build_traces

log = logging.getLogger(__name__)

IDLE_LINES_SAID = 5  # joint lines that cut nothing said one by one; the rest counted

#: keys that make the scene loader call :func:`expand_rock_mass`
TRIGGER_KEYS = ("regions", "joint_sets", "joint_lines", "excavations", "drawing")
#: every key consumed (and removed) by :func:`expand_rock_mass`
ROCK_MASS_KEYS = (*TRIGGER_KEYS, "fix", "groups", "cutting")
LARGE_CUT = 5_000  # estimated blocks above which the cut says it is cutting
DEFAULT_MIN_AREA = 1e-6  # of the rock area
TAG_TOLERANCE = 1e-8  # of the rock size: an edge midpoint this close to a trace lies on it
SELECT_TOLERANCE = 1e-6  # of the rock size: an edge this close to a side or line touches it


@dataclass(frozen=True)
class CutRockMass:
    """The cut blocks with everything needed to write them or draw them."""

    names: list[str]
    materials: list[str]
    blocks: PackedBlocks
    fixed: np.ndarray  # (n,) bool
    traces: Traces
    domain: Domain
    groups: dict[str, list[str]] = field(default_factory=dict)

    def edge_joints(self, i: int) -> list[str]:
        """Joint name of each edge of block i ("" = the default joint)."""
        return [self.traces.joints[s] if s >= 0 else "" for s in self.blocks.sources(i)]


def expand_rock_mass(raw: Mapping[str, Any], source: str, progress: Progress | None = None) -> dict:
    """Cut the rock mass of a raw scene and return the explicit-block raw scene.

    Parameters
    ----------
    raw
        The scene as read from TOML, with any of ``regions``, ``joint_sets``,
        ``joint_lines``, ``excavations`` (and optionally ``fix``, ``groups``,
        ``cutting``).
    source
        Where the scene came from, for error messages.
    progress
        ``progress(fraction, info)``, called as the cut goes, from 0 to exactly 1,
        ``info = {"stage": ..., "blocks": estimate}``
        (:mod:`dda.scene.rockmass.progress`); not called when the scene is refused
        before cutting. Without it a cut of more than :data:`LARGE_CUT` estimated
        blocks logs a warning before it starts (with it, an info message).

    Returns
    -------
    dict
        The same scene with those keys removed, the cut blocks appended to
        ``blocks`` (with ``edge_joints``), ``groups`` as name -> block names,
        and loads without ``block`` attached to the block under their point.

    Raises
    ------
    SceneError
        Naming the offending key, e.g. ``joint_sets[1].spacing``.
    """
    return cut_rock_mass(raw, source, progress)[1]


def cut_rock_mass(
    raw: Mapping[str, Any], source: str, progress: Progress | None = None
) -> tuple[CutRockMass, dict]:
    """Like :func:`expand_rock_mass`, also returning the :class:`CutRockMass`. A scene
    with a ``[drawing]`` is read from its DXF file first (:mod:`~dda.scene.rockmass.drawing`);
    a refusal of a region it drew names the drawing's entity."""
    if "drawing" not in raw:
        return _cut(raw, source, progress)
    from dda.scene.rockmass.drawing import expand_drawing

    drawing = expand_drawing(raw, source)
    try:
        return _cut(drawing.raw, source, progress)
    except SceneError as exc:
        raise drawing.translated(exc) from None


def _cut(
    raw: Mapping[str, Any], source: str, progress: Progress | None
) -> tuple[CutRockMass, dict]:
    mass = parse_rock_mass(raw, source)
    domain = build_domain(mass, source)
    estimate = check_block_count(mass, domain, source)
    if estimate > LARGE_CUT:  # a warning, unless the caller shows the progress itself
        level = logging.WARNING if progress is None else logging.INFO
        log.log(
            level, "%s: cutting about %s blocks; this may take a minute", source, f"{estimate:,}"
        )
    report = CutProgress(progress, estimate)
    traces = build_traces(mass, domain.bounds, source)
    report.plan(traces=len(traces.lines))
    report.done("traces")
    faces, region = _faces(mass, domain, traces, source, report)
    cut = _name_and_tag(mass, domain, traces, faces, region, source, report)
    _say_idle_lines(mass, cut, source)
    report.done("selecting")
    out = _explicit_scene(raw, cut, source, report)
    report.done("tables")
    log.info("%s: cut %d blocks (%d fixed)", source, len(cut.names), int(cut.fixed.sum()))
    return cut, out


def _say_idle_lines(mass: RockMass, cut: CutRockMass, source: str) -> None:
    """Warn of each joint set, and each joint line, along which no block edge lies (a
    set of joints that end inside the rock, or that lies outside it, was silent). A line
    ends inside the rock (a joint cuts the rock it crosses from side to side; one
    stopping a millimetre short of another joint cuts nothing), lies outside it, or cut
    only blocks that were merged away. Without a word it was a joint the user drew and
    the model does not have."""
    used = set(np.unique(cut.blocks.edge_source).tolist())
    first = len(mass.joint_sets)
    for k, js in enumerate(mass.joint_sets):
        if k not in used:
            log.warning(
                "%s: %s (%r) cuts nothing: its traces miss the rock, or its joints end "
                "inside it (a joint cuts the rock it crosses from side to side: with "
                "trace_length, each must reach the outline or another joint), or it cut "
                "blocks that were merged", source, js.key, js.name,
            )  # fmt: skip
    idle = [line for k, line in enumerate(mass.joint_lines) if first + k not in used]
    cutting = [line for k, line in enumerate(mass.joint_lines) if first + k in used]
    idle = _not_drawn_again(idle, cutting, source)
    for line in idle[:IDLE_LINES_SAID]:
        (x0, y0), (x1, y1) = line.points[0], line.points[-1]
        log.warning(
            "%s: %s (%r, from (%.6g, %.6g) to (%.6g, %.6g)) cuts nothing: it ends inside the "
            "rock (a joint cuts the rock it crosses from side to side: draw it on to the "
            "outline or to another joint), lies outside it, or cut blocks that were merged",
            source, line.key, line.name, x0, y0, x1, y1,
        )  # fmt: skip
    if len(idle) > IDLE_LINES_SAID:
        log.warning("%s: %d more joint lines cut nothing", source, len(idle) - IDLE_LINES_SAID)


def _not_drawn_again(idle: list, used: list, source: str) -> list:
    """The ``idle`` joint lines less those that lie along a ``used`` one (drawn twice: the
    block edges there name the other), each of those said as such."""
    if not idle or not used:
        return idle
    shapes = [shapely.LineString(line.points) for line in used]
    points = np.concatenate([line.points for line in idle + used])
    size = max(float(np.ptp(points, axis=0).max()), 1.0)
    near = shapely.STRtree(shapes)
    left = []
    for line in idle:
        trace = shapely.LineString(line.points)
        twins = [int(k) for k in near.query(trace, predicate="dwithin", distance=1e-9 * size)
                 if shapes[int(k)].buffer(1e-9 * size).covers(trace)]  # fmt: skip
        if not twins:
            left.append(line)
            continue
        other = used[twins[0]]
        log.warning("%s: %s (%r) lies along %s (%r): drawn twice, the cut has one joint there",
                    source, line.key, line.name, other.key, other.name)  # fmt: skip
    return left


def _faces(
    mass: RockMass, domain: Domain, traces: Traces, source: str, report: CutProgress
) -> tuple[np.ndarray, np.ndarray]:
    opts = mass.options
    faces, region = cut_faces(domain, traces, report)
    faces, region = split_holes(faces, region, opts.holes, source)
    min_area = opts.min_block_area
    if min_area is None:
        min_area = DEFAULT_MIN_AREA * domain.rock.area
    turn = set_turn(traces, densest_set(traces)) if len(traces.lines) >= LARGE else None
    faces, region = merge_small(faces, region, min_area, opts.small_blocks, source, turn)
    faces, region = split_holes(faces, region, opts.holes, source)
    bad = ~shapely.is_valid(faces) | (shapely.get_type_id(faces) != 3)
    if bad.any():
        raise SceneError(source, "cutting", f"{int(bad.sum())} cut block(s) are not valid polygons")
    report.done("merging")
    return faces, region


def _name_and_tag(
    mass: RockMass,
    domain: Domain,
    traces: Traces,
    faces: np.ndarray,
    region: np.ndarray,
    source: str,
    report: CutProgress,
) -> CutRockMass:
    vertices, offsets = pack_faces(faces)
    centroid = polygon_moments(vertices, offsets)["centroid"]
    order = np.lexsort((centroid[:, 0], centroid[:, 1]))
    vertices, offsets = pack_faces(faces[order])
    region = region[order]
    size = domain.size
    tags = tag_edges(vertices, offsets, traces, TAG_TOLERANCE * size, report)
    blocks = drop_collinear(PackedBlocks(vertices, offsets, tags), COLLINEAR * size)
    prefix = mass.options.name_prefix
    names = [f"{prefix}{i + 1}" for i in range(len(order))]
    materials = [domain.materials[r] for r in region]
    cut = CutRockMass(names, materials, blocks, np.zeros(len(names), bool), traces, domain)
    report.done("tagging")
    return _select(mass, cut, centroid[order], source)


def _select(mass: RockMass, cut: CutRockMass, centroid: np.ndarray, source: str) -> CutRockMass:
    b = cut.blocks
    tol = SELECT_TOLERANCE * cut.domain.size

    def pick(selector: Selector) -> np.ndarray:
        return select_blocks(
            selector,
            cut.names,
            cut.materials,
            centroid,
            b.vertices,
            b.offsets,
            cut.domain.bounds,
            tol,
            source,
        )

    fixed = np.zeros(len(cut.names), dtype=bool)
    for selector in mass.fix:
        fixed |= pick(selector)
    groups = {}
    for name, rule in mass.groups.items():
        if isinstance(rule, tuple):
            groups[name] = list(rule)
        else:
            groups[name] = [cut.names[i] for i in np.flatnonzero(pick(rule))]
    return CutRockMass(cut.names, cut.materials, b, fixed, cut.traces, cut.domain, groups)


def _explicit_scene(
    raw: Mapping[str, Any], cut: CutRockMass, source: str, report: CutProgress
) -> dict:
    out = {k: v for k, v in raw.items() if k not in ROCK_MASS_KEYS}
    written = list(raw.get("blocks", []))
    known = {str(b.get("name")) for b in written if isinstance(b, Mapping)}
    clash = known.intersection(cut.names)
    if clash:
        raise SceneError(
            source,
            "cutting.name_prefix",
            f"cut block name {sorted(clash)[0]!r} is also a [[blocks]] name; change the prefix",
        )
    out["blocks"] = written
    for chunk in report.chunks("tables", len(cut.names)):
        out["blocks"] += [_block_table(cut, i) for i in range(chunk.start, chunk.stop)]
    known.update(cut.names)
    for name, members in cut.groups.items():
        check_names(f"groups.{name}", tuple(members), known, source)
    if cut.groups or "groups" in raw:
        out["groups"] = {name: list(members) for name, members in cut.groups.items()}
    if "loads" in raw:
        out["loads"] = _attach_loads(raw["loads"], cut, source)
    return out


def _block_table(cut: CutRockMass, i: int) -> dict:
    return {
        "name": cut.names[i],
        "material": cut.materials[i],
        "vertices": cut.blocks.polygon(i).tolist(),
        "fixed": bool(cut.fixed[i]),
        "edge_joints": cut.edge_joints(i),
    }


def _attach_loads(loads: Any, cut: CutRockMass, source: str) -> Any:
    """Give a load without ``block`` the cut block under its ``point``."""
    if not isinstance(loads, list):
        return loads
    polygons = np.array(
        [shapely.Polygon(cut.blocks.polygon(i)) for i in range(len(cut.names))], dtype=object
    )
    tree = shapely.STRtree(polygons)
    out = []
    for i, load in enumerate(loads):
        if isinstance(load, Mapping) and "block" not in load and "point" in load:
            load = dict(load)
            hit = tree.query(shapely.Point(load["point"]), predicate="intersects")
            if len(hit) == 0:
                raise SceneError(source, f"loads[{i}].point", "lies in no cut block")
            load["block"] = cut.names[int(hit.min())]
        out.append(load)
    return out
