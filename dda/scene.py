"""Scene: the immutable, validated description of one analysis.

``load_scene`` accepts a path to a TOML file, TOML text or a plain dict and
returns a frozen :class:`Scene`. Every problem raises :class:`SceneError`
naming the source, the key (a dotted path such as ``blocks[2].vertices``)
and the reason; nothing runs for a refused scene.

Validation runs in three layers:

1. every table is checked for unknown keys (with a "did you mean" hint),
   every value for its type, finiteness and physical range;
2. names are resolved (materials, joints, blocks of loads and interfaces);
3. block geometry is checked for all blocks at once with shapely: simple
   polygons of non-zero area and at most ``MAX_BLOCK_VERTICES`` vertices,
   stored counter-clockwise, fixed points and load points on their block,
   and no overlap at the start (an STRtree query, never all pairs); at least
   one block free to move, and no velocity or load on a fixed block.

The run-size limits (``analysis.max_steps``) are checked when a run starts
(:mod:`dda.limits`), after command-line overrides.
"""

from __future__ import annotations

import difflib
import logging
import math
import numbers
import reprlib
import tomllib
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple, NoReturn

import numpy as np
import shapely

from dda.errors import SceneError
from dda.geometry import next_vertex_index
from dda.limits import DEFAULT_MAX_STEPS

logger = logging.getLogger(__name__)

Point = tuple[float, float]

# contact keys number a block's vertices in 10 bits and blocks in 20 (dda.contact.contact_set)
MAX_BLOCK_VERTICES = (1 << 10) - 1
MAX_BLOCKS = 1 << 19  # half the ids: the other half is for fracture fragments


@dataclass(frozen=True)
class Analysis:
    """``[analysis]``: time stepping and global settings."""

    mode: str = "dynamic"  # "dynamic" | "static"
    time_step: float = 1e-3  # maximum time step
    duration: float | None = None  # simulated time, or ...
    steps: int | None = None  # ... a number of steps (one of the two; default 1 s)
    gravity: Point = (0.0, 0.0)
    plane: str = "stress"  # "stress" | "strain"
    rotation: str = "exact"  # "exact" | "linear"
    max_displacement_ratio: float = 0.01  # g2, of the model half-size
    save_every: int = 10
    fixed_point_penalty: float | None = None  # default: 100 x largest Young's modulus
    accuracy: str | None = None  # "fast" | "balanced" | "precise"; None: engine default
    max_steps: int = DEFAULT_MAX_STEPS  # refuse (and stop) runs longer than this (dda.limits)
    checkpoint_every: int | None = None  # steps between checkpoints (dda run writes them)


@dataclass(frozen=True)
class ContactSettings:
    """``[contact]``: contact method and its numbers."""

    method: str = "augmented-lagrangian"  # | "penalty"
    penalty: float | None = None  # default: 10 x largest Young's modulus
    tolerance: float | None = None  # AL: largest penetration; default 1e-4 x model size
    max_iterations: int = 50
    shear_ratio: float = 0.4  # shear penalty / normal penalty
    state_band: float | None = None  # evidence for a state change, x model size; default 1e-9


@dataclass(frozen=True)
class Material:
    """``[materials.NAME]``. Strength keys (all three) make it breakable."""

    name: str
    density: float
    young: float
    poisson: float
    cohesion: float | None = None
    friction_angle: float | None = None  # degrees
    tensile_strength: float | None = None

    @property
    def breakable(self) -> bool:
        return self.cohesion is not None and self.friction_angle is not None


@dataclass(frozen=True)
class Joint:
    """``[joints.NAME]``: Coulomb joint properties (angle in degrees)."""

    name: str
    friction_angle: float = 0.0
    cohesion: float = 0.0
    tensile_strength: float = 0.0


@dataclass(frozen=True)
class Block:
    """``[[blocks]]``: one block; vertices counter-clockwise after loading."""

    name: str
    material: str
    vertices: tuple[Point, ...]
    fixed: bool = False
    fixed_points: tuple[Point, ...] = ()
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    stress: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # joint name of each edge (edge k runs from vertex k to k+1), None = default
    edge_joints: tuple[str | None, ...] | None = None


@dataclass(frozen=True)
class Load:
    """``[[loads]]``: a point load on a block, optionally scaled by a history."""

    block: str
    point: Point
    force: Point
    history: tuple[Point, ...] | None = None  # (time, factor) pairs, time increasing


@dataclass(frozen=True)
class Interface:
    """``[[interfaces]]``: the joint used between two named blocks."""

    blocks: tuple[str, str]
    joint: str


