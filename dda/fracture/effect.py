"""The fracture effect: after each accepted step, break the blocks that fail (paper §4).

``FractureEffect.after_step(blocks, ctx)`` evaluates the three-parameter
Mohr–Coulomb criterion (22)–(25) at the centroid of every breakable block,
cuts the failing ones through their centroid (two planes in shear, one in
tension), and returns a new BlockSet plus one :class:`FractureEvent` per
broken block. A block breaks at most once per step: its fragments are
judged again at the next step only.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import Effect, StepContext
from dda.fracture.criterion import MODE_NAMES, evaluate, strength_numbers
from dda.fracture.fragments import Fragments, replace_blocks
from dda.fracture.split import DEFAULT_MIN_AREA_RATIO, split_polygon_detailed
from dda.result import FractureEvent
from dda.scene import Scene

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Strength:
    """Strength of every material row; NaN cohesion marks an unbreakable material.

    Attributes
    ----------
    cohesion : (n_materials,) s0
    friction_angle : (n_materials,) φ in radians
    tensile_strength : (n_materials,) T0
    """

    cohesion: np.ndarray
    friction_angle: np.ndarray
    tensile_strength: np.ndarray

    @property
    def breakable(self) -> np.ndarray:
        return np.isfinite(self.cohesion)

    @classmethod
    def from_scene(cls, scene: Scene) -> Strength:
        """Rows in the order of ``scene.materials`` (the model's material table)."""
        materials = list(scene.materials.values())

        def column(key: str, scale: float = 1.0) -> np.ndarray:
            values = [getattr(m, key) if m.breakable else None for m in materials]
            return np.array([np.nan if v is None else scale * v for v in values], dtype=float)

        return cls(
            cohesion=column("cohesion"),
            friction_angle=column("friction_angle", math.pi / 180.0),
            tensile_strength=column("tensile_strength"),
        )


_SAID: set[tuple[str, float, float]] = set()  # the notes of _note_tension_beyond_shear


def _note_tension_beyond_shear(names: list[str], strength: Strength) -> None:
    """Say which materials have a tensile strength T0 above the shear criterion's own
    tension intercept C0 / N: uniaxial tension breaks such a block in shear at C0 / N,
    and the tension cut-off acts only where both principal stresses are tensile."""
    n_phi, c0, _ = strength_numbers(
        strength.cohesion, strength.friction_angle, strength.tensile_strength
    )
    with np.errstate(invalid="ignore"):
        intercept = c0 / n_phi
        beyond = strength.tensile_strength > intercept  # NaN (unbreakable): False
    for k in np.flatnonzero(beyond):
        said = (names[k], float(strength.tensile_strength[k]), float(intercept[k]))
        if said in _SAID:  # once a process: dda fos and dda ensemble build many models
            continue
        _SAID.add(said)
        log.warning(
            "materials.%s: tensile_strength %.4g is above the shear criterion's tension "
            "intercept C0 / N = %.4g (cohesion, friction_angle): uniaxial tension breaks "
            "the block in shear at %.4g, and the tension cut-off acts only under biaxial "
            "tension",
            names[k], strength.tensile_strength[k], intercept[k], intercept[k],
        )  # fmt: skip


class FractureEffect(Effect):
    """Breaks failing blocks after each accepted step.

    Unlike the other effects it adds nothing to K or F; the time loop calls
    ``after_step(blocks, ctx)`` and takes the returned BlockSet.

    Parameters
    ----------
    strength : per-material strength table
    crack_joint : joint row given to new crack edges (-1: the default joint)
    min_area : smallest fragment kept on its own (smaller slivers are merged)
    next_id : first id given to a fragment; ids are never reused
    """

    name = "fracture"

    def __init__(self, strength: Strength, crack_joint: int, min_area: float, next_id: int):
        self.strength = strength
        self.crack_joint = int(crack_joint)
        self.min_area = float(min_area)
        self.next_id = int(next_id)

    @classmethod
    def from_scene(cls, scene: Scene, blocks: BlockSet) -> FractureEffect:
        """From the scene's materials and ``[fracture]`` table, and the initial blocks."""
        strength = Strength.from_scene(scene)
        joint_names = list(scene.joints)
        name = scene.fracture.joint
        crack = joint_names.index(name) if name is not None else -1  # -1: the default joint
        min_area = scene.fracture.min_area
        if min_area is None:
            breakable = strength.breakable[blocks.material]
            smallest = blocks.area[breakable].min() if breakable.any() else 0.0
            min_area = DEFAULT_MIN_AREA_RATIO * smallest
        next_id = int(blocks.ids.max()) + 1 if blocks.count else 0
        _note_tension_beyond_shear(list(scene.materials), strength)
        return cls(strength, crack, min_area, next_id)

    def candidates(self, blocks: BlockSet) -> np.ndarray:
        """Rows of the blocks the criterion applies to: breakable material, not fixed."""
        return np.flatnonzero(self.strength.breakable[blocks.material] & ~blocks.fixed)

    def after_step(  # type: ignore[override]
        self, blocks: BlockSet, ctx: StepContext
    ) -> tuple[BlockSet, list[FractureEvent]]:
        """Break every failing block once; return the new blocks and the events."""
        rows = self.candidates(blocks)
        if not len(rows):
            return blocks, []
        mat = blocks.material[rows]
        s = self.strength
        state = evaluate(
            blocks.stress[rows], s.cohesion[mat], s.friction_angle[mat], s.tensile_strength[mat]
        )
        failing = state.failing
        # two pieces of at least min_area each need twice that: smaller blocks cannot split
        failing = failing[blocks.area[rows[failing]] >= 2.0 * self.min_area]
        if not len(failing):
            return blocks, []
        fragments: list[Fragments] = []
        events: list[FractureEvent] = []
        for k in failing:  # only the few blocks that break
            row = int(rows[k])
            pieces = self._cut(blocks, row, state.planes[k])
            if pieces is not None:
                mode = MODE_NAMES[int(state.mode[k])]
                fragments.append(pieces)
                events.append(
                    FractureEvent(
                        int(ctx.step),
                        float(ctx.time),
                        blocks.names[row],
                        pieces.names,
                        mode,
                        tuple(float(x) for x in blocks.stress[row]),
                    )  # fmt: skip
                )
        if not fragments:
            return blocks, []
        log.info("step %d: %d block(s) broke: %s", ctx.step, len(events), _describe(events))
        return replace_blocks(blocks, fragments), events

    def _cut(self, blocks: BlockSet, row: int, planes: np.ndarray) -> Fragments | None:
        """Split block ``row`` along ``planes``; None if it does not split."""
        centroid = blocks.centroid[row]
        result = split_polygon_detailed(blocks.polygon(row), centroid, planes, self.min_area)
        if not result.split:
            log.debug("%s fails but is not split (refused: %s)", blocks.names[row], result.refused)
            return None
        ids = np.arange(self.next_id, self.next_id + len(result.pieces), dtype=np.int64)
        self.next_id += len(result.pieces)
        names = tuple(f"{blocks.names[row]}/{j + 1}" for j in range(len(result.pieces)))
        return Fragments.of(blocks, row, result.pieces, names, ids, self.crack_joint)


def _describe(events: list[FractureEvent], shown: int = 4) -> str:
    text = ", ".join(f"{e.parent} ({e.mode}, {len(e.children)})" for e in events[:shown])
    return text + (f" and {len(events) - shown} more" if len(events) > shown else "")
