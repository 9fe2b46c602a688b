"""A drawing in: the ``[drawing]`` table of a scene names a DXF file whose layers say what
is rock, what is fixed, where the joints run and what a stage excavates.

The drawing becomes the rock-mass keys it stands for (docs/rock_masses.md, "Drawings"),
which the block cutting then handles as if typed:

- closed shapes on the ``blocks`` layer (default ``BLOCKS``) are ``[[regions]]`` of the
  drawing's material: a shape no joint crosses is one block; one inside another is an
  opening in it (open at t = 0), one inside an opening rock again;
- closed shapes on the ``fixed`` layer (``FIXED``) are regions too, whose blocks are fixed
  (a ``[[fix]]`` rule ``inside`` each shape);
- lines and polylines, open or closed, on the ``joints`` layer (``JOINTS``) are
  ``[[joint_lines]]``: each cuts the rock it crosses from side to side;
- closed shapes on the ``excavation`` layer (``EXCAVATION``) cut the rock they cover into
  regions of their own, whose blocks a stage at ``excavation_time`` removes (the group
  ``excavation``).

A shape is a LINE, LWPOLYLINE or POLYLINE (arcs of bulges included), CIRCLE, ARC, ELLIPSE or
SPLINE; curves are drawn as chords within ``arc_tolerance``. Coordinates are multiplied by
``scale``. Refused, in one line naming the scene file and its ``drawing.file`` key, then the
DXF file, the layer and the entity (its DXF handle): a file ezdxf cannot read, an open
shape where a closed one is needed (open shapes that close a ring end to end, an exploded
polyline, are that ring), a layer the table names that the drawing does not
have, a drawing whose units (``$INSUNITS``) are not the scene's length unit (unless
``scale`` says how to read them; ``metre``, ``feet`` and the like are read as ``m``,
``ft``), an entity of another kind on a mapped layer, a block reference that holds one on
a mapped layer, an entity that is no shape, a material or joint that the scene
does not define, an ``excavation_time`` with nothing to excavate. Layer names are
matched in any case, as CAD matches them. A joint line of no length (a point that CAD
left) is left out, with a warning.

ezdxf, the maintained DXF reader, is imported only when a scene has a drawing.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from dda.errors import SceneError, message
from dda.scene.checks import POSITIVE, Checker, suggest
from dda.scene.rockmass.domain import overlap_said

log = logging.getLogger(__name__)

LAYERS = {"blocks": "BLOCKS", "fixed": "FIXED", "joints": "JOINTS", "excavation": "EXCAVATION"}
DRAWING_KEYS = {*LAYERS, "file", "material", "joint", "excavation_time", "scale", "arc_tolerance"}
SHAPES = ("LINE", "LWPOLYLINE", "POLYLINE", "CIRCLE", "ARC", "ELLIPSE", "SPLINE")
EXCAVATION_GROUP = "excavation"
ARC_TOLERANCE = 1e-3  # default chord tolerance of curves, as a fraction of the drawing's size
CLOSED = 1e-9  # of the drawing's size: a shape whose ends are this close is closed
# an open joint line's end within an arc tolerance of the rock's outline is drawn on by
# this many arc tolerances: one snapped to a curve ends on the curve, which the rock's
# chords leave up to an arc tolerance away (on the concave side it ended inside the
# rock, and cut nothing)
JOINT_REACH = 2.0
# $INSUNITS codes -> (name, metres); 0 is "unitless": read in the scene's unit
INSUNITS = {1: ("in", 0.0254), 2: ("ft", 0.3048), 3: ("mi", 1609.344), 4: ("mm", 1e-3),
            5: ("cm", 1e-2), 6: ("m", 1.0), 7: ("km", 1e3), 10: ("yd", 0.9144),
            14: ("dm", 0.1)}  # fmt: skip
METRES = {name: metres for name, metres in INSUNITS.values()}
# the other codes of the DXF reference: a scene's length unit is none of them, so a
# drawing in one is refused with the scale that reads it in metres
OTHER_INSUNITS = {
    8: ("microinches", 2.54e-8), 9: ("mils", 2.54e-5), 11: ("angstroms", 1e-10),
    12: ("nanometres", 1e-9), 13: ("microns", 1e-6), 15: ("decametres", 10.0),
    16: ("hectometres", 100.0), 17: ("gigametres", 1e9),
    18: ("astronomical units", 1.495978707e11), 19: ("light years", 9.4607304725808e15),
    20: ("parsecs", 3.0856775814914e16), 21: ("US survey feet", 1200.0 / 3937.0),
    22: ("US survey inches", 100.0 / 3937.0), 23: ("US survey yards", 3600.0 / 3937.0),
    24: ("US survey miles", 6336000.0 / 3937.0),
}  # fmt: skip
# other spellings of the scene's [units] length (compared in lower case)
LENGTH_NAMES = {
    "metre": "m", "metres": "m", "meter": "m", "meters": "m",
    "millimetre": "mm", "millimetres": "mm", "millimeter": "mm", "millimeters": "mm",
    "centimetre": "cm", "centimetres": "cm", "centimeter": "cm", "centimeters": "cm",
    "kilometre": "km", "kilometres": "km", "kilometer": "km", "kilometers": "km",
    "foot": "ft", "feet": "ft", "inch": "in", "inches": "in", "yard": "yd", "yards": "yd",
    "mile": "mi", "miles": "mi",
}  # fmt: skip


@dataclass(frozen=True)
class Shape:
    """One entity of the drawing as points in the scene's length unit."""

    layer: str
    what: str  # "LWPOLYLINE (handle 2F)"
    points: np.ndarray  # (k, 2); a closed shape's last point is not repeated
    closed: bool


