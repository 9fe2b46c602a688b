"""Scene sections for rock engineering: bolts, earthquake input, water, measurements, stages.

``[[bolts]]``, ``[seismic]``, ``[water]``, ``[[measure]]`` and ``[[stages]]``
(docs/scene.md, docs/engineering.md). :func:`parse_engineering` checks them
after the blocks, with the same :class:`dda.scene.checks.Checker`: an unknown key
or a bad value is one :class:`dda.errors.SceneError` naming the key.

Points that must lie in a block (bolt ends, measurement points) find their
block among the scene's blocks at t = 0 unless the entry names it; a point on
the boundary of two blocks must name it. Stages resolve the blocks they
remove at load time too: by name, by group, or by their centroid at t = 0
lying inside a polygon.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from dda.scene.checks import (
    NON_NEGATIVE,
    POSITIVE,
    Checker,
    Point,
    Spec,
    checked_fields,
    choice,
    join_key,
    real,
    require,
    table_list,
)
from dda.scene.in_situ import BoundaryStress, boundary_stress
from dda.scene.text_file import UnreadableText, read_text

log = logging.getLogger(__name__)

ENGINEERING_KEYS = ("bolts", "seismic", "water", "measure", "stages")
ON_BLOCK = 1e-9  # a point within this fraction of a block's size lies on it
POINT_QUANTITIES = {"displacement": ("ux", "uy"), "velocity": ("vx", "vy"),
                    "stress": ("sxx", "syy", "sxy")}  # fmt: skip
CONTACT_QUANTITIES = {"contact_force": ("N", "fx", "fy")}
BOLT_QUANTITIES = {"bolt_force": ("force",)}


@dataclass(frozen=True)
class Bolt:
    """``[[bolts]]``: a linear spring between a point of one block and a point of another.

    Its force is ``pretension + stiffness × (length − installed length)``,
    tension positive; it breaks when that exceeds ``capacity`` (None: never).
    """

    name: str
    start: Point
    end: Point
    blocks: tuple[str, str]  # blocks holding start and end
    stiffness: float
    pretension: float = 0.0
    capacity: float | None = None


@dataclass(frozen=True)
class Seismic:
    """``[seismic]``: the ground acceleration that the fixed blocks ``blocks`` follow.

    ``record`` rows are (t, ax, ay) as given; the engine uses ``scale`` × them.
    """

    record: tuple[tuple[float, float, float], ...]
    scale: float
    blocks: tuple[str, ...]
    file: str | None = None


@dataclass(frozen=True)
class Water:
    """``[water]``: a phreatic line (x increasing) and the unit weight of water."""

    table: tuple[Point, ...]
    unit_weight: float


@dataclass(frozen=True)
class Measure:
    """``[[measure]]``: a material point, a pair of blocks in contact, or a bolt."""

    name: str
    quantities: tuple[str, ...]
    point: Point | None = None
    block: str | None = None  # the block holding ``point``
    blocks: tuple[str, str] | None = None  # contact forces between these two
    bolt: str | None = None

    @property
    def kind(self) -> str:
        """``"point"``, ``"contact"`` or ``"bolt"``."""
        return "point" if self.point is not None else "contact" if self.blocks else "bolt"

    def columns(self) -> list[str]:
        """Column names in ``history_points.csv``: ``name.component``."""
        table = {"point": POINT_QUANTITIES, "contact": CONTACT_QUANTITIES,
                 "bolt": BOLT_QUANTITIES}[self.kind]  # fmt: skip
        return [f"{self.name}.{c}" for q in self.quantities for c in table[q]]


@dataclass(frozen=True)
class Stage:
    """``[[stages]]``: at ``time``, remove blocks, install bolts and (``strength_factor``)
    divide the joints' strengths, with ``intact`` the breakable materials' too; apply or
    take away boundary stresses (:mod:`dda.scene.in_situ`)."""

    time: float
    remove: tuple[str, ...] = ()
    bolts: tuple[Bolt, ...] = ()
    strength_factor: float | None = None  # F: tan φ / F, c / F, T / F from ``time`` on
    intact: bool = False
    # boundary stresses applied from this stage on, and the names of those it takes away
    boundary_stresses: tuple[BoundaryStress, ...] = ()
    remove_boundary_stresses: tuple[str, ...] = ()


class _Geometry:
    """The scene's blocks at t = 0 as shapely polygons, for point and centroid queries."""

    def __init__(self, blocks: Sequence[Any]) -> None:
        self.names = [b.name for b in blocks]
        self.row = {name: k for k, name in enumerate(self.names)}
        self.fixed = np.array([b.fixed for b in blocks], dtype=bool)
        counts = [len(b.vertices) for b in blocks]
        coords = np.concatenate([np.asarray(b.vertices, float) for b in blocks])
        rings = shapely.linearrings(coords, indices=np.repeat(np.arange(len(counts)), counts))
        self.polygons = shapely.polygons(rings)
        bounds = shapely.bounds(self.polygons)
        self.sizes = np.hypot(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1])
        self.extent = float(np.hypot(*(bounds[:, 2:].max(0) - bounds[:, :2].min(0))))
        self.tree = shapely.STRtree(self.polygons)

    def distance(self, point: Point, name: str) -> float:
        return float(shapely.distance(self.polygons[self.row[name]], shapely.Point(point)))

    def holders(self, point: Point) -> list[str]:
        """Blocks the point lies in or on (within ``ON_BLOCK`` of their size)."""
        near = self.tree.query(
            shapely.Point(point), predicate="dwithin", distance=ON_BLOCK * self.extent
        )
        return [self.names[k] for k in sorted(near)]

    def inside(self, polygon: shapely.Polygon) -> list[str]:
        """Blocks whose centroid lies inside ``polygon``."""
        centroids = shapely.centroid(self.polygons)
        return [self.names[k] for k in np.flatnonzero(shapely.contains(polygon, centroids))]