@dataclass(frozen=True)
class FractureSettings:
    """``[fracture]``: joint given to new cracks, smallest fragment kept."""

    joint: str | None = None
    min_area: float | None = None  # default: 1e-3 of the smallest breakable block


def _empty_mapping() -> Mapping[str, tuple[str, ...]]:
    return MappingProxyType({})


@dataclass(frozen=True)
class Scene:
    """A validated scene. Mappings are read-only; sequences are tuples."""

    title: str
    analysis: Analysis
    contact: ContactSettings
    materials: Mapping[str, Material]
    joints: Mapping[str, Joint]
    blocks: tuple[Block, ...]
    loads: tuple[Load, ...] = ()
    interfaces: tuple[Interface, ...] = ()
    fracture: FractureSettings = field(default_factory=FractureSettings)
    source: str = "<dict>"
    # named sets of blocks (rock-mass scenes): group name -> block names
    groups: Mapping[str, tuple[str, ...]] = field(default_factory=_empty_mapping)

    @property
    def block_names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.blocks)


# --------------------------------------------------------------------------- entry


def load_scene(scene: str | Path | Mapping[str, Any]) -> Scene:
    """Load and validate a scene.

    Parameters
    ----------
    scene
        A :class:`pathlib.Path`, a ``str`` ending in ``.toml`` without a
        newline (a path), other TOML text, or a dict of the same structure.

    Returns
    -------
    Scene
        The frozen, validated scene; block vertices counter-clockwise.

    Raises
    ------
    SceneError
        For a missing file (key ``<file>``), bad TOML (key ``<toml>``) or any
        invalid entry (a dotted key such as ``materials.rock.poisson``).
    """
    raw, source = _read_raw(scene)
    return _build_scene(raw, source)


def _is_path(scene: object) -> bool:
    if isinstance(scene, Path):
        return True
    return isinstance(scene, str) and "\n" not in scene and scene.endswith(".toml")


def _read_raw(scene: str | Path | Mapping[str, Any]) -> tuple[Mapping[str, Any], str]:
    """The raw nested mapping of a scene and its source name."""
    if isinstance(scene, Mapping):
        return scene, "<dict>"
    if _is_path(scene):
        return _read_file(Path(scene)), str(scene)
    if isinstance(scene, str):
        return _parse_toml(scene, "<text>"), "<text>"
    raise SceneError(
        f"<{type(scene).__name__}>",
        "<scene>",
        f"expected a path, TOML text or a dict, got {_kind(scene)}",
    )


