"""The validated rock-mass description: regions, joints, excavations, selections."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

DEFAULT_MAX_BLOCKS = 20_000  # cutting.max_blocks: see dda.scene.rockmass.estimate


@dataclass(frozen=True)
class Region:
    """``[[regions]]``: one piece of rock of one material (holes already removed)."""

    key: str
    polygon: shapely.Polygon
    material: str


@dataclass(frozen=True)
class JointSet:
    """``[[joint_sets]]``: parallel traces at a spacing, optionally non-persistent.

    Traces run at angle ``dip`` (degrees, from +x) and lie on the lines
    ``n · x = offset + k * spacing`` with the unit normal ``n = (-sin dip, cos dip)``.
    With ``trace_length`` a trace is cut into joints of that length separated
    by rock bridges of ``bridge_length``.
    """

    key: str
    name: str
    joint: str
    dip: float
    spacing: float
    offset: float = 0.0
    trace_length: float | None = None
    bridge_length: float = 0.0
    stagger: float | str = 0.0  # shift along the trace per successive joint, or "random"
    dip_std: float = 0.0
    spacing_std: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class JointLine:
    """``[[joint_lines]]``: one named discontinuity along a polyline."""

    key: str
    name: str
    joint: str
    points: np.ndarray


@dataclass(frozen=True)
class Excavation:
    """``[[excavations]]``: a polygon removed from the rock."""

    key: str
    polygon: shapely.Polygon


@dataclass(frozen=True)
class Selector:
    """A rule picking blocks (used by ``[[fix]]`` and ``[groups.NAME]``).

    A block is selected when it meets every rule given: its centroid inside
    ``polygon``, all of it inside ``inside`` (to the cut's tolerance), an edge along
    the ``touching`` polyline, an edge on one of the ``sides`` of the rock mass's
    bounding box, its ``material``, its name in ``blocks``.
    """

    key: str
    polygon: shapely.Polygon | None = None
    inside: shapely.Polygon | None = None
    touching: np.ndarray | None = None
    sides: tuple[str, ...] = ()
    material: str | None = None
    blocks: tuple[str, ...] | None = None


@dataclass(frozen=True)
class CuttingOptions:
    """``[cutting]``: what to do with slivers and holed blocks, how to name blocks."""

    min_block_area: float | None = None  # default: 1e-6 of the rock area
    small_blocks: str = "merge"  # "merge" | "refuse"
    holes: str = "split"  # "split" | "refuse"
    name_prefix: str = "b"
    max_blocks: int = DEFAULT_MAX_BLOCKS  # refuse a cut estimated to give more blocks


@dataclass(frozen=True)
class RockMass:
    """Everything ``expand_rock_mass`` reads, validated."""

    regions: tuple[Region, ...]
    joint_sets: tuple[JointSet, ...] = ()
    joint_lines: tuple[JointLine, ...] = ()
    excavations: tuple[Excavation, ...] = ()
    fix: tuple[Selector, ...] = ()
    groups: dict[str, Selector | tuple[str, ...]] = field(default_factory=dict)
    options: CuttingOptions = field(default_factory=CuttingOptions)
