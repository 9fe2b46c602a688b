"""What a run returns: frames (snapshots of the blocks), events and a summary."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

# contact states, as stored in ``Contacts.state``
OPEN, SLIDING, LOCKED = 0, 1, 2
STATE_NAMES = {OPEN: "open", SLIDING: "sliding", LOCKED: "locked"}


@dataclass(frozen=True)
class Contacts:
    """Contacts of one frame, one row each (struct of arrays).

    ``block_a`` holds the row (in the frame's block arrays) of the block whose
    vertex touches; ``block_b`` the row of the block whose edge is touched.
    Forces are per unit thickness; ``normal_force`` > 0 is compression,
    ``penetration`` > 0 is overlap. ``state`` is OPEN, SLIDING or LOCKED.
    """

    block_a: np.ndarray  # (m,) int
    block_b: np.ndarray  # (m,) int
    points: np.ndarray  # (m, 2) contact vertex position
    normals: np.ndarray  # (m, 2) unit normal, from block_b towards block_a
    normal_force: np.ndarray  # (m,)
    shear_force: np.ndarray  # (m,) along the edge direction of block_b
    penetration: np.ndarray  # (m,)
    state: np.ndarray  # (m,) int8

    @classmethod
    def empty(cls) -> Contacts:
        z = np.zeros(0)
        i = np.zeros(0, dtype=np.int64)
        return cls(i, i, np.zeros((0, 2)), np.zeros((0, 2)), z, z, z, np.zeros(0, np.int8))

    def __len__(self) -> int:
        return len(self.block_a)


@dataclass(frozen=True)
class Frame:
    """The block system at one instant. Row k of every array is one block."""

    time: float
    step: int
    names: tuple[str, ...]
    ids: np.ndarray  # (n,) stable integer ids
    centroids: np.ndarray  # (n, 2)
    rotations: np.ndarray  # (n,) accumulated rotation, rad
    velocities: np.ndarray  # (n, 3) vx, vy, omega at the centroid
    stresses: np.ndarray  # (n, 3) sxx, syy, sxy
    displacements: np.ndarray  # (n, 2) centroid displacement since the start
    vertices: list[np.ndarray]  # (k_i, 2) each, counter-clockwise
    areas: np.ndarray  # (n,)
    fixed: np.ndarray  # (n,) bool
    contacts: Contacts = field(default_factory=Contacts.empty)
    # the [[measure]] rows of the steps since the previous frame (columns as in
    # Result.measurements), for writers that stream them; None without [[measure]]
    measured: dict[str, np.ndarray] | None = None
    # (b, 2, 2) start and end points of the rock bolts in place; None without [[bolts]]
    bolts: np.ndarray | None = None
    # (b,) the tension of each of those bolts (force, tension positive); None without
    # [[bolts]] (or read from bolts files written without it)
    bolt_tensions: np.ndarray | None = None
    # (b,) the index of each of those bolts among the scene's (``summary["bolt_names"]``:
    # the scene's bolts, then its stages'), the same bolt at every frame; None without
    # [[bolts]] (or read from bolts files written without it)
    bolt_ids: np.ndarray | None = None
    # (n,) the out-of-plane stress szz = ν (sxx + syy) of a plane-strain scene; None in
    # plane stress (szz = 0)
    out_of_plane: np.ndarray | None = None

    def block(self, name: str) -> int:
        """Row of the block called ``name``."""
        return self.names.index(name)


class FractureEvent(NamedTuple):
    """One block breaking: ``mode`` is "shear" or "tension"; ``stress`` the parent's
    (sxx, syy, sxy) that met the criterion, which its children start with."""

    step: int
    time: float
    parent: str
    children: tuple[str, ...]
    mode: str
    stress: tuple[float, ...] = ()


class BoltEvent(NamedTuple):
    """A rock bolt breaking: its tension ``force`` exceeded its capacity after ``step``;
    ``energy``: what it held then, f0 e + ½ k e², which goes with it (dissipated by the
    break, not by the numerics)."""

    step: int
    time: float
    bolt: str
    force: float
    energy: float = 0.0


@dataclass
class Result:
    """Frames kept during the run, fracture events and a summary dict.

    ``frames``: every kept frame, or with ``simulate(..., keep_frames=False)``
    the first and the latest only; a run resumed from a checkpoint starts with
    the checkpoint's state. ``history``: one value per step (12 columns).
    ``bolt_events``: the rock bolts that broke. ``measurements``: the
    ``[[measure]]`` quantities, one value per step from step 0 (columns
    ``step``, ``time`` and ``name.component``; empty without ``[[measure]]``).

    ``summary`` keys: steps, time, wall_seconds, compile_seconds (of the wall time, numba
    compiling kernels that were not in its cache yet: 0 on a warm install), iterations
    (linear solves: Newton iterations and chord steps, dda.solve.newton),
    iterations_per_step, newton_iterations
    (assembled systems solved), newton_iterations_per_step, factorisations,
    max_penetration, active_effects, stage_seconds, contact_method, cut_steps,
    search_redos (steps redone after a contact search with the full distance,
    dda.contact.reach), friction_dissipation (work of the friction forces against the
    slips, dda.contact.law.friction_dissipation), status ("finished", "interrupted" by
    ``stop``, "failed"), environment (dda.run.environment).
    """

    frames: list[Frame]
    fracture_events: list[FractureEvent] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    history: dict[str, np.ndarray] = field(default_factory=dict)
    bolt_events: list[BoltEvent] = field(default_factory=list)
    measurements: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def final(self) -> Frame:
        return self.frames[-1]