def _read_file(path: Path) -> dict[str, Any]:
    if path.is_dir():
        raise SceneError(str(path), "<file>", "is a directory, not a scene file")
    if not path.is_file():
        raise SceneError(str(path), "<file>", "no such file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(str(path), "<file>", f"cannot read: {exc}") from None
    return _parse_toml(text, str(path))


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(source, "<toml>", str(exc)) from None


# --------------------------------------------------------------------------- values


class _Interval(NamedTuple):
    """A range of allowed real values, for checks and messages."""

    low: float = -math.inf
    high: float = math.inf
    low_closed: bool = False
    high_closed: bool = False

    def holds(self, x: float) -> bool:
        above = x >= self.low if self.low_closed else x > self.low
        below = x <= self.high if self.high_closed else x < self.high
        return above and below

    def describe(self) -> str:
        if self.high == math.inf:
            return f"{'>=' if self.low_closed else '>'} {self.low:g}"
        left = "[" if self.low_closed else "("
        right = "]" if self.high_closed else ")"
        return f"in {left}{self.low:g}, {self.high:g}{right}"


_ANY = _Interval()
# positions (block vertices, fixed points, load points) beyond this are refused: they
# leave no precision for contacts, and squares of them overflow in the geometry checks
MAX_COORDINATE = 1e15
_POSITIVE = _Interval(0.0)
_NON_NEGATIVE = _Interval(0.0, low_closed=True)
_POISSON = _Interval(-1.0, 0.5)
_ANGLE = _Interval(0.0, 90.0, low_closed=True)
_OPEN_UNIT = _Interval(0.0, 1.0)

_KINDS = {
    bool: "a boolean",
    np.bool_: "a boolean",
    str: "a string",
    Mapping: "a table",
    list: "a list",
    tuple: "a list",
}


def _kind(value: object) -> str:
    """Plain-words type of a value for messages."""
    for cls, words in _KINDS.items():
        if isinstance(value, cls):
            return words
    if isinstance(value, numbers.Number):
        return f"the number {reprlib.repr(value)}"
    return f"a {type(value).__name__}"


def _plain_points(items: Sequence[Any]) -> tuple[Point, ...] | None:
    """Fast path: pairs of plain finite floats or ints, else None (check in detail)."""
    plain = (float, int)
    for p in items:
        if type(p) not in (list, tuple) or len(p) != 2:
            return None
        if type(p[0]) not in plain or type(p[1]) not in plain:
            return None
    try:
        array = np.array(items, dtype=float).reshape(-1, 2)
    except OverflowError:
        return None
    if not np.isfinite(array).all():
        return None
    return tuple(map(tuple, array.tolist()))


def _join(prefix: str, name: object) -> str:
    """Dotted key of ``name`` inside the table at ``prefix``."""
    text = str(name) if name != "" else '""'
    return f"{prefix}.{text}" if prefix else text


def _suggest(word: str, options: Collection[str]) -> str:
    """A "did you mean" hint for a near miss, or the list of options."""
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    if close:
        return f"did you mean {close[0]!r}?"
    if len(options) <= 12:
        return "expected one of " + ", ".join(repr(o) for o in sorted(options))
    return "no similar name"


@dataclass(frozen=True)
class _Checker:
    """Type and range checks of raw values; every failure is a SceneError."""

    source: str

    def fail(self, key: str, reason: str) -> NoReturn:
        raise SceneError(self.source, key, reason)

    def table(self, value: object, key: str, allowed: Collection[str]) -> Mapping[str, Any]:
        """A mapping whose keys are all in ``allowed``."""
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {_kind(value)}")
        for name in value:
            if name not in allowed:
                self.fail(_join(key, name), "unknown key; " + _suggest(str(name), allowed))
        return value

    def named_tables(self, value: object, key: str) -> Mapping[str, Any]:
        """A mapping of user-chosen, non-empty string names."""
        if not isinstance(value, Mapping):
            self.fail(key, f"expected a table, got {_kind(value)}")
        for name in value:
            if not isinstance(name, str) or not name:
                self.fail(_join(key, name), "names must be non-empty strings")
        return value

    def sequence(self, value: object, key: str) -> Sequence[Any]:
        """A list (or tuple, or 1-D+ numpy array)."""
        if isinstance(value, list | tuple):
            return value
        if isinstance(value, np.ndarray) and value.ndim >= 1:
            return value
        self.fail(key, f"expected a list, got {_kind(value)}")

    def real(self, value: object, key: str, interval: _Interval = _ANY) -> float:
        """A finite real number (not a boolean) inside ``interval``."""
        if type(value) is not float:
            if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
                self.fail(key, f"expected a number, got {_kind(value)}")
            try:
                value = float(value)
            except OverflowError:
                self.fail(key, "number too large")
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        if not interval.holds(value):
            self.fail(key, f"must be {interval.describe()}, got {value:g}")
        return value

    def count(self, value: object, key: str) -> int:
        """A positive integer (not a boolean, not a float)."""
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
            self.fail(key, f"expected a positive integer, got {_kind(value)}")
        if value < 1:
            self.fail(key, f"must be a positive integer, got {value}")
        return int(value)

    def boolean(self, value: object, key: str) -> bool:
        if not isinstance(value, bool | np.bool_):
            self.fail(key, f"expected true or false, got {_kind(value)}")
        return bool(value)

    def text(self, value: object, key: str) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_kind(value)}")
        return value

    def choice(self, value: object, key: str, options: tuple[str, ...]) -> str:
        """One of ``options``, with a near-miss hint otherwise."""
        word = self.text(value, key)
        if word not in options:
            self.fail(key, f"unknown value {word!r}; " + _suggest(word, options))
        return word

    def vector(self, value: object, key: str, size: int) -> tuple[float, ...]:
        """A list of exactly ``size`` finite numbers."""
        items = self.sequence(value, key)
        if len(items) != size:
            self.fail(key, f"expected {size} numbers, got {len(items)}")
        return tuple(self.real(x, f"{key}[{k}]") for k, x in enumerate(items))

    def points(self, value: object, key: str, min_count: int = 0) -> tuple[Point, ...]:
        """A list of [x, y] pairs, at least ``min_count`` of them."""
        items = self.sequence(value, key)
        if len(items) < min_count:
            self.fail(key, f"expected at least {min_count} pairs, got {len(items)}")
        plain = _plain_points(items)
        if plain is not None:
            return plain
        return tuple(self.vector(p, f"{key}[{k}]", 2) for k, p in enumerate(items))

    def positions(self, value: object, key: str, min_count: int = 0) -> tuple[Point, ...]:
        """:meth:`points` within ±``MAX_COORDINATE``."""
        pairs = self.points(value, key, min_count)
        for k, pair in enumerate(pairs):
            self.bounded(pair, f"{key}[{k}]")
        return pairs

    def position(self, value: object, key: str) -> tuple[float, ...]:
        """One [x, y] within ±``MAX_COORDINATE``."""
        return self.bounded(self.vector(value, key, 2), key)

    def bounded(self, pair: tuple[float, ...], key: str) -> tuple[float, ...]:
        """``pair`` itself, refused when a coordinate lies beyond ±``MAX_COORDINATE``."""
        if max(abs(pair[0]), abs(pair[1])) > MAX_COORDINATE:
            self.fail(
                key,
                f"{list(pair)} lies beyond ±{MAX_COORDINATE:g}: a model this large keeps no "
                "precision for its contacts (use a length unit that fits)",
            )
        return pair

    def known(self, value: object, key: str, names: Collection[str], what: str) -> str:
        """The name of an existing ``what`` (material, joint, block)."""
        name = self.text(value, key)
        if name not in names:
            self.fail(key, f"unknown {what} {name!r}; " + _suggest(name, names))
        return name


