"""Scene: the immutable, validated description of one analysis.

``load_scene`` accepts a path to a TOML file, TOML text or a plain dict and
returns a frozen :class:`Scene`. Every problem raises :class:`SceneError`
naming the source, the key and the reason; nothing runs for a refused scene.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from dda.errors import SceneError

Point = tuple[float, float]


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


@dataclass(frozen=True)
class ContactSettings:
    """``[contact]``: contact method and its numbers."""

    method: str = "augmented-lagrangian"  # | "penalty"
    penalty: float | None = None  # default: 10 x largest Young's modulus
    tolerance: float | None = None  # AL: largest penetration; default 1e-4 x model size
    max_iterations: int = 50
    shear_ratio: float = 0.4  # shear penalty / normal penalty


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

    @property
    def block_names(self) -> tuple[str, ...]:
        return tuple(b.name for b in self.blocks)


def load_scene(scene: str | Path | Mapping[str, Any]) -> Scene:
    """Load and validate a scene from a TOML path, TOML text or a dict."""
    raw, source = _read_raw(scene)
    return _build_scene(raw, source)


def _read_raw(scene: str | Path | Mapping[str, Any]) -> tuple[dict, str]:
    if isinstance(scene, Mapping):
        return dict(scene), "<dict>"
    if isinstance(scene, Path) or (isinstance(scene, str) and "\n" not in scene and
                                   scene.strip().endswith(".toml")):
        path = Path(scene)
        if not path.is_file():
            raise SceneError(str(path), "<file>", "no such file")
        try:
            return tomllib.loads(path.read_text()), str(path)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(str(path), "<toml>", str(exc)) from None
    try:
        return tomllib.loads(scene), "<text>"
    except tomllib.TOMLDecodeError as exc:
        raise SceneError("<text>", "<toml>", str(exc)) from None


def _points(value: Any) -> tuple[Point, ...]:
    return tuple((float(p[0]), float(p[1])) for p in value)


def _ccw(vertices: tuple[Point, ...]) -> tuple[Point, ...]:
    area2 = sum(
        x0 * y1 - x1 * y0
        for (x0, y0), (x1, y1) in zip(vertices, vertices[1:] + vertices[:1], strict=True)
    )
    return vertices if area2 > 0 else tuple(reversed(vertices))


def _build_scene(raw: dict, source: str) -> Scene:
    """Minimal builder (validation is extended in a later change)."""
    a = dict(raw.get("analysis", {}))
    if "gravity" in a:
        a["gravity"] = tuple(float(g) for g in a["gravity"])
    analysis = Analysis(**a)
    contact = ContactSettings(**raw.get("contact", {}))
    materials = {n: Material(name=n, **m) for n, m in raw.get("materials", {}).items()}
    joints = {n: Joint(name=n, **j) for n, j in raw.get("joints", {}).items()}
    blocks = []
    for b in raw.get("blocks", []):
        b = dict(b)
        b["vertices"] = _ccw(_points(b["vertices"]))
        b["fixed_points"] = _points(b.get("fixed_points", ()))
        b["velocity"] = tuple(float(v) for v in b.get("velocity", (0, 0, 0)))
        b["stress"] = tuple(float(v) for v in b.get("stress", (0, 0, 0)))
        blocks.append(Block(**b))
    loads = []
    for ld in raw.get("loads", []):
        ld = dict(ld)
        ld["point"] = tuple(map(float, ld["point"]))
        ld["force"] = tuple(map(float, ld["force"]))
        if "history" in ld:
            ld["history"] = _points(ld["history"])
        loads.append(Load(**ld))
    interfaces = tuple(
        Interface(blocks=tuple(i["blocks"]), joint=i["joint"]) for i in raw.get("interfaces", [])
    )
    fracture = FractureSettings(**raw.get("fracture", {}))
    if not math.isfinite(analysis.time_step):
        raise SceneError(source, "analysis.time_step", "must be finite")
    return Scene(
        title=str(raw.get("title", "")),
        analysis=analysis,
        contact=contact,
        materials=MappingProxyType(materials),
        joints=MappingProxyType(joints),
        blocks=tuple(blocks),
        loads=tuple(loads),
        interfaces=interfaces,
        fracture=fracture,
        source=source,
    )