def parse_engineering(
    chk: Checker,
    raw: Mapping[str, Any],
    blocks: Sequence[Any],
    groups: Mapping[str, tuple[str, ...]],
    analysis: Any,
    loads: Sequence[Any] = (),
) -> dict[str, Any]:
    """The Scene fields ``bolts``, ``seismic``, ``water``, ``measure`` and ``stages``."""
    if not any(k in raw for k in ENGINEERING_KEYS):
        return {}
    geometry = _Geometry(blocks)
    names = _BoltNames()
    bolts = tuple(
        _bolt(chk, value, f"bolts[{i}]", geometry, names)
        for i, value in enumerate(table_list(chk, raw, "bolts"))
    )
    stages = _stages(chk, raw, geometry, groups, analysis, names)
    out = {
        "bolts": bolts,
        "stages": stages,
        "measure": _measures(chk, raw, geometry, names.seen),
        "seismic": _seismic(chk, raw, geometry, groups, analysis),
        "water": _water(chk, raw),
    }
    _check_removals(chk, out, blocks, loads)
    return out


# --------------------------------------------------------------------------- points


def _host(chk: Checker, point: Point, key: str, geometry: _Geometry, what: str) -> str:
    """The block holding ``point``; refused when it lies in none or on two."""
    holders = geometry.holders(point)
    if not holders:
        chk.fail(key, f"{list(point)} lies in no block")
    if len(holders) > 1:
        chk.fail(
            key,
            f"{list(point)} lies on the boundary of blocks {holders[0]!r} and {holders[1]!r}: "
            f"name its block with {what}",
        )
    return holders[0]


def _on_named(chk: Checker, point: Point, name: str, key: str, geometry: _Geometry) -> None:
    distance = geometry.distance(point, name)
    if distance > ON_BLOCK * geometry.sizes[geometry.row[name]]:
        chk.fail(key, f"lies outside block {name!r} (distance {distance:g})")


# --------------------------------------------------------------------------- bolts