@dataclass(frozen=True)
class Expanded:
    """A scene's drawing made rock-mass keys: the raw scene, the scene file it came from,
    and what each region it added was drawn as (``regions[i]`` ->
    ``"layer BLOCKS: LWPOLYLINE (handle 2F)"``), for messages about them."""

    raw: dict
    source: str
    path: Path
    origins: dict[int, str]

    def translated(self, exc: SceneError) -> SceneError:
        """``exc`` about a region the drawing added, said of the drawing's entities."""
        found = re.match(r"regions\[(\d+)\]", exc.key)
        if not found or int(found.group(1)) not in self.origins:
            return exc
        reason = re.sub(
            r"regions\[(\d+)\]", lambda m: self.origins.get(int(m.group(1)), m.group(0)),
            exc.reason,
        )  # fmt: skip
        drawn = SceneError(str(self.path), self.origins[int(found.group(1))], reason)
        return of_scene(drawn, self.source, self.path)


def expand_drawing(raw: Mapping[str, Any], source: str) -> Expanded:
    """The raw scene with its ``[drawing]`` replaced by the rock-mass keys it stands for
    (``regions``, ``joint_lines``, ``fix``, ``groups``, ``stages``; those the scene gives
    itself are kept, the drawing's added).

    Raises
    ------
    SceneError
        Naming the scene file and its ``drawing.file`` key, then the DXF file, the layer
        and the entity, and what is wrong (or the scene and a key of ``[drawing]``).
    """
    chk = Checker(source)
    table = chk.table(raw["drawing"], "drawing", DRAWING_KEYS)
    if "file" not in table:
        chk.fail("drawing.file", "missing: the DXF file to read (beside the scene file)")
    path = drawing_path(chk.text(table["file"], "drawing.file"), source)
    if not path.is_file():
        where = "the current folder" if source.startswith("<") else "beside the scene file"
        chk.fail("drawing.file", f"no such file {path} (a drawing is read from {where})")
    layers = _layers(chk, table)
    try:
        return _read(chk, raw, table, layers, path)
    except SceneError as exc:
        raise of_scene(exc, source, path) from None


def _read(chk: Checker, raw: Mapping, table: Mapping, layers: dict, path: Path) -> Expanded:
    """The drawing at ``path`` read into rock-mass keys (its errors name ``path``)."""
    document = read_dxf(path)
    scale = _scale(chk, table, document, raw, path)
    drawn = _entities(document, path, layers)
    size = scale * _size(drawn, path, layers["blocks"])
    tolerance = ARC_TOLERANCE * size
    if "arc_tolerance" in table:
        tolerance = chk.real(table["arc_tolerance"], "drawing.arc_tolerance", POSITIVE)
    shapes = [_flattened(*entity, scale, tolerance, size) for entity in drawn]
    return _rock_mass(chk, raw, table, layers, shapes, path, tolerance)


def of_scene(exc: SceneError, source: str, path: Path) -> SceneError:
    """``exc`` about the DXF file ``path`` said of the scene ``source`` that names it:
    ``scene.toml: drawing.file: section.dxf: layer BLOCKS: ...``; a refused key of
    ``[drawing]`` (``drawing.blocks``) stays that key; an error about the scene is kept."""
    if exc.source != str(path):
        return exc
    if exc.key.startswith("drawing."):
        return SceneError(source, exc.key, exc.reason)
    return SceneError(source, "drawing.file", message(str(path), exc.key, exc.reason))


def drawing_path(name: str, source: str) -> Path:
    """The DXF file ``name`` of a scene read from ``source``: beside the scene file, or
    from the current folder for a scene given as text or a dict."""
    path = Path(name)
    if path.is_absolute() or source.startswith("<"):
        return path
    return Path(source).parent / path