_Spec = Callable[[_Checker, Any, str], Any]


def _real(interval: _Interval = _ANY) -> _Spec:
    return partial(_Checker.real, interval=interval)


def _choice(*options: str) -> _Spec:
    return partial(_Checker.choice, options=options)


def _vector(size: int) -> _Spec:
    return partial(_Checker.vector, size=size)


def _fields(chk: _Checker, value: object, key: str, specs: Mapping[str, _Spec]) -> dict:
    """Check a table against per-key specs; return the converted values given."""
    table = chk.table(value, key, specs)
    return {name: specs[name](chk, item, _join(key, name)) for name, item in table.items()}


def _require(chk: _Checker, values: Mapping[str, Any], key: str, names: Sequence[str]) -> None:
    for name in names:
        if name not in values:
            chk.fail(_join(key, name), "is required")


def _table_list(chk: _Checker, raw: Mapping[str, Any], key: str) -> Sequence[Any]:
    """An optional array of tables (``[[blocks]]`` etc.), empty when absent."""
    return chk.sequence(raw.get(key, []), key)


# --------------------------------------------------------------------------- sections

_ROCK_MASS_KEYS = ("regions", "joint_sets", "joint_lines", "excavations")
_TOP_KEYS = (
    "title",
    "analysis",
    "contact",
    "materials",
    "joints",
    "fracture",
    "blocks",
    "loads",
    "interfaces",
    *_ROCK_MASS_KEYS,
    "groups",
)

_ANALYSIS: dict[str, _Spec] = {
    "mode": _choice("dynamic", "static"),
    "time_step": _real(_POSITIVE),
    "duration": _real(_POSITIVE),
    "steps": _Checker.count,
    "gravity": _vector(2),
    "plane": _choice("stress", "strain"),
    "rotation": _choice("exact", "linear"),
    "max_displacement_ratio": _real(_OPEN_UNIT),
    "save_every": _Checker.count,
    "fixed_point_penalty": _real(_POSITIVE),
    "accuracy": _choice("fast", "balanced", "precise"),
    "max_steps": _Checker.count,
    "checkpoint_every": _Checker.count,
}

_CONTACT: dict[str, _Spec] = {
    "method": _choice("augmented-lagrangian", "penalty"),
    "penalty": _real(_POSITIVE),
    "tolerance": _real(_POSITIVE),
    "max_iterations": _Checker.count,
    "shear_ratio": _real(_POSITIVE),
    "state_band": _real(_OPEN_UNIT),
}

_STRENGTH_KEYS = ("cohesion", "friction_angle", "tensile_strength")
_MATERIAL: dict[str, _Spec] = {
    "density": _real(_POSITIVE),
    "young": _real(_POSITIVE),
    "poisson": _real(_POISSON),
    "cohesion": _real(_NON_NEGATIVE),
    "friction_angle": _real(_ANGLE),
    "tensile_strength": _real(_NON_NEGATIVE),
}

_JOINT: dict[str, _Spec] = {
    "friction_angle": _real(_ANGLE),
    "cohesion": _real(_NON_NEGATIVE),
    "tensile_strength": _real(_NON_NEGATIVE),
}


def _analysis(chk: _Checker, raw: Mapping[str, Any]) -> Analysis:
    """``[analysis]``; duration defaults to 1 s when neither it nor steps is given."""
    values = _fields(chk, raw.get("analysis", {}), "analysis", _ANALYSIS)
    if "duration" in values and "steps" in values:
        chk.fail("analysis.steps", "give either duration or steps, not both")
    if "steps" not in values:
        values.setdefault("duration", 1.0)
    return Analysis(**values)