class _BoltNames:
    """Bolt names in order of appearance (scene bolts, then stage bolts): unique."""

    def __init__(self) -> None:
        self.seen: dict[str, str] = {}  # name -> key of its entry

    def take(self, chk: Checker, value: object, key: str) -> str:
        if value is None:
            value = f"bolt{len(self.seen) + 1}"
        name = _label(chk, value, f"{key}.name")
        if name in self.seen:
            chk.fail(f"{key}.name", f"duplicate bolt name {name!r} ({self.seen[name]})")
        self.seen[name] = key
        return name


def _label(chk: Checker, value: object, key: str) -> str:
    """A name that can head a CSV column: not empty, no comma, dot or quote."""
    name = chk.text(value, key)
    if not name or any(c in name for c in ',."\n'):
        chk.fail(key, f'{name!r}: a name must be non-empty, without , . " or a newline')
    return name


_BOLT: dict[str, Spec] = {
    "name": lambda chk, value, key: value,  # checked by _BoltNames
    "start": Checker.position,
    "end": Checker.position,
    "blocks": lambda chk, value, key: chk.sequence(value, key),
    "stiffness": real(POSITIVE),
    "pretension": real(NON_NEGATIVE),
    "capacity": real(POSITIVE),
}


def _bolt(chk: Checker, value: object, key: str, geometry: _Geometry, names: _BoltNames) -> Bolt:
    values = checked_fields(chk, value, key, _BOLT)
    require(chk, values, key, ("start", "end", "stiffness"))
    name = names.take(chk, values.get("name"), key)
    start, end = values["start"], values["end"]
    if math.dist(start, end) <= ON_BLOCK * geometry.extent:
        chk.fail(f"{key}.end", "coincides with start: a bolt needs two distinct points")
    hosts = _bolt_hosts(chk, values, key, geometry)
    if hosts[0] == hosts[1]:
        chk.fail(f"{key}.end", f"start and end lie in the same block {hosts[0]!r}")
    if geometry.fixed[geometry.row[hosts[0]]] and geometry.fixed[geometry.row[hosts[1]]]:
        chk.fail(f"{key}.blocks", "both ends lie in fixed blocks: the bolt would hold nothing")
    pretension = values.get("pretension", 0.0)
    capacity = values.get("capacity")
    if capacity is not None and capacity <= pretension:
        chk.fail(f"{key}.capacity", f"{capacity:g} must exceed the pretension {pretension:g}")
    return Bolt(name, start, end, hosts, values["stiffness"], pretension, capacity)


def _bolt_hosts(chk: Checker, values: dict, key: str, geometry: _Geometry) -> tuple[str, str]:
    points = (values["start"], values["end"])
    given = values.get("blocks")
    if given is None:
        hint = f"{key}.blocks = [start block, end block]"
        return tuple(
            _host(chk, p, f"{key}.{end}", geometry, hint)
            for p, end in zip(points, ("start", "end"), strict=True)
        )
    if len(given) != 2:
        chk.fail(f"{key}.blocks", f"expected two block names (start, end), got {len(given)}")
    hosts = tuple(
        chk.known(name, f"{key}.blocks[{k}]", geometry.row, "block") for k, name in enumerate(given)
    )
    for p, host, end in zip(points, hosts, ("start", "end"), strict=True):
        _on_named(chk, p, host, f"{key}.{end}", geometry)
    return hosts


# --------------------------------------------------------------------------- measure