def read_dxf(path: Path) -> Any:
    """The ezdxf document of ``path``, or a SceneError saying why it cannot be read (any
    error of ezdxf's reader: a file cut short raises StopIteration, not a DXFError)."""
    import ezdxf

    if not path.is_file():
        raise SceneError(str(path), "<file>", "no such drawing file")
    try:
        return ezdxf.readfile(path)
    except Exception as exc:  # whatever stops the reader, said in one line
        detail = " ".join(str(exc).split()) or type(exc).__name__
        if isinstance(exc, StopIteration):
            detail = "it ends early"
        reason = "not a DXF drawing ezdxf can read"
        if "is not a DXF file" not in detail:  # ezdxf's own words repeat the file name
            reason = f"{reason} ({detail})"
        raise SceneError(str(path), "<file>", reason) from None


def _layers(chk: Checker, table: Mapping) -> dict[str, Any]:
    """Role -> layer name (the joints' layer may be a table of layer -> joint name);
    the roles the table names explicitly are marked as required ('!' in ``given``)."""
    layers: dict[str, Any] = {}
    for role, default in LAYERS.items():
        value = table.get(role, default)
        if role == "joints" and isinstance(value, Mapping):
            if not value:
                chk.fail("drawing.joints", "is an empty table: give a layer, or a table "
                         "{LAYER = \"joint name\", ...}")  # fmt: skip
            if "joint" in table:  # it would be ignored
                chk.fail("drawing.joint", "the joints table names each layer's joint: give "
                         "joint only with a single joints layer (joints = \"LAYER\")")  # fmt: skip
            layers[role] = {chk.text(k, "drawing.joints"): chk.text(v, f"drawing.joints.{k}")
                            for k, v in value.items()}  # fmt: skip
        else:
            layers[role] = chk.text(value, f"drawing.{role}")
    layers["given"] = {role for role in LAYERS if role in table}
    _one_role_a_layer(chk, layers)
    return layers


def _one_role_a_layer(chk: Checker, layers: dict[str, Any]) -> None:
    """Refuse a layer named for two roles (rock and fixed, say): its shapes would be both,
    and overlap themselves."""
    seen: dict[str, str] = {}
    for role in LAYERS:
        value = layers[role]
        names = list(value) if isinstance(value, Mapping) else [value]
        for name in names:
            other = seen.get(name.upper())
            if other is not None:
                key, also = (role, other) if role in layers["given"] else (other, role)
                reason = f"layer {name!r} is also drawing.{also}'s: each role needs its own"
                chk.fail(f"drawing.{key}", reason)
            seen[name.upper()] = role


def _scale(chk: Checker, table: Mapping, document: Any, raw: Mapping, path: Path) -> float:
    """``[drawing] scale``; without it the drawing's ``$INSUNITS`` must be unitless or the
    scene's length unit."""
    if "scale" in table:
        return chk.real(table["scale"], "drawing.scale", POSITIVE)
    code = int(document.header.get("$INSUNITS", 0) or 0)
    units = raw.get("units", {})
    given = units.get("length", "m") if isinstance(units, Mapping) else "m"
    length = _length_name(given)
    if code == 0:
        return 1.0
    if code not in INSUNITS:
        name, metres = OTHER_INSUNITS.get(code, (None, None))
        unit = f"in {name}" if name else "in no unit the DXF reference defines"
        hint = f" ([drawing] scale = {metres!r} reads it in m)" if name else ""
        raise SceneError(
            str(path),
            "$INSUNITS",
            f"the drawing is {unit} ($INSUNITS = {code}): give [drawing] scale, the scene's "
            f"length unit in one drawing unit{hint}, or set $INSUNITS to the scene's unit",
        )
    name, metres = INSUNITS[code]
    if length is None:
        raise SceneError(
            str(path),
            "$INSUNITS",
            f"the drawing is in {name} ($INSUNITS = {code}) and the scene's length unit "
            f"{given!r} ([units] length) is none this check knows: give [drawing] scale, "
            "the scene's length unit in one drawing unit",
        )
    if name != length:
        factor = metres / METRES[length]
        raise SceneError(
            str(path),
            "$INSUNITS",
            f"the drawing is in {name} ($INSUNITS = {code}) and the scene in {length} "
            f"([units] length): give [drawing] scale = {factor!r} to read it in {length}, "
            f"or set $INSUNITS to {length}",
        )
    return 1.0


def _length_name(given: Any) -> str | None:
    """The $INSUNITS name of the scene's length unit (``m`` for ``metre``, ``M``...),
    None for one it does not know."""
    text = str(given).strip()
    if text in METRES:
        return text
    lower = text.lower()
    return lower if lower in METRES else LENGTH_NAMES.get(lower)


