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
(:mod:`dda.scene.limits`), after command-line overrides.
"""

from __future__ import annotations

import logging
import math
import re
import tomllib
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np
import shapely

from dda.errors import SceneError
from dda.geometry import next_vertex_index
from dda.scene.checks import (
    ANGLE,
    NON_NEGATIVE,
    OPEN_UNIT,
    POISSON,
    POSITIVE,
    Checker,
    Interval,
    Point,
    Spec,
    checked_fields,
    choice,
    join_key,
    real,
    require,
    table_list,
    value_kind,
    vector,
)
from dda.scene.engineering import (
    ENGINEERING_KEYS,
    Bolt,
    Measure,
    Seismic,
    Stage,
    Water,
    parse_engineering,
)
from dda.scene.in_situ import IN_SITU_KEYS, BoundaryStress, StressField, parse_in_situ
from dda.scene.joints import Joint, parse_joints
from dda.scene.limits import DEFAULT_MAX_STEPS
from dda.scene.local_frame import origin_of
from dda.scene.overlap import sharing_area
from dda.scene.stability import (
    STABILITY_KEYS,
    EnsembleSettings,
    FosSettings,
    parse_stability,
)
from dda.scene.text_file import check_scene_file, read_scene_text

logger = logging.getLogger(__name__)

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
    max_steps: int = DEFAULT_MAX_STEPS  # refuse (and stop) runs longer than this (dda.scene.limits)
    checkpoint_every: int | None = None  # steps between checkpoints (dda run writes them)
    newmark_gamma: float = 1.0  # velocity update (dda.solve.integrator); 1: Shi's
    start: str = "equilibrium"  # "equilibrium" | "unloaded" (dda.run.equilibrium_start)

    @property
    def run_length(self) -> float:
        """The simulated time of the run as planned: ``duration``, or ``steps`` ×
        ``time_step`` (the longest step; a run that cuts steps ends earlier)."""
        return self.duration if self.duration is not None else self.steps * self.time_step


@dataclass(frozen=True)
class ContactSettings:
    """``[contact]``: contact method and its numbers."""

    method: str = "augmented-lagrangian"  # | "penalty"
    penalty: float | None = None  # default: 10 x largest Young's modulus
    tolerance: float | None = None  # AL: largest penetration; default 1e-4 x model size
    max_iterations: int = 100  # Newton iterations a step may take before it is cut
    shear_ratio: float = 0.4  # shear penalty / normal penalty


@dataclass(frozen=True)
class Units:
    """``[units]``: names of the units the scene's numbers are in, for pictures and tables.

    The engine needs only a consistent set; these names label axes and colour bars.
    """

    length: str = "m"
    force: str = "N"
    time: str = "s"

    @property
    def stress(self) -> str:
        """Force per area: ``Pa`` for N and m, else ``force/length²``."""
        if (self.force, self.length) == ("N", "m"):
            return "Pa"
        return f"{self.force}/{self.length}²"

    @property
    def velocity(self) -> str:
        return f"{self.length}/{self.time}"

    @property
    def energy(self) -> str:
        """Force times length: ``J`` for N and m, else ``force·length``."""
        if (self.force, self.length) == ("N", "m"):
            return "J"
        return f"{self.force}·{self.length}"


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
    # viscous stress, as a fraction of critical damping of a block's slowest elastic
    # mode (dda.effects.damping); dynamic analysis only
    damping: float = 0.2

    @property
    def breakable(self) -> bool:
        return self.cohesion is not None and self.friction_angle is not None


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
    units: Units = field(default_factory=Units)
    # rock engineering (dda.scene.engineering): absent sections build nothing
    bolts: tuple[Bolt, ...] = ()
    seismic: Seismic | None = None
    water: Water | None = None
    measure: tuple[Measure, ...] = ()
    stages: tuple[Stage, ...] = ()
    # the stress the rock mass stands in (dda.scene.in_situ): at t = 0, and on outer edges
    in_situ: StressField | None = None
    boundary_stresses: tuple[BoundaryStress, ...] = ()
    # stability (dda.scene.stability): dda fos and dda ensemble
    fos: FosSettings = field(default_factory=FosSettings)
    ensemble: EnsembleSettings | None = None
    # what loading said as warnings (a drawing's left-out shapes, joint lines that cut
    # nothing): the run's summary repeats them
    load_warnings: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """What progress and the closing line call the run: the title, else the scene
        file's name without its suffix, else ``"scene"`` (text or a dict)."""
        if self.title:
            return self.title
        return "scene" if self.source.startswith("<") else Path(self.source).stem

    @property
    def block_names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.blocks)