def _measures(
    chk: Checker, raw: Mapping[str, Any], geometry: _Geometry, bolts: Mapping[str, str]
) -> tuple[Measure, ...]:
    specs: dict[str, Spec] = {
        "name": _label,
        "point": Checker.position,
        "block": partial(Checker.known, names=geometry.row, what="block"),
        "blocks": lambda chk, value, key: chk.sequence(value, key),
        "bolt": partial(Checker.known, names=bolts, what="bolt"),
        "quantities": lambda chk, value, key: chk.sequence(value, key),
    }
    out, seen = [], {}
    for i, value in enumerate(table_list(chk, raw, "measure")):
        key = f"measure[{i}]"
        values = checked_fields(chk, value, key, specs)
        name = values.setdefault("name", f"m{i + 1}")
        if name in seen:
            chk.fail(f"{key}.name", f"duplicate measurement name {name!r} (measure[{seen[name]}])")
        seen[name] = i
        given = [k for k in ("point", "blocks", "bolt") if k in values]
        if len(given) != 1:
            chk.fail(key, "give exactly one of point, blocks (a contact pair) or bolt")
        if "block" in values and "point" not in values:
            chk.fail(f"{key}.block", "names the block of a point: give point as well")
        if "point" in values:
            point = values["point"]
            if "block" in values:
                _on_named(chk, point, values["block"], f"{key}.point", geometry)
            else:
                values["block"] = _host(chk, point, f"{key}.point", geometry, f"{key}.block")
        if "blocks" in values:
            values["blocks"] = _pair(chk, values["blocks"], f"{key}.blocks", geometry)
        kind = Measure(name, (), **{k: values.get(k) for k in ("point", "blocks", "bolt")}).kind
        quantities = _quantities(chk, values.get("quantities"), key, kind)
        values["quantities"] = _without_static_velocity(chk, quantities, values, key, raw)
        out.append(Measure(**values))
    return tuple(out)


def _without_static_velocity(
    chk: Checker, quantities: tuple[str, ...], values: Mapping[str, Any], key: str,
    raw: Mapping[str, Any],
) -> tuple[str, ...]:  # fmt: skip
    """``quantities`` less the velocity in a static analysis, where it is 0 at every
    step (left out of the default ones; named, refused with the reason)."""
    analysis = raw.get("analysis")
    static = isinstance(analysis, Mapping) and analysis.get("mode") == "static"
    if not static or "velocity" not in quantities:
        return quantities
    if values.get("quantities") is not None:
        chk.fail(f"{key}.quantities", "velocity is 0 at every step of a static analysis: "
                 "measure the displacement")  # fmt: skip
    return tuple(q for q in quantities if q != "velocity")


def _pair(chk: Checker, items: Sequence[Any], key: str, geometry: _Geometry) -> tuple[str, str]:
    if len(items) != 2:
        chk.fail(key, f"expected two block names, got {len(items)}")
    a, b = (chk.known(n, f"{key}[{k}]", geometry.row, "block") for k, n in enumerate(items))
    if a == b:
        chk.fail(key, f"the two blocks must differ, got {a!r} twice")
    return a, b


def _quantities(chk: Checker, value: object, key: str, kind: str) -> tuple[str, ...]:
    table = {"point": POINT_QUANTITIES, "contact": CONTACT_QUANTITIES,
             "bolt": BOLT_QUANTITIES}[kind]  # fmt: skip
    if value is None:
        return tuple(table)
    words = [chk.choice(v, f"{key}.quantities[{k}]", tuple(table)) for k, v in enumerate(value)]
    if not words:
        chk.fail(f"{key}.quantities", "name at least one quantity")
    if len(set(words)) != len(words):
        chk.fail(f"{key}.quantities", "a quantity is listed twice")
    return tuple(words)


# --------------------------------------------------------------------------- seismic


def _seismic(
    chk: Checker,
    raw: Mapping[str, Any],
    geometry: _Geometry,
    groups: Mapping[str, tuple[str, ...]],
    analysis: Any,
) -> Seismic | None:
    if "seismic" not in raw:
        return None
    specs: dict[str, Spec] = {
        "acceleration": lambda chk, value, key: chk.sequence(value, key),
        "file": Checker.text,
        "component": choice("x", "y"),
        "scale": real(),
        "blocks": Checker.listed,
    }
    values = checked_fields(chk, raw["seismic"], "seismic", specs)
    if values.get("scale") == 0.0:
        chk.fail("seismic.scale", "is 0: the ground would not move (leave [seismic] out)")
    if ("acceleration" in values) == ("file" in values):
        chk.fail("seismic", "give the record as acceleration = [[t, ax, ay], ...] or as file")
    if analysis.mode != "dynamic":
        chk.fail("seismic", 'earthquake input needs analysis.mode = "dynamic"')
    if "file" in values:
        rows = _read_record(chk, values["file"])
        key = "seismic.file"
    else:
        key = "seismic.acceleration"
        rows = [
            chk.vector(r, f"{key}[{k}]", len(chk.sequence(r, f"{key}[{k}]")))
            for k, r in enumerate(values["acceleration"])
        ]
    record = _record(chk, rows, key, values.get("component"))
    _say_record_fit(record, analysis, key)
    moving = _named_blocks(chk, values.get("blocks"), "seismic.blocks", geometry, groups)
    if values.get("blocks") is None:
        moving = tuple(n for n, f in zip(geometry.names, geometry.fixed, strict=True) if f)
        if not moving:
            chk.fail("seismic", "the scene has no fixed block to move with the ground")
    for k, name in enumerate(moving):
        if not geometry.fixed[geometry.row[name]]:
            chk.fail(
                f"seismic.blocks[{k}]",
                f"{name!r} is not fixed: only fixed blocks follow the ground",
            )
    return Seismic(record, values.get("scale", 1.0), moving, values.get("file"))