def _contact(chk: _Checker, raw: Mapping[str, Any]) -> ContactSettings:
    return ContactSettings(**_fields(chk, raw.get("contact", {}), "contact", _CONTACT))


def _material(chk: _Checker, name: str, value: object) -> Material:
    """One material; the strength keys come all three or not at all."""
    key = _join("materials", name)
    values = _fields(chk, value, key, _MATERIAL)
    _require(chk, values, key, ("density", "young", "poisson"))
    given = [k for k in _STRENGTH_KEYS if k in values]
    missing = [k for k in _STRENGTH_KEYS if k not in values]
    if given and missing:
        chk.fail(
            _join(key, missing[0]),
            f"is required because {', '.join(given)} given: a breakable material "
            "needs all of cohesion, friction_angle and tensile_strength",
        )
    return Material(name=name, **values)


def _materials(chk: _Checker, raw: Mapping[str, Any]) -> Mapping[str, Material]:
    table = chk.named_tables(raw.get("materials", {}), "materials")
    return MappingProxyType({name: _material(chk, name, v) for name, v in table.items()})


def _joints(chk: _Checker, raw: Mapping[str, Any]) -> Mapping[str, Joint]:
    """Declared joints plus a frictionless ``default`` unless one is declared."""
    table = chk.named_tables(raw.get("joints", {}), "joints")
    joints = {
        name: Joint(name=name, **_fields(chk, v, _join("joints", name), _JOINT))
        for name, v in table.items()
    }
    joints.setdefault("default", Joint("default"))
    return MappingProxyType(joints)


def _fracture(chk: _Checker, raw: Mapping[str, Any], joints: Collection[str]) -> FractureSettings:
    specs: dict[str, _Spec] = {
        "joint": partial(_Checker.known, names=joints, what="joint"),
        "min_area": _real(_POSITIVE),
    }
    return FractureSettings(**_fields(chk, raw.get("fracture", {}), "fracture", specs))


# --------------------------------------------------------------------------- blocks


def _ring(chk: _Checker, value: object, key: str) -> tuple[Point, ...]:
    """Polygon vertices: >= 3 pairs, a repeated closing vertex dropped."""
    vertices = chk.positions(value, key)
    if len(vertices) > 1 and vertices[0] == vertices[-1]:
        vertices = vertices[:-1]
    if len(vertices) < 3:
        chk.fail(key, f"a polygon needs at least 3 distinct vertices, got {len(vertices)}")
    if len(vertices) > MAX_BLOCK_VERTICES:
        chk.fail(
            key,
            f"{len(vertices)} vertices, at most {MAX_BLOCK_VERTICES} per block "
            "(contacts number a block's vertices in 10 bits)",
        )
    return vertices


def _edge_joints(
    chk: _Checker, value: object, key: str, joints: Collection[str]
) -> tuple[str | None, ...]:
    """Joint name per edge; an empty string means the default joint (None)."""
    items = chk.sequence(value, key)
    names = [chk.text(item, f"{key}[{k}]") for k, item in enumerate(items)]
    for k, name in enumerate(names):
        if name:
            chk.known(name, f"{key}[{k}]", joints, "joint")
    return tuple(name or None for name in names)


def _block_name(chk: _Checker, value: object, key: str) -> str:
    name = chk.text(value, key)
    if not name:
        chk.fail(key, "must not be empty")
    if "/" in name:
        chk.fail(key, f"{name!r}: '/' is reserved for fracture fragments")
    return name


def _block_specs(materials: Collection[str], joints: Collection[str]) -> dict[str, _Spec]:
    return {
        "name": _block_name,
        "material": partial(_Checker.known, names=materials, what="material"),
        "vertices": _ring,
        "fixed": _Checker.boolean,
        "fixed_points": _Checker.positions,
        "velocity": _vector(3),
        "stress": _vector(3),
        "edge_joints": partial(_edge_joints, joints=joints),
    }


def _block_values(chk: _Checker, value: object, key: str, specs: Mapping[str, _Spec]) -> dict:
    """One ``[[blocks]]`` entry as converted values (geometry not yet checked)."""
    values = _fields(chk, value, key, specs)
    _require(chk, values, key, ("name", "material", "vertices"))
    if values.get("fixed") and any(v != 0.0 for v in values.get("velocity", ())):
        chk.fail(f"{key}.velocity", "the block is fixed and cannot move: drop velocity or fixed")
    edge_joints = values.get("edge_joints")
    if edge_joints is not None and len(edge_joints) != len(values["vertices"]):
        chk.fail(
            f"{key}.edge_joints",
            f"expected one entry per vertex ({len(values['vertices'])}), got {len(edge_joints)}",
        )
    return values