# --------------------------------------------------------------------------- entry


def load_scene(
    scene: str | Path | Mapping[str, Any],
    source: str | None = None,
    *,
    progress: Callable[[float, dict], None] | None = None,
) -> Scene:
    """Load and validate a scene.

    Parameters
    ----------
    scene
        A :class:`pathlib.Path`, a ``str`` ending in ``.toml`` without a
        newline (a path), other TOML text, or a dict of the same structure.
    source
        For a dict: the file it was read from (messages name it, and files the
        scene names are found beside it), e.g. a scene file changed in memory.
    progress
        ``progress(fraction, info)``, called as a rock-mass scene is cut into blocks
        (:mod:`dda.scene.rockmass.progress`); never for a scene of explicit blocks.

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
    raw, read_from = _read_raw(scene)
    source = source if source and isinstance(scene, Mapping) else read_from
    return _build_scene(raw, source, progress)


def read_scene_file(path: str | Path) -> dict[str, Any]:
    """The raw tables of a scene file, unchecked (:func:`load_scene` checks them).

    Raises
    ------
    SceneError
        For a missing file (key ``<file>``) or bad TOML (key ``<toml>``).
    """
    return _read_file(Path(path))


def _is_path(scene: object) -> bool:
    """A Path; or a one-line str that ends in ``.toml``, names a file, or holds no ``=``
    (TOML text of one line without a key/value pair is no scene: read it as a path)."""
    if isinstance(scene, Path):
        return True
    if not isinstance(scene, str) or "\n" in scene:
        return False
    if scene.endswith(".toml") or "=" not in scene:
        return True
    try:
        return Path(scene).is_file()
    except (OSError, ValueError):  # a name the file system refuses
        return False


def _read_raw(scene: str | Path | Mapping[str, Any]) -> tuple[Mapping[str, Any], str]:
    """The raw nested mapping of a scene and its source name."""
    if isinstance(scene, Mapping):
        return scene, "<dict>"
    if isinstance(scene, str) and not scene.strip():  # Path("") is ".": "a directory"
        raise SceneError("<text>", "<scene>", "empty: give a path, TOML text or a dict")
    if _is_path(scene):
        return _read_file(Path(scene)), str(scene)
    if isinstance(scene, str):
        return parse_toml(scene, "<text>"), "<text>"
    raise SceneError(
        f"<{type(scene).__name__}>",
        "<scene>",
        f"expected a path, TOML text or a dict, got {value_kind(scene)}",
    )


def _read_file(path: Path) -> dict[str, Any]:
    check_scene_file(path)
    return parse_toml(read_scene_text(path), str(path))


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The raw mapping of a scene's TOML ``text``; a SceneError of ``source`` that
    names the key given twice, or says what tomllib found wrong and where."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        key = _overwritten_key(text, message)
        if key:
            raise SceneError(source, key, f"given twice ({message})") from None
        raise SceneError(source, "<toml>", f"not valid TOML: {message}") from None


_AT_LINE = re.compile(r"\(at line (\d+), column \d+\)")


def _overwritten_key(text: str, message: str) -> str | None:
    """The dotted key a "Cannot overwrite a value" error of tomllib is about (its table
    header and the key of the line it names), else None: tomllib names the line only."""
    at = _AT_LINE.search(message)
    if not message.startswith("Cannot overwrite a value") or at is None:
        return None
    lines = text.splitlines()
    number = int(at.group(1))
    if not 1 <= number <= len(lines) or "=" not in lines[number - 1]:
        return None
    key = lines[number - 1].split("=", 1)[0].strip()
    table = ""
    for line in reversed(lines[: number - 1]):
        header = line.strip()
        if header.startswith("["):
            table = header.strip("[]").strip()
            break
    return f"{table}.{key}" if table else key


# --------------------------------------------------------------------------- sections

MAX_SIZES_PER_STEP = 1000.0  # an initial velocity may move a block this many model sizes a step
_ROCK_MASS_KEYS = ("regions", "joint_sets", "joint_lines", "excavations", "drawing")
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
    "units",
    *ENGINEERING_KEYS,
    *IN_SITU_KEYS,
    *STABILITY_KEYS,
)

_UNITS: dict[str, Spec] = {"length": Checker.text, "force": Checker.text, "time": Checker.text}

# γ of the velocity update: unconditionally stable with β = ½ for ½ ≤ γ ≤ 2β = 1
NEWMARK_GAMMA = Interval(0.5, 1.0, low_closed=True, high_closed=True)
# the least γ at which no step was measured to create energy where contacts close and
# open (a block dropped onto a base at Δt = 2e-3 to 1e-4 s: γ = 0.5 and 0.55 gain up to
# 1.6e-2 and 3.1e-4 of E0, 0.6 to 1 nothing; docs/contact.md, Energy): below it a scene is
# told so as it loads
GAMMA_ENERGY_SAFE = 0.6
# a fraction of critical damping: none to critical
DAMPING_RATIO = Interval(0.0, 1.0, low_closed=True, high_closed=True)

_ANALYSIS: dict[str, Spec] = {
    "mode": choice("dynamic", "static"),
    "time_step": real(POSITIVE),
    "duration": real(POSITIVE),
    "steps": Checker.count,
    "gravity": vector(2),
    "plane": choice("stress", "strain"),
    "rotation": choice("exact", "linear"),
    "max_displacement_ratio": real(OPEN_UNIT),
    "save_every": Checker.count,
    "fixed_point_penalty": real(POSITIVE),
    "accuracy": choice("fast", "balanced", "precise"),
    "max_steps": Checker.count,
    "checkpoint_every": Checker.count,
    "newmark_gamma": real(NEWMARK_GAMMA),
    "start": choice("equilibrium", "unloaded"),
}

_CONTACT: dict[str, Spec] = {
    "method": choice("augmented-lagrangian", "penalty"),
    "penalty": real(POSITIVE),
    "tolerance": real(POSITIVE),
    "max_iterations": Checker.count,
    "shear_ratio": real(POSITIVE),
}

_STRENGTH_KEYS = ("cohesion", "friction_angle", "tensile_strength")
_MATERIAL: dict[str, Spec] = {
    "density": real(POSITIVE),
    "young": real(POSITIVE),
    "poisson": real(POISSON),
    "cohesion": real(NON_NEGATIVE),
    "friction_angle": real(ANGLE),
    "tensile_strength": real(NON_NEGATIVE),
    "damping": real(DAMPING_RATIO),
}


def _units(chk: Checker, raw: Mapping[str, Any]) -> Units:
    """``[units]``: unit names (non-empty text), SI by default."""
    values = checked_fields(chk, raw.get("units", {}), "units", _UNITS)
    for name, text in values.items():
        if not text.strip():
            chk.fail(join_key("units", name), "must not be empty")
    return Units(**values)


def _analysis(chk: Checker, raw: Mapping[str, Any]) -> Analysis:
    """``[analysis]``; duration defaults to 1 s when neither it nor steps is given."""
    values = checked_fields(chk, raw.get("analysis", {}), "analysis", _ANALYSIS)
    if "duration" in values and "steps" in values:
        chk.fail("analysis.steps", "give either duration or steps, not both")
    if "steps" not in values:
        values.setdefault("duration", 1.0)
    return Analysis(**values)


def _contact(chk: Checker, raw: Mapping[str, Any]) -> ContactSettings:
    return ContactSettings(**checked_fields(chk, raw.get("contact", {}), "contact", _CONTACT))


def _material(chk: Checker, name: str, value: object) -> Material:
    """One material; the strength keys come all three or not at all."""
    key = join_key("materials", name)
    values = checked_fields(chk, value, key, _MATERIAL)
    require(chk, values, key, ("density", "young", "poisson"))
    given = [k for k in _STRENGTH_KEYS if k in values]
    missing = [k for k in _STRENGTH_KEYS if k not in values]
    if given and missing:
        chk.fail(
            join_key(key, missing[0]),
            f"is required because {', '.join(given)} given: a breakable material "
            "needs all of cohesion, friction_angle and tensile_strength",
        )
    return Material(name=name, **values)


def _materials(chk: Checker, raw: Mapping[str, Any]) -> Mapping[str, Material]:
    table = chk.named_tables(raw.get("materials", {}), "materials")
    return MappingProxyType({name: _material(chk, name, v) for name, v in table.items()})


def _fracture(chk: Checker, raw: Mapping[str, Any], joints: Collection[str]) -> FractureSettings:
    specs: dict[str, Spec] = {
        "joint": partial(Checker.known, names=joints, what="joint"),
        "min_area": real(POSITIVE),
    }
    return FractureSettings(**checked_fields(chk, raw.get("fracture", {}), "fracture", specs))


# --------------------------------------------------------------------------- blocks


def _ring(chk: Checker, value: object, key: str) -> tuple[Point, ...]:
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
            "(contacts number a block's vertices in 10 bits): split the block with a joint, "
            "or draw its curves with fewer chords (a larger [drawing] arc_tolerance)",
        )
    return vertices


def _edge_joints(
    chk: Checker, value: object, key: str, joints: Collection[str]
) -> tuple[str | None, ...]:
    """Joint name per edge; an empty string means the default joint (None)."""
    items = chk.sequence(value, key)
    names = [chk.text(item, f"{key}[{k}]") for k, item in enumerate(items)]
    for k, name in enumerate(names):
        if name:
            chk.known(name, f"{key}[{k}]", joints, "joint")
    return tuple(name or None for name in names)


def _block_name(chk: Checker, value: object, key: str) -> str:
    name = chk.text(value, key)
    if not name:
        chk.fail(key, "must not be empty")
    if "/" in name:
        chk.fail(key, f"{name!r}: '/' is reserved for fracture fragments")
    return name


def _block_specs(materials: Collection[str], joints: Collection[str]) -> dict[str, Spec]:
    return {
        "name": _block_name,
        "material": partial(Checker.known, names=materials, what="material"),
        "vertices": _ring,
        "fixed": Checker.boolean,
        "fixed_points": Checker.positions,
        "velocity": vector(3),
        "stress": vector(3),
        "edge_joints": partial(_edge_joints, joints=joints),
    }


def _block_values(chk: Checker, value: object, key: str, specs: Mapping[str, Spec]) -> dict:
    """One ``[[blocks]]`` entry as converted values (geometry not yet checked)."""
    values = checked_fields(chk, value, key, specs)
    require(chk, values, key, ("name", "material", "vertices"))
    if values.get("fixed") and any(v != 0.0 for v in values.get("velocity", ())):
        chk.fail(f"{key}.velocity", "the block is fixed and cannot move: drop velocity or fixed")
    edge_joints = values.get("edge_joints")
    if edge_joints is not None and len(edge_joints) != len(values["vertices"]):
        chk.fail(
            f"{key}.edge_joints",
            f"expected one entry per vertex ({len(values['vertices'])}), got {len(edge_joints)}",
        )
    return values


def _unique_names(chk: Checker, blocks: Sequence[Mapping[str, Any]]) -> None:
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
    chk: Checker,
    raw: Mapping[str, Any],
    materials: Collection[str],
    joints: Collection[str],
) -> tuple[Block, ...]:
    """All ``[[blocks]]``: fields, unique names, then the geometry at once."""
    specs = _block_specs(materials, joints)
    items = table_list(chk, raw, "blocks")
    if len(items) == 0:
        chk.fail("blocks", "a scene needs at least one block")
    if len(items) > MAX_BLOCKS:
        chk.fail("blocks", f"{len(items)} blocks, at most {MAX_BLOCKS}")
    try:
        blocks = [_block_values(chk, v, f"blocks[{i}]", specs) for i, v in enumerate(items)]
        if all(values.get("fixed", False) for values in blocks):
            chk.fail("blocks", "every block is fixed: nothing can move; free at least one block")
        _unique_names(chk, blocks)
        clockwise = _check_geometry(chk, blocks)
    except SceneError as exc:
        raise _naming_the_block(exc, items) from None
    for i in np.flatnonzero(clockwise):
        blocks[i] = _counter_clockwise(blocks[i])
    return tuple(Block(**values) for values in blocks)


def _check_stresses(chk: Checker, blocks: Sequence[Block], materials: Mapping[str, Any]) -> None:
    """Refuse a block's initial ``stress`` as large as its material's Young's modulus (a
    strain of 1 or more, no stress rock stands in), as an ``[in_situ]`` field is refused
    (an audit: −1e12 Pa on a block of E = 5e9 ran to its end, unsaid)."""
    for i, block in enumerate(blocks):
        young = materials[block.material].young
        largest = max(abs(value) for value in block.stress)
        if largest >= young:
            chk.fail(f"blocks[{i}].stress", f"{largest:.3g} on block {block.name!r} is as "
                     f"large as the Young's modulus {young:.3g} of its material "
                     f"{block.material!r} (a strain of 1 or more), no stress rock stands "
                     "in")  # fmt: skip


def _check_speeds(chk: Checker, blocks: Sequence[Block], analysis: Analysis) -> None:
    """Refuse an initial velocity that moves a block more than ``MAX_SIZES_PER_STEP``
    model sizes in one time step (1e10 m/s for 10 m/s, a unit mix-up): no step could
    resolve it, and the run would fail with "contacts did not settle"."""
    points = np.concatenate([np.asarray(b.vertices, float) for b in blocks])
    size = float(np.hypot(*np.ptp(points, axis=0)))
    velocity = np.array([b.velocity for b in blocks], float).reshape(-1, 3)
    speed = np.hypot(velocity[:, 0], velocity[:, 1]) + np.abs(velocity[:, 2]) * size
    sizes = speed * analysis.time_step / size if size > 0 else np.zeros(len(blocks))
    fast = np.flatnonzero(~(sizes <= MAX_SIZES_PER_STEP))
    if fast.size:
        i = fast[0]
        chk.fail(
            f"blocks[{i}].velocity",
            f"(block {blocks[i].name!r}) moves {sizes[i]:.3g} model sizes ({size:.3g}) in one "
            f"time step ({analysis.time_step:g}), more than {MAX_SIZES_PER_STEP:g}: no step "
            "can follow it; check the velocity and its units",
        )


def _naming_the_block(exc: SceneError, items: Sequence[Any]) -> SceneError:
    """The error of ``blocks[i]...`` with the block's name in its reason: in a scene of a
    thousand blocks, ``blocks[734]`` alone is hard to find."""
    match = re.match(r"blocks\[(\d+)\]", exc.key)
    if match is None or int(match.group(1)) >= len(items):
        return exc
    item = items[int(match.group(1))]
    name = item.get("name") if isinstance(item, Mapping) else None
    if not isinstance(name, str) or exc.reason.startswith(f"(block {name!r})"):
        return exc
    return SceneError(exc.source, exc.key, f"(block {name!r}) {exc.reason}")


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
    origin: np.ndarray  # (2,) subtracted from the coordinates (dda.scene.local_frame)


def _pack(blocks: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = np.array([len(b["vertices"]) for b in blocks], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    coords = np.array([p for b in blocks for p in b["vertices"]], dtype=float)
    owner = np.repeat(np.arange(len(blocks)), counts)
    return coords, owner, offsets


def _repeated_vertices(
    chk: Checker, coords: np.ndarray, owner: np.ndarray, offsets: np.ndarray
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


def _simple_polygons(chk: Checker, polygons: np.ndarray) -> None:
    """Refuse self-intersecting or otherwise invalid polygons."""
    invalid = np.flatnonzero(~shapely.is_valid(polygons))
    if invalid.size:
        i = invalid[0]
        if _collinear(shapely.get_coordinates(polygons[i])):
            chk.fail(f"blocks[{i}].vertices", "its vertices lie on one line (no area)")
        reason = shapely.is_valid_reason(polygons[i])
        chk.fail(f"blocks[{i}].vertices", f"not a simple polygon ({reason})")


def _collinear(points: np.ndarray) -> bool:
    """Whether ``points`` (k, 2) lie on one line: the smaller singular value of the
    centred points is below 1e-12 of the larger (shapely calls such a polygon
    self-intersecting)."""
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    return bool(singular[-1] <= 1e-12 * singular[0])


def _sized_polygons(chk: Checker, areas: np.ndarray, sizes: np.ndarray) -> None:
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


def _build_polygons(chk: Checker, blocks: Sequence[Mapping[str, Any]]) -> _Packed:
    """Pack the block vertices and make valid shapely polygons of them."""
    coords, owner, offsets = _pack(blocks)
    _repeated_vertices(chk, coords, owner, offsets)
    origin = origin_of(coords)  # far from (0, 0): check about the model's centre
    coords = coords - origin
    polygons = shapely.polygons(shapely.linearrings(coords, indices=owner))
    _simple_polygons(chk, polygons)
    bounds = shapely.bounds(polygons)
    sizes = np.hypot(bounds[:, 2] - bounds[:, 0], bounds[:, 3] - bounds[:, 1])
    areas = shapely.area(polygons)
    _sized_polygons(chk, areas, sizes)
    return _Packed(coords, owner, offsets, polygons, areas, bounds, sizes, origin)


def _clockwise(packed: _Packed) -> np.ndarray:
    """Boolean per block: vertices given clockwise (signed shoelace area < 0)."""
    nxt = next_vertex_index(packed.offsets)
    # shift by each polygon's first vertex for round-off safety
    p = packed.coords - packed.coords[packed.offsets[:-1]][packed.owner]
    q = p[nxt]
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    return np.bincount(packed.owner, weights=cross, minlength=len(packed.areas)) < 0


def _overlaps(chk: Checker, packed: _Packed, blocks: Sequence[Mapping[str, Any]]) -> None:
    """Refuse two blocks sharing more than 1e-9 of the smaller area (the blocks as given;
    :func:`dda.scene.overlap.sharing_area`)."""
    left, right, shared = sharing_area(
        packed.polygons, packed.coords, packed.offsets, packed.areas, 1e-9
    )
    if left.size:
        k = np.lexsort((left, right))[0]
        i, j = left[k], right[k]
        chk.fail(
            f"blocks[{j}].vertices",
            f"overlaps block {blocks[i]['name']!r} (blocks[{i}]) "
            f"by area {shapely.area(shared[k]):g}",
        )


def _fixed_points_on_blocks(
    chk: Checker, packed: _Packed, blocks: Sequence[Mapping[str, Any]]
) -> None:
    """Every fixed point lies inside or on its block (within 1e-9 x size)."""
    owner = [i for i, b in enumerate(blocks) for _ in b.get("fixed_points", ())]
    if not owner:
        return
    points = np.array([p for b in blocks for p in b.get("fixed_points", ())], dtype=float)
    points -= packed.origin
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


def _check_geometry(chk: Checker, blocks: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """Check every block polygon at once; return which ones are clockwise."""
    packed = _build_polygons(chk, blocks)
    _fixed_points_on_blocks(chk, packed, blocks)
    _overlaps(chk, packed, blocks)
    return _clockwise(packed)


# --------------------------------------------------------------------------- references


def _history(chk: Checker, value: object, key: str) -> tuple[Point, ...]:
    """(time, factor) pairs with strictly increasing time."""
    pairs = chk.points(value, key, min_count=1)
    for k in range(1, len(pairs)):
        if not pairs[k][0] > pairs[k - 1][0]:
            chk.fail(f"{key}[{k}]", "times must increase strictly")
    return pairs


def _loads(chk: Checker, raw: Mapping[str, Any], blocks: Mapping[str, Block]) -> tuple[Load, ...]:
    """``[[loads]]``: on an existing free block, the point on (or in) the block."""
    specs: dict[str, Spec] = {
        "block": partial(Checker.known, names=blocks, what="block"),
        "point": Checker.position,
        "force": vector(2),
        "history": _history,
    }
    loads = []
    for i, value in enumerate(table_list(chk, raw, "loads")):
        values = checked_fields(chk, value, f"loads[{i}]", specs)
        require(chk, values, f"loads[{i}]", ("block", "point", "force"))
        block = blocks[values["block"]]
        if block.fixed:
            chk.fail(f"loads[{i}].block", f"{block.name!r} is fixed: a load on it does nothing")
        _on_block(chk, values["point"], block, f"loads[{i}].point")
        loads.append(Load(**values))
    return tuple(loads)


def _on_block(chk: Checker, point: Point, block: Block, key: str) -> None:
    """Refuse a point farther than 1e-9 x its size from ``block`` (as for fixed points)."""
    polygon = shapely.Polygon(block.vertices)
    xmin, ymin, xmax, ymax = polygon.bounds
    distance = polygon.distance(shapely.Point(point))
    if distance > 1e-9 * math.hypot(xmax - xmin, ymax - ymin):
        chk.fail(key, f"lies outside block {block.name!r} (distance {distance:g})")


def _block_pair(chk: Checker, value: object, key: str, blocks: Collection[str]) -> tuple[str, str]:
    items = chk.sequence(value, key)
    if len(items) != 2:
        chk.fail(key, f"expected two block names, got {len(items)}")
    a, b = (chk.known(name, f"{key}[{k}]", blocks, "block") for k, name in enumerate(items))
    if a == b:
        chk.fail(key, f"the two blocks must differ, got {a!r} twice")
    return a, b


def _interfaces(
    chk: Checker, raw: Mapping[str, Any], blocks: Collection[str], joints: Collection[str]
) -> tuple[Interface, ...]:
    """``[[interfaces]]``: distinct existing blocks, an existing joint, one per pair."""
    specs: dict[str, Spec] = {
        "blocks": partial(_block_pair, blocks=blocks),
        "joint": partial(Checker.known, names=joints, what="joint"),
    }
    interfaces = []
    seen: dict[frozenset[str], int] = {}
    for i, value in enumerate(table_list(chk, raw, "interfaces")):
        values = checked_fields(chk, value, f"interfaces[{i}]", specs)
        require(chk, values, f"interfaces[{i}]", ("blocks", "joint"))
        j = seen.setdefault(frozenset(values["blocks"]), i)
        if j != i:
            chk.fail(f"interfaces[{i}].blocks", f"the same pair as interfaces[{j}]")
        interfaces.append(Interface(**values))
    return tuple(interfaces)


def _groups(
    chk: Checker, raw: Mapping[str, Any], blocks: Collection[str]
) -> Mapping[str, tuple[str, ...]]:
    """``groups``: group name -> names of existing blocks."""
    table = chk.named_tables(raw.get("groups", {}), "groups")
    groups = {}
    for name, members in table.items():
        key = join_key("groups", name)
        items = chk.sequence(members, key)
        if not items:  # [seismic] blocks, a stage or [fos] naming it would do nothing
            chk.fail(key, "names no block")
        groups[name] = tuple(
            chk.known(m, f"{key}[{k}]", blocks, "block") for k, m in enumerate(items)
        )
    return MappingProxyType(groups)


# --------------------------------------------------------------------------- scene


def _expand_rock_mass(
    raw: Mapping[str, Any], source: str, progress: Callable[[float, dict], None] | None
) -> Mapping[str, Any]:
    """Hand rock-mass scenes to :mod:`dda.scene.rockmass`, which makes blocks explicit.

    The rock-mass module consumes its own keys (and may accept more than the
    trigger keys), so top-level keys are checked on the expanded scene.
    """
    if not any(key in raw for key in _ROCK_MASS_KEYS):
        return raw
    try:
        from dda.scene.rockmass import expand_rock_mass
    except ImportError as exc:
        raise SceneError(source, "regions", "rock-mass scenes need dda.scene.rockmass") from exc
    logger.debug("expanding rock-mass scene %s", source)
    return expand_rock_mass(raw, source, progress)


def _build_scene(
    raw: Mapping[str, Any],
    source: str,
    progress: Callable[[float, dict], None] | None = None,
) -> Scene:
    """Validate a raw nested mapping section by section into a Scene."""
    chk = Checker(source)
    written = raw
    said: list[str] = []
    with _warnings_said(said):
        raw = chk.table(_expand_rock_mass(raw, source, progress), "", _TOP_KEYS)
        title = chk.text(raw.get("title", ""), "title")
        analysis = _analysis(chk, raw)
        contact = _contact(chk, raw)
        materials = _materials(chk, raw)
        joints = parse_joints(chk, raw)
        blocks = _blocks(chk, raw, materials, joints)
        _check_speeds(chk, blocks, analysis)
        _check_stresses(chk, blocks, materials)
        names = frozenset(b.name for b in blocks)
        by_name = {b.name: b for b in blocks}
        loads = _loads(chk, raw, by_name)
        interfaces = _interfaces(chk, raw, names, joints)
        fracture = _fracture(chk, raw, joints)
        groups = _groups(chk, raw, names)
        units = _units(chk, raw)
        engineering = parse_engineering(chk, raw, blocks, groups, analysis, loads)
        stages = engineering.get("stages", ())
        young = {name: m.young for name, m in materials.items()}
        in_situ = parse_in_situ(chk, raw, blocks, stages, joints, interfaces, young)
    scene = Scene(
        title=title,
        analysis=analysis,
        contact=contact,
        materials=materials,
        joints=joints,
        blocks=blocks,
        loads=loads,
        interfaces=interfaces,
        fracture=fracture,
        source=source,
        groups=groups,
        units=units,
        **engineering,
        **in_situ,
        **parse_stability(chk, raw, written, blocks, groups),
        load_warnings=tuple(said),
    )
    _check_intact(chk, scene)
    _check_restitution(chk, scene)
    _check_default_name(chk, scene, raw.get("joints", {}))
    idle = _idle_keys(scene, raw)
    for sentence in idle:
        logger.warning("%s: %s", source, sentence)
    logger.debug("loaded scene %s: %d blocks", source, len(blocks))
    return replace(scene, load_warnings=(*scene.load_warnings, *idle)) if idle else scene


def _idle_keys(scene: Scene, raw: Mapping[str, Any]) -> list[str]:
    """Sentences for keys the scene gives that do nothing in it: a static analysis's
    ``newmark_gamma`` and initial velocities (each step starts at rest); and for a dynamic
    ``newmark_gamma`` below :data:`GAMMA_ENERGY_SAFE`. (``[fracture]`` that can break
    nothing is said by the run: dda.run.run_warnings.)"""
    said = []
    at_rest = "a static analysis starts each step at rest"
    if scene.analysis.mode == "static":
        if "newmark_gamma" in raw.get("analysis", {}):
            said.append(f"analysis.newmark_gamma: {at_rest} and updates no velocity; the key "
                        "does nothing")  # fmt: skip
        moving = [i for i, b in enumerate(scene.blocks) if any(v != 0.0 for v in b.velocity)]
        if moving:
            said.append(f"blocks[{moving[0]}].velocity: {at_rest}; the initial velocity of "
                        f"{len(moving)} block(s) does nothing")  # fmt: skip
    if scene.analysis.mode == "dynamic" and scene.analysis.newmark_gamma < GAMMA_ENERGY_SAFE:
        said.append(f"analysis.newmark_gamma = {scene.analysis.newmark_gamma:g}: below "
                    f"{GAMMA_ENERGY_SAFE:g} the velocity update can create energy where a "
                    "contact opens (it carries the contact's last force into the velocity: "
                    "docs/contact.md, Energy); 0.9 damps a rocking mode without it")  # fmt: skip
    return said


class _Said(logging.Handler):
    """Keeps the messages of the warnings logged while it is attached."""

    def __init__(self, into: list[str]) -> None:
        super().__init__(logging.WARNING)
        self.into = into

    def emit(self, record: logging.LogRecord) -> None:
        self.into.append(record.getMessage())


@contextmanager
def _warnings_said(into: list[str]) -> Iterator[None]:
    """Collect into ``into`` the warnings that :mod:`dda.scene` logs meanwhile."""
    handler, scene_log = _Said(into), logging.getLogger("dda.scene")
    scene_log.addHandler(handler)
    try:
        yield
    finally:
        scene_log.removeHandler(handler)


def _check_default_name(chk: Checker, scene: Scene, declared: Mapping[str, Any]) -> None:
    """Refuse a joint that nothing names whose name is a near miss of ``default`` where
    no ``[joints.default]`` is given (``[joints.defualt]``): every edge that names no
    joint then takes the frictionless default, silently, instead of the joint meant."""
    if "default" in declared:
        return
    named = {scene.fracture.joint, *(i.joint for i in scene.interfaces)}
    for block in scene.blocks:
        named.update(block.edge_joints or ())
    for name in declared:
        if name not in named and _misspelt_default(name):
            chk.fail(
                join_key("joints", name),
                "names no edge, interface or crack, and the edges that name no joint take "
                "the default joint, frictionless as none is given: did you mean 'default'?",
            )


def _misspelt_default(name: str) -> bool:
    """True for ``default`` mistyped: the same first letter, within two letters typed
    wrong, left out, added or swapped (case aside; ``fault`` and ``defect`` are names)."""
    word, target = name.casefold(), "default"
    if name == target or not word.startswith("d"):
        return False
    rows = [list(range(len(target) + 1))]
    for i, a in enumerate(word, 1):
        row = [i]
        for j, b in enumerate(target, 1):
            row.append(min(rows[-1][j] + 1, row[j - 1] + 1, rows[-1][j - 1] + (a != b)))
            if i > 1 and j > 1 and a == target[j - 2] and word[i - 2] == b:
                row[j] = min(row[j], rows[-2][j - 2] + 1)  # two letters swapped
        rows.append(row)
    return rows[-1][-1] <= 2


def _check_restitution(chk: Checker, scene: Scene) -> None:
    """Refuse a joint's ``restitution`` (given, or drawn by ``[[ensemble.vary]]``) with the
    augmented Lagrangian (the method the run will use: ``[analysis] accuracy`` may set
    it): its multiplier, once an impact's penetration passes the
    tolerance, stiffens the contact beyond the penalty the dashpot is tuned to, and the
    rebound is not e (a block dropped 0.4 m at Δt = 1e-4 s rebounds at 0.43 for e = 0.3,
    0.64 for 0.8 and 0.77 for 1, and further from e at smaller Δt; the penalty method
    gives 0.285, 0.800 and 0.996)."""
    from dda.scene.presets import apply_preset  # the method the run will use

    if apply_preset(scene).contact.method != "augmented-lagrangian":
        return
    keys = [f"joints.{name}.restitution" for name, joint in scene.joints.items()
            if joint.restitution is not None]  # fmt: skip
    if scene.ensemble is not None:
        keys += [f"ensemble.vary[{k}].key" for k, d in enumerate(scene.ensemble.vary)
                 if d.key.endswith(".restitution")]  # fmt: skip
    if keys:
        chk.fail(keys[0], 'needs [contact] method = "penalty": the augmented Lagrangian\'s '
                 "multipliers stiffen an impact beyond the penalty the dashpot is tuned to, "
                 "and the rebound is then not e")  # fmt: skip


def _check_intact(chk: Checker, scene: Scene) -> None:
    """Refuse ``intact = true`` (a stage's, or [fos]'s) where no block's material is
    breakable: there would be no intact rock's strength to divide, and it did nothing
    without a word."""
    if any(scene.materials[b.material].breakable for b in scene.blocks):
        return
    keys = [f"stages[{k}].intact" for k, stage in enumerate(scene.stages) if stage.intact]
    if scene.fos.intact:
        keys.append("fos.intact")
    if keys:
        chk.fail(keys[0], "no block's material is breakable (cohesion and friction_angle "
                 "in [materials.NAME]): there is no intact rock to weaken")  # fmt: skip