def _say_record_fit(record: Sequence[Sequence[float]], analysis: Any, key: str) -> None:
    """Warn where the run cannot see the record as written: it ends before the record's
    first time (a row index read as time), or before its second (times in ms, say). The
    run's end is ``duration``, or ``steps`` at the longest ``time_step``."""
    end = analysis.run_length
    first, second = record[0][0], record[1][0]
    if first >= end:
        log.warning("%s: the record starts at t = %g s, after the run ends (%g s): the "
                    "ground never moves (is the first column a time in seconds?)",
                    key, first, end)  # fmt: skip
    elif second >= end:
        log.warning("%s: the run ends (%g s) before the record's second time (%g s): it "
                    "sees one segment of the record (are its times in seconds?)",
                    key, end, second)  # fmt: skip


RECORD_SEPARATORS = re.compile(r"[,;\s]+")  # between a record's numbers
HEADER_WORD = re.compile(r"[A-Za-z]{2,}|^[A-Za-z]")  # a word: not the e of 1e-3


def _read_record(chk: Checker, name: str) -> list[list[float]]:
    """Rows of numbers from a text file, separated by commas, semicolons, spaces or tabs
    (``#`` comments and header lines, text before the numbers, skipped). A line that is
    no row of numbers is refused by its number, unless it is a header (it holds a word)."""
    base = Path(chk.source).parent if chk.source.endswith(".toml") else Path.cwd()
    path = base / name
    try:
        lines = read_text(path, "a record is rows of numbers").splitlines()
    except UnreadableText as exc:
        chk.fail("seismic.file", f"{str(path)!r} {exc}")
    rows: list[list[float]] = []
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        where = f"{name} line {number}"
        if _decimal_comma(text):
            chk.fail("seismic.file", f"{where}: a comma inside a number, {line.strip()!r}: "
                     "write decimal points (commas may only separate numbers)")  # fmt: skip
        try:
            row = [float(x) for x in RECORD_SEPARATORS.split(text.strip(",; \t"))]
        except ValueError:
            if rows or not HEADER_WORD.search(text):
                chk.fail("seismic.file", f"{where}: not numbers: {line.strip()!r}")
            continue
        if rows and len(row) != len(rows[0]):
            chk.fail("seismic.file", f"{where}: {len(row)} numbers where the rows above hold "
                     f"{len(rows[0])}: {line.strip()!r}")  # fmt: skip
        rows.append(row)
    return rows


DECIMAL_COMMA = re.compile(r"\d,\d")


def _decimal_comma(text: str) -> bool:
    """Whether a record line writes numbers with decimal commas: it separates its numbers
    by spaces, tabs or semicolons and one of them holds a comma between digits
    (``0 0,5`` or ``0,1;2,5``; ``0.1,2.5`` separates by the comma)."""
    parts = re.split(r"[;\s]+", text.strip(",; \t"))
    return len(parts) > 1 and any(DECIMAL_COMMA.search(part) for part in parts)