def _entities(document: Any, path: Path, layers: dict[str, Any]) -> list[tuple]:
    """(layer, description, ezdxf path) of every model-space entity on a mapped layer; a
    layer the table names (or the blocks layer) must be in the drawing."""
    from ezdxf import path as dxf_path

    mapped = _mapped(layers)
    entities = list(document.modelspace())
    present = {layer.dxf.name for layer in document.layers} | {e.dxf.layer for e in entities}
    known = {name.upper() for name in present}
    for role, layer in mapped.items():
        if (role.split(":")[0] in layers["given"] or role == "blocks") and (
            layer.upper() not in known
        ):
            listed = ", ".join(sorted(present)) or "none"
            key = f"drawing.{role.split(':')[0]}"
            raise SceneError(str(path), key, f"no layer {layer!r} in the drawing {path} (its "
                             f"layers: {listed})")  # fmt: skip
    wanted = {layer.upper(): layer for layer in mapped.values()}  # CAD: names in any case
    drawn, looked = [], {}  # looked: block definitions looked into (_mapped_inside)
    for entity in entities:
        layer = wanted.get(entity.dxf.layer.upper())
        what = f"{entity.dxftype()} (handle {entity.dxf.handle})"
        if layer is None:
            _no_mapped_content(entity, what, wanted, path, looked)
            continue
        if entity.dxftype() == "POINT":  # a point CAD left behind, as a LINE of no length
            log.warning("layer %s: %s is a point: left out", layer, what)
            continue
        if entity.dxftype() not in SHAPES:
            reason = f"{what} is not a line, polyline, arc, circle, ellipse or spline"
            hint = " (explode block references)" if entity.dxftype() == "INSERT" else ""
            raise SceneError(str(path), f"layer {layer}", f"{reason}{hint}")
        try:
            outline = dxf_path.make_path(entity)
        except (TypeError, ValueError) as exc:  # a polyface mesh, a spline without points
            detail = " ".join(str(exc).split())
            raise SceneError(str(path), f"layer {layer}", f"{what} cannot be read as a "
                             f"shape ({detail})") from None  # fmt: skip
        corners = [(v.x, v.y) for v in outline.control_vertices()]
        if not np.all(np.isfinite(np.array(corners, dtype=float))):
            raise SceneError(str(path), f"layer {layer}", f"{what} has a coordinate that is "
                             "not a finite number")  # fmt: skip
        drawn.append((layer, what, outline, entity))
    return drawn


def _no_mapped_content(
    entity: Any, what: str, wanted: dict[str, str], path: Path, seen: dict
) -> None:
    """Refuse a block reference on an unmapped layer (``0``, say) that holds entities on
    a mapped one: CAD shows them on that layer, and left out they would be rock or joints
    missing without a word."""
    if entity.dxftype() != "INSERT":
        return
    inner = _mapped_inside(entity.block(), wanted, seen)
    if inner is not None:
        kind, layer = inner
        raise SceneError(
            str(path),
            f"layer {layer}",
            f"{what} on layer {entity.dxf.layer!r} holds a {kind} on layer {layer!r}: "
            "explode block references (the reader takes model-space entities only)",
        )


def _mapped_inside(block: Any, wanted: dict[str, str], seen: dict) -> tuple[str, str] | None:
    """(kind, layer) of an entity on a mapped layer in ``block`` or the blocks it
    references, None if none; each block definition looked into once (``seen``, by name:
    references that fan out do not multiply the work, one to itself ends)."""
    if block is None or block.name in seen:
        return seen.get(getattr(block, "name", None))
    seen[block.name] = None
    for inner in block:
        layer = wanted.get(inner.dxf.layer.upper())
        found = (inner.dxftype(), layer) if layer is not None else None
        if found is None and inner.dxftype() == "INSERT":
            found = _mapped_inside(inner.block(), wanted, seen)
        if found is not None:
            seen[block.name] = found
            return found
    return None


def _mapped(layers: dict[str, Any]) -> dict[str, str]:
    """Role -> layer, with one role ``joints:LAYER`` per layer of a joints table."""
    mapped = {role: layers[role] for role in LAYERS if role != "joints"}
    joints = layers["joints"]
    if isinstance(joints, Mapping):
        mapped.update({f"joints:{layer}": layer for layer in joints})
    else:
        mapped["joints"] = joints
    return mapped


def _size(drawn: list[tuple], path: Path, blocks_layer: str) -> float:
    """The diagonal of the blocks layer's extent, in drawing units (the length scale of
    tolerances)."""
    corners = []
    for layer, _, geometry, _ in drawn:
        box = geometry.bbox()
        if layer == blocks_layer and box.has_data:
            corners += [(box.extmin.x, box.extmin.y), (box.extmax.x, box.extmax.y)]
    if not corners:
        raise SceneError(str(path), f"layer {blocks_layer}", "holds no shape: draw the rock "
                         "as closed polylines on it")  # fmt: skip
    return float(np.hypot(*np.ptp(np.array(corners), axis=0))) or 1.0


