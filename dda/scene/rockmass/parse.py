"""Read and validate the rock-mass keys of a raw scene into a :class:`RockMass`.

Every refusal is a :class:`dda.errors.SceneError` with a dotted key such as
``joint_sets[1].spacing``. Geometric checks that need the whole domain
(overlapping regions, excavations outside the rock) live in
:mod:`dda.scene.rockmass.domain`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import shapely

from dda.scene.checks import (
    ANY,
    MAX_COORDINATE,
    NON_NEGATIVE,
    POSITIVE,
    Checker,
    Interval,
    suggest,
)
from dda.scene.rockmass.spec import (
    DEFAULT_MAX_BLOCKS,
    CuttingOptions,
    Excavation,
    JointLine,
    JointSet,
    Region,
    RockMass,
    Selector,
)

REGION_KEYS = {"polygon", "holes", "material"}
JOINT_SET_KEYS = {
    "name",
    "joint",
    "dip",
    "spacing",
    "offset",
    "trace_length",
    "bridge_length",
    "stagger",
    "dip_std",
    "spacing_std",
    "seed",
}
JOINT_LINE_KEYS = {"name", "joint", "points"}
EXCAVATION_KEYS = {"polygon", "center", "radius", "segments"}
SELECTOR_KEYS = {"polygon", "inside", "touching", "sides", "material", "blocks"}
CUTTING_KEYS = {"min_block_area", "small_blocks", "holes", "name_prefix", "max_blocks"}
SIDES = ("bottom", "top", "left", "right")
MAX_CIRCLE_SEGMENTS = 4096


def parse_rock_mass(raw: Mapping[str, Any], source: str) -> RockMass:
    """Validate the rock-mass keys of ``raw`` (regions, joints, excavations, ...)."""
    chk = Checker(source)
    materials = _names(raw.get("materials", {}))
    joints = _names(raw.get("joints", {}))
    regions = _entries(chk, raw, "regions")
    if not regions:
        chk.fail("regions", "a rock mass needs at least one [[regions]] entry")
    return RockMass(
        regions=tuple(_region(chk, f"regions[{i}]", r, materials) for i, r in regions),
        joint_sets=tuple(
            _joint_set(chk, f"joint_sets[{i}]", i, t, joints)
            for i, t in _entries(chk, raw, "joint_sets")
        ),
        joint_lines=tuple(
            _joint_line(chk, f"joint_lines[{i}]", i, t, joints)
            for i, t in _entries(chk, raw, "joint_lines")
        ),
        excavations=tuple(
            _excavation(chk, f"excavations[{i}]", t) for i, t in _entries(chk, raw, "excavations")
        ),
        fix=tuple(_selector(chk, f"fix[{i}]", t, materials) for i, t in _entries(chk, raw, "fix")),
        groups=_groups(chk, raw.get("groups", {}), materials),
        options=_options(chk, raw.get("cutting", {})),
    )


def _names(table: Any) -> set[str] | None:
    """Names defined in a table, or None when the table is malformed (checked later)."""
    return set(table) if isinstance(table, Mapping) else None


def _entries(chk: Checker, raw: Mapping[str, Any], key: str) -> list[tuple[int, Any]]:
    return list(enumerate(chk.sequence(raw.get(key, []), key)))


def _known(chk: Checker, key: str, name: str, known: set[str] | None, what: str) -> str:
    if known is not None and name not in known:
        chk.fail(key, f"unknown {what} {name!r}: {suggest(name, known)}")
    return name


def _region(chk: Checker, key: str, table: Any, materials: set[str] | None) -> Region:
    chk.table(table, key, REGION_KEYS)
    if "polygon" not in table:
        chk.fail(f"{key}.polygon", "missing")
    outer = chk.simple_polygon(table["polygon"], f"{key}.polygon")
    holes = []
    for j, hole in enumerate(chk.sequence(table.get("holes", []), f"{key}.holes")):
        hkey = f"{key}.holes[{j}]"
        ring = chk.simple_polygon(hole, hkey)
        if not outer.contains(ring):
            chk.fail(hkey, "hole must lie strictly inside the region polygon")
        holes.append(ring.exterior.coords)
    polygon = shapely.Polygon(outer.exterior.coords, holes)
    if not polygon.is_valid:
        reason = shapely.is_valid_reason(polygon)
        chk.fail(f"{key}.holes", f"holes overlap or touch ({reason})")
    if "material" in table:
        material = chk.text(table["material"], f"{key}.material")
    elif materials is not None and len(materials) == 1:
        material = next(iter(materials))
    else:
        chk.fail(f"{key}.material", "missing (needed with several materials)")
    _known(chk, f"{key}.material", material, materials, "material")
    return Region(key=key, polygon=polygon, material=material)


def _joint_name(chk: Checker, key: str, table: Mapping, joints: set[str] | None) -> str:
    name = chk.text(table.get("joint", ""), f"{key}.joint")
    return _known(chk, f"{key}.joint", name, joints, "joint") if name else ""


def _joint_set(chk: Checker, key: str, index: int, table: Any, joints: set[str] | None) -> JointSet:
    chk.table(table, key, JOINT_SET_KEYS)
    for required in ("dip", "spacing"):
        if required not in table:
            chk.fail(f"{key}.{required}", "missing")

    def num(name: str, default: float | None = None, interval: Interval = ANY) -> float | None:
        if name not in table:
            return default
        return chk.real(table[name], f"{key}.{name}", interval)

    trace = num("trace_length", None, POSITIVE)
    if "bridge_length" in table and trace is None:
        chk.fail(f"{key}.bridge_length", "needs trace_length")
    stagger: float | str = 0.0
    if isinstance(table.get("stagger"), str):
        stagger = chk.choice(table["stagger"], f"{key}.stagger", ("random",))
    elif "stagger" in table:
        stagger = num("stagger")
    return JointSet(
        key=key,
        name=chk.text(table.get("name", f"set{index + 1}"), f"{key}.name"),
        joint=_joint_name(chk, key, table, joints),
        dip=num("dip"),
        spacing=num("spacing", interval=POSITIVE),
        offset=num("offset", 0.0),
        trace_length=trace,
        bridge_length=num("bridge_length", 0.0, NON_NEGATIVE),
        stagger=stagger,
        dip_std=num("dip_std", 0.0, NON_NEGATIVE),
        spacing_std=num("spacing_std", 0.0, NON_NEGATIVE),
        seed=chk.integer(table.get("seed", index), f"{key}.seed", 0),
    )


def _joint_line(
    chk: Checker, key: str, index: int, table: Any, joints: set[str] | None
) -> JointLine:
    chk.table(table, key, JOINT_LINE_KEYS)
    if "points" not in table:
        chk.fail(f"{key}.points", "missing")
    xy = np.array(chk.positions(table["points"], f"{key}.points", 2))
    if np.any(np.all(np.diff(xy, axis=0) == 0.0, axis=1)):
        chk.fail(f"{key}.points", "two consecutive points are equal")
    return JointLine(
        key=key,
        name=chk.text(table.get("name", f"line{index + 1}"), f"{key}.name"),
        joint=_joint_name(chk, key, table, joints),
        points=xy,
    )


def _excavation(chk: Checker, key: str, table: Any) -> Excavation:
    chk.table(table, key, EXCAVATION_KEYS)
    if "polygon" in table:
        if (EXCAVATION_KEYS - {"polygon"}) & set(table):
            chk.fail(key, "give either polygon or center/radius, not both")
        return Excavation(key, chk.simple_polygon(table["polygon"], f"{key}.polygon"))
    if "center" not in table or "radius" not in table:
        chk.fail(key, "needs polygon, or center and radius")
    cx, cy = chk.position(table["center"], f"{key}.center")
    radius = chk.real(table["radius"], f"{key}.radius", POSITIVE)
    if radius > MAX_COORDINATE:  # its ring would overflow the geometry's arithmetic
        chk.fail(f"{key}.radius", f"must be at most {MAX_COORDINATE:g} (as a coordinate), "
                 f"got {radius:g}")  # fmt: skip
    n = chk.integer(table.get("segments", 36), f"{key}.segments", 3)
    if n > MAX_CIRCLE_SEGMENTS:
        chk.fail(f"{key}.segments", f"at most {MAX_CIRCLE_SEGMENTS}")
    angle = 2.0 * math.pi * np.arange(n) / n
    ring = np.column_stack([cx + radius * np.cos(angle), cy + radius * np.sin(angle)])
    return Excavation(key, shapely.Polygon(ring))


def _selector(chk: Checker, key: str, table: Any, materials: set[str] | None) -> Selector:
    chk.table(table, key, SELECTOR_KEYS)
    if not table:
        chk.fail(key, f"needs one of {', '.join(sorted(SELECTOR_KEYS))}")
    polygon = inside = touching = material = blocks = None
    sides: tuple[str, ...] = ()
    if "polygon" in table:
        polygon = chk.simple_polygon(table["polygon"], f"{key}.polygon")
    if "inside" in table:
        inside = chk.simple_polygon(table["inside"], f"{key}.inside")
    if "touching" in table:
        touching = np.array(chk.positions(table["touching"], f"{key}.touching", 2))
    if "sides" in table:
        raw_sides = chk.sequence(table["sides"], f"{key}.sides")
        sides = tuple(chk.choice(s, f"{key}.sides[{i}]", SIDES) for i, s in enumerate(raw_sides))
    if "material" in table:
        material = chk.text(table["material"], f"{key}.material")
        _known(chk, f"{key}.material", material, materials, "material")
    if "blocks" in table:
        names = chk.sequence(table["blocks"], f"{key}.blocks")
        blocks = tuple(chk.text(b, f"{key}.blocks[{i}]") for i, b in enumerate(names))
    return Selector(key, polygon, inside, touching, sides, material, blocks)


def _groups(
    chk: Checker, table: Any, materials: set[str] | None
) -> dict[str, Selector | tuple[str, ...]]:
    if not isinstance(table, Mapping):
        chk.fail("groups", "must be a table of groups")
    groups: dict[str, Selector | tuple[str, ...]] = {}
    for name, rule in table.items():
        key = f"groups.{name}"
        if isinstance(rule, list):
            groups[name] = tuple(chk.text(b, f"{key}[{i}]") for i, b in enumerate(rule))
        else:
            groups[name] = _selector(chk, key, rule, materials)
    return groups


def _options(chk: Checker, table: Any) -> CuttingOptions:
    chk.table(table, "cutting", CUTTING_KEYS)
    area = table.get("min_block_area")
    prefix = chk.text(table.get("name_prefix", "b"), "cutting.name_prefix")
    if not prefix or "/" in prefix:
        chk.fail("cutting.name_prefix", "must be non-empty, without '/'")
    return CuttingOptions(
        min_block_area=None
        if area is None
        else chk.real(area, "cutting.min_block_area", NON_NEGATIVE),
        small_blocks=chk.choice(
            table.get("small_blocks", "merge"), "cutting.small_blocks", ("merge", "refuse")
        ),
        holes=chk.choice(table.get("holes", "split"), "cutting.holes", ("split", "refuse")),
        name_prefix=prefix,
        max_blocks=chk.integer(
            table.get("max_blocks", DEFAULT_MAX_BLOCKS), "cutting.max_blocks", 1
        ),
    )