def _record(
    chk: Checker, rows: Sequence[Sequence[float]], key: str, component: str | None
) -> tuple[tuple[float, float, float], ...]:
    """(t, ax, ay) rows from rows of (t, a) (along ``component``) or (t, ax, ay)."""
    if len(rows) < 2:
        chk.fail(key, f"expected at least 2 rows (t, a), got {len(rows)}")
    widths = {len(r) for r in rows}
    if len(widths) != 1 or widths.pop() not in (2, 3):
        chk.fail(key, "every row must hold t, ax (2 numbers) or t, ax, ay (3 numbers)")
    table = np.array(rows, dtype=float)
    if not np.isfinite(table).all():
        chk.fail(key, "numbers must be finite")
    if table.shape[1] == 3 and component is not None:
        chk.fail("seismic.component", "a record with ax and ay columns takes no component")
    if table[0, 0] < 0.0:
        chk.fail(key, f"times must start at 0 or later, got {table[0, 0]:g}")
    bad = np.flatnonzero(np.diff(table[:, 0]) <= 0.0)
    if bad.size:
        chk.fail(f"{key}[{bad[0] + 1}]", "times must increase strictly")
    if table.shape[1] == 2:
        zero = np.zeros(len(table))
        a = table[:, 1]
        ax, ay = (zero, a) if component == "y" else (a, zero)
        table = np.column_stack([table[:, 0], ax, ay])
    return tuple(map(tuple, table.tolist()))


# --------------------------------------------------------------------------- water


def _water(chk: Checker, raw: Mapping[str, Any]) -> Water | None:
    if "water" not in raw:
        return None
    specs: dict[str, Spec] = {"table": Checker.positions, "unit_weight": real(POSITIVE)}
    values = checked_fields(chk, raw["water"], "water", specs)
    require(chk, values, "water", ("table", "unit_weight"))
    table = values["table"]
    if len(table) < 2:
        chk.fail("water.table", f"a phreatic line needs at least 2 points, got {len(table)}")
    for k in range(1, len(table)):
        if not table[k][0] > table[k - 1][0]:
            chk.fail(f"water.table[{k}]", "x must increase strictly along the phreatic line")
    return Water(table, values["unit_weight"])


# --------------------------------------------------------------------------- stages


def _named_blocks(
    chk: Checker,
    value: Sequence[Any] | None,
    key: str,
    geometry: _Geometry,
    groups: Mapping[str, tuple[str, ...]],
) -> tuple[str, ...]:
    """Block names from a list of block or group names (groups expanded), in order."""
    out: list[str] = []
    for k, item in enumerate(() if value is None else value):  # a list or a numpy array
        name = chk.known(item, f"{key}[{k}]", {**geometry.row, **groups}, "block or group")
        members = groups[name] if name in groups and name not in geometry.row else (name,)
        out += [m for m in members if m not in out]
    return tuple(out)