def _unique_names(chk: _Checker, blocks: Sequence[Mapping[str, Any]]) -> None:
    first: dict[str, int] = {}
    for i, values in enumerate(blocks):
        j = first.setdefault(values["name"], i)
        if j != i:
            chk.fail(f"blocks[{i}].name", f"duplicate block name {values['name']!r} (blocks[{j}])")


def _counter_clockwise(values: dict) -> dict:
    """Reverse a clockwise block: vertices, and edge joints to match."""
    vertices = values["vertices"][::-1]
    n = len(vertices)
    out = {**values, "vertices": vertices}
    if values.get("edge_joints") is not None:
        # new edge j (v[n-1-j] -> v[n-2-j]) is old edge (n-2-j) mod n
        out["edge_joints"] = tuple(values["edge_joints"][(n - 2 - j) % n] for j in range(n))
    return out


def _blocks(
    chk: _Checker,
    raw: Mapping[str, Any],
    materials: Collection[str],
    joints: Collection[str],
) -> tuple[Block, ...]:
    """All ``[[blocks]]``: fields, unique names, then the geometry at once."""
    specs = _block_specs(materials, joints)
    items = _table_list(chk, raw, "blocks")
    if len(items) == 0:
        chk.fail("blocks", "a scene needs at least one block")
    if len(items) > MAX_BLOCKS:
        chk.fail("blocks", f"{len(items)} blocks, at most {MAX_BLOCKS}")
    blocks = [_block_values(chk, v, f"blocks[{i}]", specs) for i, v in enumerate(items)]
    if all(values.get("fixed", False) for values in blocks):
        chk.fail("blocks", "every block is fixed: nothing can move; free at least one block")
    _unique_names(chk, blocks)
    clockwise = _check_geometry(chk, blocks)
    for i in np.flatnonzero(clockwise):
        blocks[i] = _counter_clockwise(blocks[i])
    return tuple(Block(**values) for values in blocks)


# --------------------------------------------------------------------------- geometry


class _Packed(NamedTuple):
    """All block polygons packed for vectorised checks."""

    coords: np.ndarray  # (NV, 2)
    owner: np.ndarray  # (NV,) block of each vertex
    offsets: np.ndarray  # (n + 1,)
    polygons: np.ndarray  # (n,) shapely polygons
    areas: np.ndarray  # (n,)
    bounds: np.ndarray  # (n, 4) xmin, ymin, xmax, ymax
    sizes: np.ndarray  # (n,) bounding-box diagonal