def _flattened(
    layer: str,
    what: str,
    geometry: Any,
    entity: Any,
    scale: float,
    tolerance: float,
    size: float,
) -> Shape:
    """An entity's points in the scene's unit (curves as chords within ``tolerance``:
    :func:`_curve_points`), without repeated points; closed when its ends meet."""
    points = _curve_points(geometry, entity, tolerance / scale, size / scale) * scale
    points = points.reshape(-1, 2)
    keep = np.ones(len(points), bool)
    keep[1:] = np.any(np.abs(np.diff(points, axis=0)) > CLOSED * size, axis=1)
    points = points[keep]
    # ends that meet close a shape of three points or more (two: a closed polyline
    # of one segment, refused as having no area)
    closed = len(points) >= 3 and bool(np.all(np.abs(points[0] - points[-1]) <= CLOSED * size))
    return Shape(layer, what, points[:-1] if closed else points, closed)


def _curve_points(geometry: Any, entity: Any, tolerance: float, size: float) -> np.ndarray:
    """(k, 2) points of an entity within ``tolerance`` of the curve it draws (drawing
    units; ``size``: the drawing's extent). A spline is flattened from its own B-spline,
    every point on the curve. Arcs (circles, ellipses, bulges) go through ezdxf's cubic
    Béziers, which leave a quarter circle by up to 2.7e-4 R, and (θ / 90°)⁶ times that an
    arc of θ: each arc is split into at least :func:`_arc_pieces` Béziers, so that they
    stay within a tenth of the tolerance for any radius up to the drawing's size, and
    chords within nine tenths of it are drawn on them (ezdxf splits a polyline's bulge
    into a third as many pieces as it is asked for, an ellipse into as many: asked for
    three times :func:`_arc_pieces`, each gets at least that many)."""
    from ezdxf import path as dxf_path

    if entity.dxftype() == "SPLINE":
        curve = entity.construction_tool().flattening(tolerance, segments=1)
    else:
        box = geometry.bbox()
        extent = float(np.hypot(*(box.extmax - box.extmin).vec2)) if box.has_data else 0.0
        pieces = _arc_pieces(tolerance, max(size, extent))
        outline = dxf_path.make_path(entity, segments=3 * pieces)
        curve = outline.flattening(0.9 * tolerance, segments=1)
    return np.array([(v.x, v.y) for v in curve], dtype=float).reshape(-1, 2)


def _arc_pieces(tolerance: float, radius: float) -> int:
    """Béziers a full circle of ``radius`` needs to stay within ``tolerance`` / 10 of it:
    the error of one of angle θ is about 2.7e-4 R (θ / (π/2))⁶, so n ≥ 4 (2.7e-3 R / tol)^(1/6)."""
    return max(4, int(np.ceil(4.0 * (2.7e-3 * radius / tolerance) ** (1.0 / 6.0))))


def _rock_mass(
    chk: Checker,
    raw: Mapping,
    table: Mapping,
    layers: dict,
    shapes: list[Shape],
    path: Path,
    tolerance: float,
) -> Expanded:
    """The raw scene with the drawing's regions, joint lines, fixed rules, groups, stage."""
    rock = _closed(shapes, layers["blocks"], path)
    fixed = _closed(shapes, layers["fixed"], path)
    holes = _closed(shapes, layers["excavation"], path)
    out = {k: v for k, v in raw.items() if k != "drawing"}
    material = _material(chk, table, raw)
    dug = shapely.union_all([_polygon(s, path) for s in holes]) if holes else None
    regions, origins = list(_list(raw, "regions")), {}
    openings, open_in = _openings(rock, path)
    for k, shape in enumerate(rock + fixed):
        if k in openings:
            continue  # an opening: no rock of its own
        for region in _regions(shape, dug, material, path, open_in.get(k)):
            origins[len(regions)] = f"layer {shape.layer}: {shape.what}"
            regions.append(region)
    out["regions"] = regions
    _check_joint_names(chk, table, layers, raw)
    outline = shapely.union_all([shapely.boundary(_polygon(s, path)) for s in rock + fixed + holes])
    drawn = _joint_lines(chk, table, layers, shapes, outline, tolerance)
    out["joint_lines"] = [*_list(raw, "joint_lines"), *drawn]
    if fixed:
        out["fix"] = [*_list(raw, "fix"), *({"inside": s.points.tolist()} for s in fixed)]
    if holes:
        _check_holes_remove_rock(holes, rock, fixed, openings, path)
        out.update(_excavation(chk, raw, table, holes))
    elif "excavation_time" in table:
        chk.fail("drawing.excavation_time", f"the drawing has no closed shape on layer "
                 f"{layers['excavation']!r} to excavate")  # fmt: skip
    return Expanded(out, chk.source, path, origins)