def _stages(
    chk: Checker,
    raw: Mapping[str, Any],
    geometry: _Geometry,
    groups: Mapping[str, tuple[str, ...]],
    analysis: Any,
    names: _BoltNames,
) -> tuple[Stage, ...]:
    specs: dict[str, Spec] = {
        "time": real(POSITIVE),
        "remove": Checker.listed,
        "polygon": Checker.simple_polygon,
        "bolts": Checker.listed,
        "strength_factor": real(POSITIVE),
        "intact": Checker.boolean,
        "boundary_stresses": Checker.listed,
        "remove_boundary_stresses": lambda chk, value, key: tuple(
            chk.text(v, f"{key}[{k}]") for k, v in enumerate(chk.listed(value, key))
        ),
    }
    stages: list[Stage] = []
    removed: dict[str, str] = {}  # block -> the stage key that removed it
    for i, value in enumerate(table_list(chk, raw, "stages")):
        key = f"stages[{i}]"
        values = checked_fields(chk, value, key, specs)
        require(chk, values, key, ("time",))
        time = values["time"]
        if stages and not time > stages[-1].time:
            chk.fail(f"{key}.time", "stages must come in order of strictly increasing time")
        if analysis.duration is not None and time >= analysis.duration:
            chk.fail(f"{key}.time", f"{time:g} is not before the end of the run "
                     f"(analysis.duration = {analysis.duration:g})")  # fmt: skip
        if analysis.steps is not None and time >= analysis.run_length:
            end = analysis.run_length
            chk.fail(f"{key}.time", f"{time:g} is not before the end of the run (analysis."
                     f"steps x time_step = {end:g}; give duration to end at a time)")  # fmt: skip
        if "intact" in values and "strength_factor" not in values:
            chk.fail(f"{key}.intact", "needs strength_factor in the same stage")
        changes = ("remove", "polygon", "bolts", "strength_factor", "boundary_stresses",
                   "remove_boundary_stresses")  # fmt: skip
        if not any(k in values for k in changes):
            chk.fail(key, "a stage removes blocks (remove, polygon), adds bolts (bolts), "
                     "divides the strengths (strength_factor) or applies or removes "
                     "boundary stresses (boundary_stresses, remove_boundary_stresses)")  # fmt: skip
        remove = list(_named_blocks(chk, values.get("remove"), f"{key}.remove", geometry, groups))
        if "polygon" in values:
            inside = geometry.inside(values["polygon"])
            if not inside:
                chk.fail(f"{key}.polygon", "holds the centroid of no block")
            remove += [n for n in inside if n not in remove]
        for name in remove:
            if name in removed:
                chk.fail(f"{key}.remove", f"block {name!r} is removed already by {removed[name]}")
            removed[name] = key
        bolts = tuple(
            _bolt(chk, b, f"{key}.bolts[{k}]", geometry, names)
            for k, b in enumerate(values.get("bolts", ()))
        )
        for k, bolt in enumerate(bolts):
            for end, host in zip(("start", "end"), bolt.blocks, strict=True):
                if host in removed:
                    chk.fail(f"{key}.bolts[{k}].{end}", f"lies in block {host!r}, removed by "
                             f"{removed[host]}")  # fmt: skip
        factor = values.get("strength_factor")
        loads = tuple(
            boundary_stress(chk, b, f"{key}.boundary_stresses[{k}]", on=time)
            for k, b in enumerate(values.get("boundary_stresses", ()))
        )
        stages.append(
            Stage(time, tuple(remove), bolts, factor, values.get("intact", False), loads,
                  values.get("remove_boundary_stresses", ()))
        )  # fmt: skip
    left = [n for n, f in zip(geometry.names, geometry.fixed, strict=True) if not f]
    if left and all(n in removed for n in left):
        chk.fail("stages", "the stages remove every free block: nothing would be left to move")
    return tuple(stages)


def _check_removals(
    chk: Checker, sections: Mapping[str, Any], blocks: Sequence[Any], loads: Sequence[Any]
) -> None:
    """Refuse a stage that removes a block something acts on or is attached to."""
    removed = {name: i for i, s in enumerate(sections["stages"]) for name in s.remove}
    if not removed:
        return
    users: list[tuple[str, str]] = []  # (block, what uses it)
    users += [(b.name, f"blocks[{k}].fixed_points") for k, b in enumerate(blocks) if b.fixed_points]
    users += [(ld.block, f"loads[{k}]") for k, ld in enumerate(loads)]
    users += [
        (m.block, f"measure[{k}].point") for k, m in enumerate(sections["measure"]) if m.block
    ]
    for k, bolt in enumerate(sections["bolts"]):
        users += [(host, f"bolts[{k}]") for host in bolt.blocks]
    seismic = sections["seismic"]  # the fixed blocks it names move with the ground
    if seismic is not None:
        users += [(name, f"seismic.blocks[{k}]") for k, name in enumerate(seismic.blocks)]
    for i, stage in enumerate(sections["stages"]):
        for k, bolt in enumerate(stage.bolts):
            users += [(host, f"stages[{i}].bolts[{k}]") for host in bolt.blocks]
    for block, what in users:
        if block in removed:
            chk.fail(
                join_key(f"stages[{removed[block]}]", "remove"),
                f"removes block {block!r}, which {what} is attached to",
            )
