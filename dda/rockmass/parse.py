"""Read and validate the rock-mass keys of a raw scene into a :class:`RockMass`.

Every refusal is a :class:`dda.errors.SceneError` with a dotted key such as
``joint_sets[1].spacing``. Geometric checks that need the whole domain
(overlapping regions, excavations outside the rock) live in
:mod:`dda.rockmass.domain`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import shapely

from dda.errors import SceneError
from dda.rockmass import values as v
from dda.rockmass.spec import (
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
SELECTOR_KEYS = {"polygon", "touching", "sides", "material", "blocks"}
CUTTING_KEYS = {"min_block_area", "small_blocks", "holes", "name_prefix"}
SIDES = ("bottom", "top", "left", "right")
MAX_CIRCLE_SEGMENTS = 4096


def parse_rock_mass(raw: Mapping[str, Any], source: str) -> RockMass:
    """Validate the rock-mass keys of ``raw`` (regions, joints, excavations, ...)."""
    materials = _names(raw.get("materials", {}))
    joints = _names(raw.get("joints", {}))
    regions = _entries(raw, source, "regions")
    if not regions:
        raise SceneError(source, "regions", "a rock mass needs at least one [[regions]] entry")
    return RockMass(
        regions=tuple(_region(source, f"regions[{i}]", r, materials) for i, r in regions),
        joint_sets=tuple(
            _joint_set(source, f"joint_sets[{i}]", i, t, joints)
            for i, t in _entries(raw, source, "joint_sets")
        ),
        joint_lines=tuple(
            _joint_line(source, f"joint_lines[{i}]", i, t, joints)
            for i, t in _entries(raw, source, "joint_lines")
        ),
        excavations=tuple(
            _excavation(source, f"excavations[{i}]", t)
            for i, t in _entries(raw, source, "excavations")
        ),
        fix=tuple(
            _selector(source, f"fix[{i}]", t, materials) for i, t in _entries(raw, source, "fix")
        ),
        groups=_groups(source, raw.get("groups", {}), materials),
        options=_options(source, raw.get("cutting", {})),
    )


def _names(table: Any) -> set[str] | None:
    """Names defined in a table, or None when the table is malformed (checked later)."""
    return set(table) if isinstance(table, Mapping) else None


def _entries(raw: Mapping[str, Any], source: str, key: str) -> list[tuple[int, Any]]:
    return list(enumerate(v.check_list(source, key, raw.get(key, []))))


def _known(source: str, key: str, name: str, known: set[str] | None, what: str) -> str:
    if known is not None and name not in known:
        listed = ", ".join(sorted(known)) or "none"
        raise SceneError(source, key, f"unknown {what} {name!r} (defined: {listed})")
    return name


def _region(source: str, key: str, table: Any, materials: set[str] | None) -> Region:
    v.check_table(source, key, table, REGION_KEYS)
    if "polygon" not in table:
        raise SceneError(source, f"{key}.polygon", "missing")
    outer = v.simple_polygon(source, f"{key}.polygon", table["polygon"])
    holes = []
    for j, hole in enumerate(v.check_list(source, f"{key}.holes", table.get("holes", []))):
        hkey = f"{key}.holes[{j}]"
        ring = v.simple_polygon(source, hkey, hole)
        if not outer.contains(ring):
            raise SceneError(source, hkey, "hole must lie strictly inside the region polygon")
        holes.append(ring.exterior.coords)
    polygon = shapely.Polygon(outer.exterior.coords, holes)
    if not polygon.is_valid:
        reason = shapely.is_valid_reason(polygon)
        raise SceneError(source, f"{key}.holes", f"holes overlap or touch ({reason})")
    if "material" in table:
        material = v.text(source, f"{key}.material", table["material"])
    elif materials is not None and len(materials) == 1:
        material = next(iter(materials))
    else:
        raise SceneError(source, f"{key}.material", "missing (needed with several materials)")
    _known(source, f"{key}.material", material, materials, "material")
    return Region(key=key, polygon=polygon, material=material)


def _joint_name(source: str, key: str, table: Mapping, joints: set[str] | None) -> str:
    name = v.text(source, f"{key}.joint", table.get("joint", ""))
    return _known(source, f"{key}.joint", name, joints, "joint") if name else ""


def _joint_set(source: str, key: str, index: int, table: Any, joints: set[str] | None) -> JointSet:
    v.check_table(source, key, table, JOINT_SET_KEYS)
    for required in ("dip", "spacing"):
        if required not in table:
            raise SceneError(source, f"{key}.{required}", "missing")

    def num(name: str, default: float | None = None, **kw: bool) -> float | None:
        if name not in table:
            return default
        return v.number(source, f"{key}.{name}", table[name], **kw)

    trace = num("trace_length", None, positive=True)
    if "bridge_length" in table and trace is None:
        raise SceneError(source, f"{key}.bridge_length", "needs trace_length")
    stagger: float | str = 0.0
    if isinstance(table.get("stagger"), str):
        stagger = v.text(source, f"{key}.stagger", table["stagger"], choices=("random",))
    elif "stagger" in table:
        stagger = num("stagger")
    return JointSet(
        key=key,
        name=v.text(source, f"{key}.name", table.get("name", f"set{index + 1}")),
        joint=_joint_name(source, key, table, joints),
        dip=num("dip"),
        spacing=num("spacing", positive=True),
        offset=num("offset", 0.0),
        trace_length=trace,
        bridge_length=num("bridge_length", 0.0, non_negative=True),
        stagger=stagger,
        dip_std=num("dip_std", 0.0, non_negative=True),
        spacing_std=num("spacing_std", 0.0, non_negative=True),
        seed=v.integer(source, f"{key}.seed", table.get("seed", index), minimum=0),
    )


def _joint_line(
    source: str, key: str, index: int, table: Any, joints: set[str] | None
) -> JointLine:
    v.check_table(source, key, table, JOINT_LINE_KEYS)
    if "points" not in table:
        raise SceneError(source, f"{key}.points", "missing")
    xy = v.points(source, f"{key}.points", table["points"], minimum=2)
    if np.any(np.all(np.diff(xy, axis=0) == 0.0, axis=1)):
        raise SceneError(source, f"{key}.points", "two consecutive points are equal")
    return JointLine(
        key=key,
        name=v.text(source, f"{key}.name", table.get("name", f"line{index + 1}")),
        joint=_joint_name(source, key, table, joints),
        points=xy,
    )


def _excavation(source: str, key: str, table: Any) -> Excavation:
    v.check_table(source, key, table, EXCAVATION_KEYS)
    if "polygon" in table:
        if (EXCAVATION_KEYS - {"polygon"}) & set(table):
            raise SceneError(source, key, "give either polygon or center/radius, not both")
        return Excavation(key, v.simple_polygon(source, f"{key}.polygon", table["polygon"]))
    if "center" not in table or "radius" not in table:
        raise SceneError(source, key, "needs polygon, or center and radius")
    cx, cy = v.point(source, f"{key}.center", table["center"])
    radius = v.number(source, f"{key}.radius", table["radius"], positive=True)
    n = v.integer(source, f"{key}.segments", table.get("segments", 36), minimum=3)
    if n > MAX_CIRCLE_SEGMENTS:
        raise SceneError(source, f"{key}.segments", f"at most {MAX_CIRCLE_SEGMENTS}")
    angle = 2.0 * math.pi * np.arange(n) / n
    ring = np.column_stack([cx + radius * np.cos(angle), cy + radius * np.sin(angle)])
    return Excavation(key, shapely.Polygon(ring))


def _selector(source: str, key: str, table: Any, materials: set[str] | None) -> Selector:
    v.check_table(source, key, table, SELECTOR_KEYS)
    if not table:
        raise SceneError(source, key, f"needs one of {', '.join(sorted(SELECTOR_KEYS))}")
    polygon = touching = material = blocks = None
    sides: tuple[str, ...] = ()
    if "polygon" in table:
        polygon = v.simple_polygon(source, f"{key}.polygon", table["polygon"])
    if "touching" in table:
        touching = v.points(source, f"{key}.touching", table["touching"], minimum=2)
    if "sides" in table:
        raw_sides = v.check_list(source, f"{key}.sides", table["sides"])
        sides = tuple(
            v.text(source, f"{key}.sides[{i}]", s, choices=SIDES) for i, s in enumerate(raw_sides)
        )
    if "material" in table:
        material = v.text(source, f"{key}.material", table["material"])
        _known(source, f"{key}.material", material, materials, "material")
    if "blocks" in table:
        names = v.check_list(source, f"{key}.blocks", table["blocks"])
        blocks = tuple(v.text(source, f"{key}.blocks[{i}]", b) for i, b in enumerate(names))
    return Selector(key, polygon, touching, sides, material, blocks)


def _groups(
    source: str, table: Any, materials: set[str] | None
) -> dict[str, Selector | tuple[str, ...]]:
    if not isinstance(table, Mapping):
        raise SceneError(source, "groups", "must be a table of groups")
    groups: dict[str, Selector | tuple[str, ...]] = {}
    for name, rule in table.items():
        key = f"groups.{name}"
        if isinstance(rule, list):
            groups[name] = tuple(v.text(source, f"{key}[{i}]", b) for i, b in enumerate(rule))
        else:
            groups[name] = _selector(source, key, rule, materials)
    return groups


def _options(source: str, table: Any) -> CuttingOptions:
    v.check_table(source, "cutting", table, CUTTING_KEYS)
    area = table.get("min_block_area")
    prefix = v.text(source, "cutting.name_prefix", table.get("name_prefix", "b"))
    if not prefix or "/" in prefix:
        raise SceneError(source, "cutting.name_prefix", "must be non-empty, without '/'")
    return CuttingOptions(
        min_block_area=None
        if area is None
        else v.number(source, "cutting.min_block_area", area, non_negative=True),
        small_blocks=v.text(
            source,
            "cutting.small_blocks",
            table.get("small_blocks", "merge"),
            choices=("merge", "refuse"),
        ),
        holes=v.text(
            source, "cutting.holes", table.get("holes", "split"), choices=("split", "refuse")
        ),
        name_prefix=prefix,
    )