def _closed(shapes: list[Shape], layer: str, path: Path) -> list[Shape]:
    """The shapes of ``layer``, each closed: its closed shapes, and the rings that its open
    ones close end to end (an exploded polyline: LINEs and ARCs, :func:`_rings`); an open
    shape that closes no ring is refused."""
    found = [s for s in shapes if s.layer == layer]
    for shape in found:
        if len(shape.points) < (3 if shape.closed else 2):
            raise SceneError(str(path), f"layer {layer}", f"{shape.what} has no area (a point, "
                             "or a circle of radius 0): remove it")  # fmt: skip
    opened = [s for s in found if not s.closed]
    rings, left = _rings(opened, layer)
    if left:
        raise SceneError(str(path), f"layer {layer}", _open_reason(left, opened))
    return [s for s in found if s.closed] + rings


def _open_reason(left: list[Shape], opened: list[Shape]) -> str:
    """Why the open shapes ``left`` close no ring: a loose end of their chains (an end
    no other open shape of the layer meets, within :data:`CLOSED` of their extent) and
    the nearest other loose end, with the gap between them; else the first shape."""
    points = np.concatenate([s.points for s in opened])
    grid = CLOSED * float(np.ptp(points, axis=0).max() or 1.0)
    ends = [(s, s.points[k]) for s in left for k in (0, -1)]
    cells = [tuple(np.round(np.asarray(p) / grid).astype(np.int64)) for _, p in ends]
    loose = [e for e, c in zip(ends, cells, strict=True) if cells.count(c) == 1]
    note = ": a block or an excavation is a closed polyline"
    overlap = _overlapping_pair(left)
    if overlap is not None:
        one, other, length = overlap
        return (f"{one.what} overlaps {other.what} along {length:.3g} of their length: "
                f"draw them end to end{note}")  # fmt: skip
    if len(loose) < 2:
        shape = left[0]
        (x0, y0), (x1, y1) = shape.points[0], shape.points[-1]
        return (f"{shape.what} is open (from ({x0:.6g}, {y0:.6g}) to ({x1:.6g}, {y1:.6g})) "
                f"and closes no ring with the layer's other open shapes{note}")  # fmt: skip
    (shape, end), others = loose[0], loose[1:]
    gaps = [float(np.hypot(*(np.asarray(p) - end))) for _, p in others]
    (other, near), gap = others[int(np.argmin(gaps))], min(gaps)
    if other is shape:
        return (f"{shape.what} is open: its ends ({end[0]:.6g}, {end[1]:.6g}) and "
                f"({near[0]:.6g}, {near[1]:.6g}) are {gap:.3g} apart{note}")  # fmt: skip
    return (f"{shape.what} has a loose end at ({end[0]:.6g}, {end[1]:.6g}), which no "
            "other shape of "
            f"the layer meets; the nearest loose end is {other.what}'s at ({near[0]:.6g}, "
            f"{near[1]:.6g}), {gap:.3g} away: join them{note}")  # fmt: skip


def _overlapping_pair(shapes: list[Shape]) -> tuple[Shape, Shape, float] | None:
    """Two open shapes that lie along each other over a length (collinear pieces drawn
    over one another), and that length; None where none do."""
    lines = [shapely.LineString(s.points) for s in shapes]
    tree = shapely.STRtree(lines)
    for i, j in zip(*tree.query(lines, predicate="intersects"), strict=True):
        if i < j:
            common = shapely.intersection(lines[i], lines[j])
            if common.length > 0.0:
                return shapes[int(i)], shapes[int(j)], float(common.length)
    return None


def _rings(shapes: list[Shape], layer: str) -> tuple[list[Shape], list[Shape]]:
    """(the closed rings that ``shapes``, all open, make end to end, each named by its
    pieces; the shapes no ring takes). Ends within :data:`CLOSED` of the shapes' extent
    meet (their coordinates put on a grid that fine, then ``shapely.polygonize``)."""
    if not shapes:
        return [], []
    points = np.concatenate([s.points for s in shapes])
    grid = CLOSED * float(np.ptp(points, axis=0).max() or 1.0)
    lines = shapely.set_precision(
        np.array([shapely.LineString(s.points) for s in shapes], dtype=object), grid
    )
    # a shape drawn twice (a CAD leftover) is one: polygonize closes no ring through a
    # doubled edge, so each copy after the first is left out of it and taken with it
    first = {}
    for k, line in enumerate(lines):
        first.setdefault(shapely.normalize(line).wkb, k)
    single = np.array(sorted(first.values()), dtype=np.int64)
    polygons = shapely.get_parts(shapely.polygonize(lines[single]))
    rings, used = [], np.zeros(len(shapes), bool)
    for polygon in polygons:
        edge = polygon.exterior
        pieces = np.flatnonzero(shapely.covered_by(lines, shapely.buffer(edge, grid)))
        used[pieces] = True
        what = " + ".join(shapes[k].what for k in pieces)
        rings.append(Shape(layer, what, np.asarray(edge.coords)[:-1], True))
    return rings, [s for s, taken in zip(shapes, used, strict=True) if not taken]