def _pack(blocks: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = np.array([len(b["vertices"]) for b in blocks], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    coords = np.array([p for b in blocks for p in b["vertices"]], dtype=float)
    owner = np.repeat(np.arange(len(blocks)), counts)
    return coords, owner, offsets


def _repeated_vertices(
    chk: _Checker, coords: np.ndarray, owner: np.ndarray, offsets: np.ndarray
) -> None:
    """Refuse a vertex equal to the next one (a zero-length edge)."""
    nxt = next_vertex_index(offsets)
    same = np.flatnonzero(np.all(coords == coords[nxt], axis=1))
    if same.size:
        k = same[0]
        i = owner[k]
        chk.fail(
            f"blocks[{i}].vertices",
            f"vertices {k - offsets[i]} and {nxt[k] - offsets[i]} coincide (zero-length edge)",
        )


def _simple_polygons(chk: _Checker, polygons: np.ndarray) -> None:
    """Refuse self-intersecting or otherwise invalid polygons."""
    invalid = np.flatnonzero(~shapely.is_valid(polygons))
    if invalid.size:
        i = invalid[0]
        reason = shapely.is_valid_reason(polygons[i])
        chk.fail(f"blocks[{i}].vertices", f"not a simple polygon ({reason})")


def _sized_polygons(chk: _Checker, areas: np.ndarray, sizes: np.ndarray) -> None:
    """Refuse slivers: area must exceed 1e-12 of the squared bbox diagonal (compared as
    √area > 1e-6 x diagonal, which does not overflow for huge coordinates)."""
    thin = np.flatnonzero(~(np.sqrt(np.maximum(areas, 0.0)) > 1e-6 * sizes))
    if thin.size:
        i = thin[0]
        chk.fail(
            f"blocks[{i}].vertices",
            f"area {areas[i]:g} is too small for a block of size {sizes[i]:g} "
            "(needs more than 1e-12 x squared bounding-box diagonal)",
        )


def _build_polygons(chk: _Checker, blocks: Sequence[Mapping[str, Any]]) -> _Packed:
    """Pack the block vertices and make valid shapely polygons of them."""
    coords, owner, offsets = _pack(blocks)
    _repeated_vertices(chk, coords, owner, offsets)
    polygons = shapely.polygons(shapely.linearrings(coords, indices=owner))
    _simple_polygons(chk, polygons)
    bounds = shapely.bounds(polygons)
    sizes = np.hypot(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1])
    areas = shapely.area(polygons)
    _sized_polygons(chk, areas, sizes)
    return _Packed(coords, owner, offsets, polygons, areas, bounds, sizes)


def _clockwise(packed: _Packed) -> np.ndarray:
    """Boolean per block: vertices given clockwise (signed shoelace area < 0)."""
    nxt = next_vertex_index(packed.offsets)
    # shift by each polygon's first vertex for round-off safety
    p = packed.coords - packed.coords[packed.offsets[:-1]][packed.owner]
    q = p[nxt]
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    return np.bincount(packed.owner, weights=cross, minlength=len(packed.areas)) < 0


def _box_overlap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Area shared by bounding boxes (xmin, ymin, xmax, ymax), row by row."""
    width = np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
    height = np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1])
    return np.clip(width, 0.0, None) * np.clip(height, 0.0, None)


def _overlaps(chk: _Checker, packed: _Packed, blocks: Sequence[Mapping[str, Any]]) -> None:
    """Refuse two blocks sharing more than 1e-9 of the smaller area.

    Candidate pairs come from one STRtree query ("intersects"), so the cost is
    near O(n log n); touching along an edge or at a point has zero area.
    """
    tree = shapely.STRtree(packed.polygons)
    left, right = tree.query(packed.polygons, predicate="intersects")
    left, right = left[left < right], right[left < right]
    limit = 1e-9 * np.minimum(packed.areas[left], packed.areas[right])
    # the shared area is at most the shared bounding-box area: skip pairs below the limit
    possible = _box_overlap(packed.bounds[left], packed.bounds[right]) > limit
    left, right, limit = left[possible], right[possible], limit[possible]
    shared = shapely.area(shapely.intersection(packed.polygons[left], packed.polygons[right]))
    bad = np.flatnonzero(shared > limit)
    if bad.size:
        k = bad[np.lexsort((left[bad], right[bad]))[0]]
        i, j = left[k], right[k]
        chk.fail(
            f"blocks[{j}].vertices",
            f"overlaps block {blocks[i]['name']!r} (blocks[{i}]) by area {shared[k]:g}",
        )


def _fixed_points_on_blocks(
    chk: _Checker, packed: _Packed, blocks: Sequence[Mapping[str, Any]]
) -> None:
    """Every fixed point lies inside or on its block (within 1e-9 x size)."""
    owner = [i for i, b in enumerate(blocks) for _ in b.get("fixed_points", ())]
    if not owner:
        return
    points = np.array([p for b in blocks for p in b.get("fixed_points", ())], dtype=float)
    owner = np.asarray(owner)
    distance = shapely.distance(shapely.points(points), packed.polygons[owner])
    outside = np.flatnonzero(distance > 1e-9 * packed.sizes[owner])
    if outside.size:
        k = outside[0]
        i = owner[k]
        index = k - np.searchsorted(owner, i)
        chk.fail(
            f"blocks[{i}].fixed_points[{index}]",
            f"lies outside the block (distance {distance[k]:g})",
        )


def _check_geometry(chk: _Checker, blocks: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """Check every block polygon at once; return which ones are clockwise."""
    packed = _build_polygons(chk, blocks)
    _fixed_points_on_blocks(chk, packed, blocks)
    _overlaps(chk, packed, blocks)
    return _clockwise(packed)


# --------------------------------------------------------------------------- references


def _history(chk: _Checker, value: object, key: str) -> tuple[Point, ...]:
    """(time, factor) pairs with strictly increasing time."""
    pairs = chk.points(value, key, min_count=1)
    for k in range(1, len(pairs)):
        if not pairs[k][0] > pairs[k - 1][0]:
            chk.fail(f"{key}[{k}]", "times must increase strictly")
    return pairs


def _loads(chk: _Checker, raw: Mapping[str, Any], blocks: Mapping[str, Block]) -> tuple[Load, ...]:
    """``[[loads]]``: on an existing free block, the point on (or in) the block."""
    specs: dict[str, _Spec] = {
        "block": partial(_Checker.known, names=blocks, what="block"),
        "point": _Checker.position,
        "force": _vector(2),
        "history": _history,
    }
    loads = []
    for i, value in enumerate(_table_list(chk, raw, "loads")):
        values = _fields(chk, value, f"loads[{i}]", specs)
        _require(chk, values, f"loads[{i}]", ("block", "point", "force"))
        block = blocks[values["block"]]
        if block.fixed:
            chk.fail(f"loads[{i}].block", f"{block.name!r} is fixed: a load on it does nothing")
        _on_block(chk, values["point"], block, f"loads[{i}].point")
        loads.append(Load(**values))
    return tuple(loads)


def _on_block(chk: _Checker, point: Point, block: Block, key: str) -> None:
    """Refuse a point farther than 1e-9 x its size from ``block`` (as for fixed points)."""
    polygon = shapely.Polygon(block.vertices)
    xmin, ymin, xmax, ymax = polygon.bounds
    distance = polygon.distance(shapely.Point(point))
    if distance > 1e-9 * math.hypot(xmax - xmin, ymax - ymin):
        chk.fail(key, f"lies outside block {block.name!r} (distance {distance:g})")


def _block_pair(chk: _Checker, value: object, key: str, blocks: Collection[str]) -> tuple[str, str]:
    items = chk.sequence(value, key)
    if len(items) != 2:
        chk.fail(key, f"expected two block names, got {len(items)}")
    a, b = (chk.known(name, f"{key}[{k}]", blocks, "block") for k, name in enumerate(items))
    if a == b:
        chk.fail(key, f"the two blocks must differ, got {a!r} twice")
    return a, b


def _interfaces(
    chk: _Checker, raw: Mapping[str, Any], blocks: Collection[str], joints: Collection[str]
) -> tuple[Interface, ...]:
    """``[[interfaces]]``: distinct existing blocks, an existing joint, one per pair."""
    specs: dict[str, _Spec] = {
        "blocks": partial(_block_pair, blocks=blocks),
        "joint": partial(_Checker.known, names=joints, what="joint"),
    }
    interfaces = []
    seen: dict[frozenset[str], int] = {}
    for i, value in enumerate(_table_list(chk, raw, "interfaces")):
        values = _fields(chk, value, f"interfaces[{i}]", specs)
        _require(chk, values, f"interfaces[{i}]", ("blocks", "joint"))
        j = seen.setdefault(frozenset(values["blocks"]), i)
        if j != i:
            chk.fail(f"interfaces[{i}].blocks", f"the same pair as interfaces[{j}]")
        interfaces.append(Interface(**values))
    return tuple(interfaces)


def _groups(
    chk: _Checker, raw: Mapping[str, Any], blocks: Collection[str]
) -> Mapping[str, tuple[str, ...]]:
    """``groups``: group name -> names of existing blocks."""
    table = chk.named_tables(raw.get("groups", {}), "groups")
    groups = {}
    for name, members in table.items():
        key = _join("groups", name)
        items = chk.sequence(members, key)
        groups[name] = tuple(
            chk.known(m, f"{key}[{k}]", blocks, "block") for k, m in enumerate(items)
        )
    return MappingProxyType(groups)


# --------------------------------------------------------------------------- scene


def _expand_rock_mass(raw: Mapping[str, Any], source: str) -> Mapping[str, Any]:
    """Hand rock-mass scenes to :mod:`dda.rockmass`, which makes blocks explicit.

    The rock-mass module consumes its own keys (and may accept more than the
    trigger keys), so top-level keys are checked on the expanded scene.
    """
    if not any(key in raw for key in _ROCK_MASS_KEYS):
        return raw
    try:
        from dda.rockmass import expand_rock_mass
    except ImportError as exc:
        raise SceneError(source, "regions", "rock-mass scenes need dda.rockmass") from exc
    logger.debug("expanding rock-mass scene %s", source)
    return expand_rock_mass(raw, source)


def _build_scene(raw: Mapping[str, Any], source: str) -> Scene:
    """Validate a raw nested mapping section by section into a Scene."""
    chk = _Checker(source)
    raw = chk.table(_expand_rock_mass(raw, source), "", _TOP_KEYS)
    title = chk.text(raw.get("title", ""), "title")
    analysis = _analysis(chk, raw)
    contact = _contact(chk, raw)
    materials = _materials(chk, raw)
    joints = _joints(chk, raw)
    blocks = _blocks(chk, raw, materials, joints)
    names = frozenset(b.name for b in blocks)
    by_name = {b.name: b for b in blocks}
    scene = Scene(
        title=title,
        analysis=analysis,
        contact=contact,
        materials=materials,
        joints=joints,
        blocks=blocks,
        loads=_loads(chk, raw, by_name),
        interfaces=_interfaces(chk, raw, names, joints),
        fracture=_fracture(chk, raw, joints),
        source=source,
        groups=_groups(chk, raw, names),
    )
    logger.debug("loaded scene %s: %d blocks", source, len(blocks))
    return scene