AREA_SHARE = 1e-9  # an excavation sharing less of its area with the rock removes nothing


def _polygon(shape: Shape, path: Path) -> shapely.Polygon:
    """A closed shape as a polygon; a shape that crosses itself is refused."""
    polygon = shapely.Polygon(shape.points)
    if not polygon.is_valid or polygon.area <= 0.0:
        raise SceneError(str(path), f"layer {shape.layer}", f"{shape.what} is not a simple "
                         f"closed shape ({shapely.is_valid_reason(polygon)})")  # fmt: skip
    return polygon


def _openings(rock: list[Shape], path: Path) -> tuple[set[int], dict[int, Any]]:
    """The nesting of the blocks layer's closed shapes, as CAD's hatch islands: a shape
    inside an odd number of others is an opening in the one just around it (open at
    t = 0), one inside an even number is rock (an island in an opening). Returns (the
    openings' indices, the union of its openings by the index of a shape that has some)."""
    polygons = [_polygon(s, path) for s in rock]
    if len(polygons) < 2:
        return set(), {}
    tree = shapely.STRtree(polygons)
    one, other = tree.query(polygons, predicate="overlaps")  # crossing: no nesting
    if len(one):
        i, j = int(other[0]), int(one[0])
        raise SceneError(
            str(path),
            f"layer {rock[i].layer}",
            f"{rock[i].what} crosses {rock[j].what} by {overlap_said(polygons[i], polygons[j])}"
            ": closed shapes on the blocks layer do not cross (one inside another is an "
            "opening in it)",
        )
    # outer ⊇ inner, a shape that touches the one around it from inside too (an island on
    # its opening's floor, a notch in the outline: contains_properly left them out)
    outer, inner = tree.query(polygons, predicate="covers")
    itself = outer == inner
    outer, inner = outer[~itself], inner[~itself]
    pairs = set(zip(outer.tolist(), inner.tolist(), strict=True))
    twin = next(((i, j) for i, j in pairs if (j, i) in pairs), None)
    if twin is not None:
        i, j = twin
        raise SceneError(
            str(path),
            f"layer {rock[i].layer}",
            f"{rock[max(i, j)].what} is drawn again as {rock[min(i, j)].what} (the same "
            "closed shape twice): delete one",
        )
    depth = np.bincount(inner, minlength=len(polygons))
    openings = {int(k) for k in np.flatnonzero(depth % 2 == 1)}
    holes: dict[int, Any] = {}
    for k in openings:
        parents = outer[inner == k]
        parent = int(parents[np.argmax(depth[parents])])  # the one just around it
        holes[parent] = shapely.union(holes.get(parent, shapely.Polygon()), polygons[k])
    return openings, holes


def _regions(shape: Shape, dug: Any, material: str, path: Path, openings: Any = None) -> list[dict]:
    """The ``[[regions]]`` of one closed shape, less its ``openings``: the rock outside the
    excavations, and (a region of its own, to be removed) the rock inside them."""
    polygon = _polygon(shape, path)
    if openings is not None:
        polygon = polygon.difference(openings)
    pieces = [polygon] if dug is None else [polygon.difference(dug), polygon.intersection(dug)]
    regions = []
    for piece in pieces:
        for part in shapely.get_parts(piece):
            if isinstance(part, shapely.Polygon) and part.area > 0.0:
                regions.append({
                    "polygon": _ring(part.exterior),
                    "holes": [_ring(ring) for ring in part.interiors],
                    "material": material,
                })  # fmt: skip
    return regions


def _ring(ring: Any) -> list[list[float]]:
    return np.asarray(ring.coords)[:-1].tolist()


def _joint_lines(
    chk: Checker,
    table: Mapping,
    layers: dict,
    shapes: list[Shape],
    outline: Any,
    tolerance: float,
) -> list[dict]:
    """A ``[[joint_lines]]`` entry per shape on a joints layer (a closed one back to its
    start; an open one's ends within ``tolerance`` of the rock's ``outline`` drawn on by
    :data:`JOINT_REACH` tolerances); its joint: :func:`_layer_joints`."""
    joints = _layer_joints(chk, table, layers)
    lines = []
    for shape in shapes:
        if shape.layer not in joints:
            continue
        if len(shape.points) < 2:  # a CAD leftover: a point
            log.warning("layer %s: %s has no length: left out", shape.layer, shape.what)
            continue
        points = (
            _drawn_on(shape.points, outline, tolerance)
            if not shape.closed
            else np.vstack([shape.points, shape.points[:1]])
        )
        entry = {"points": points.tolist(), "name": shape.layer}
        joint = joints[shape.layer][1]
        if joint:
            entry["joint"] = joint
        lines.append(entry)
    return lines


def _layer_joints(chk: Checker, table: Mapping, layers: dict) -> dict[str, tuple[str, str]]:
    """Joints layer -> (the ``[drawing]`` key that names its joint, the joint its lines
    take: the table's ``joint``, or the joint a joints table maps the layer to; "" for the
    default)."""
    joints = layers["joints"]
    if isinstance(joints, Mapping):
        return {layer: (f"drawing.joints.{layer}", joint) for layer, joint in joints.items()}
    return {joints: ("drawing.joint", chk.text(table.get("joint", ""), "drawing.joint"))}


def _check_joint_names(chk: Checker, table: Mapping, layers: dict, raw: Mapping) -> None:
    """Refuse a joint the drawing's lines would name (:func:`_layer_joints`) that
    ``[joints]`` does not define, under its own key."""
    defined = raw.get("joints", {})
    if not isinstance(defined, Mapping):
        return  # checked with the scene
    for key, joint in _layer_joints(chk, table, layers).values():
        if joint and joint != "default" and joint not in defined:
            chk.fail(key, f"unknown joint {joint!r}: {suggest(str(joint), list(defined))}")


def _drawn_on(points: np.ndarray, outline: Any, tolerance: float) -> np.ndarray:
    """``points`` with each end that lies within ``tolerance`` of ``outline`` (on a curved
    boundary, the rock's chords are up to that far) moved on by :data:`JOINT_REACH`
    tolerances along its end segment: it then crosses the chord. An end farther from the
    outline (a joint that stops short of it, by design) stays."""
    out = np.array(points, float)
    for end, inner in ((0, 1), (-1, -2)):
        step = out[end] - out[inner]
        length = float(np.hypot(*step))
        near = shapely.distance(shapely.Point(out[end]), outline) <= tolerance
        if length > 0.0 and near:
            out[end] = out[end] + JOINT_REACH * tolerance * step / length
    return out


def _material(chk: Checker, table: Mapping, raw: Mapping) -> str:
    """``[drawing] material``, or the scene's only material."""
    if "material" in table:
        name = chk.text(table["material"], "drawing.material")
        defined = raw.get("materials", {})
        if isinstance(defined, Mapping) and name not in defined:
            chk.fail(
                "drawing.material", f"unknown material {name!r}: {suggest(name, list(defined))}"
            )
        return name
    materials = raw.get("materials", {})
    if isinstance(materials, Mapping) and len(materials) == 1:
        return next(iter(materials))
    chk.fail("drawing.material", "missing: which [materials.NAME] the drawn rock is of")


def _check_holes_remove_rock(
    holes: list[Shape], rock: list[Shape], fixed: list[Shape], openings: set[int], path: Path
) -> None:
    """Refuse a shape on the excavation layer that lies outside the rock or in one of its
    openings: it would remove nothing (it was refused as ``groups.excavation: selects no
    block``, a key the user never wrote, naming no entity)."""
    solid = [_polygon(s, path) for k, s in enumerate(rock) if k not in openings]
    solid += [_polygon(s, path) for s in fixed]
    hollow = [_polygon(rock[k], path) for k in openings]
    mass = shapely.difference(shapely.union_all(solid), shapely.union_all(hollow))
    for shape in holes:
        polygon = _polygon(shape, path)
        if shapely.intersection(polygon, mass).area <= AREA_SHARE * polygon.area:
            raise SceneError(str(path), f"layer {shape.layer}", f"{shape.what} lies outside "
                             "the rock or in one of its openings: it removes nothing")  # fmt: skip


def _excavation(chk: Checker, raw: Mapping, table: Mapping, holes: list[Shape]) -> dict:
    """The groups of the excavated blocks (``excavation``; ``excavation_1``, ... for
    several shapes) and the stage that removes them."""
    if "excavation_time" not in table:
        chk.fail("drawing.excavation_time", f"missing: the drawing has {len(holes)} shape(s) "
                 "to excavate; give the time of the stage that removes them")  # fmt: skip
    time = chk.real(table["excavation_time"], "drawing.excavation_time", POSITIVE)
    names = [EXCAVATION_GROUP] if len(holes) == 1 else [
        f"{EXCAVATION_GROUP}_{k}" for k in range(1, len(holes) + 1)
    ]  # fmt: skip
    groups = raw.get("groups", {})
    groups = dict(groups) if isinstance(groups, Mapping) else groups
    if isinstance(groups, dict):
        for name, shape in zip(names, holes, strict=True):
            if name in groups:
                chk.fail(f"groups.{name}", "is the drawing's excavation: name your group otherwise")
            groups[name] = {"inside": shape.points.tolist()}
    stages = [*_list(raw, "stages"), {"time": time, "remove": names}]
    stages.sort(key=lambda s: s.get("time", 0.0) if isinstance(s, Mapping) else 0.0)
    return {"groups": groups, "stages": stages}


def _list(raw: Mapping, key: str) -> list:
    value = raw.get(key, [])
    return list(value) if isinstance(value, list) else value
