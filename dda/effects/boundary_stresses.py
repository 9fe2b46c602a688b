"""Boundary stresses: the traction of a far-field stress on a model's outer edges."""

from __future__ import annotations

import numpy as np

from dda.effects.loads import PointLoads
from dda.effects.points import MaterialPoints
from dda.scene.edge_cover import outer_pieces

# a stage's change takes effect from the step after the one ending at its time: this
# fraction of the step's time is the round-off allowed on that time
TIME_TOLERANCE = 1e-9


class BoundaryStresses(PointLoads):
    """F_i += T_i(x)ᵀ f at the two ends of every loaded outer edge piece (dead loads: the
    forces the traction σ·n gives them where the scene draws them,
    :meth:`dda.scene.in_situ.StressField.segment_forces`, applied at material points
    that move with the block), each set on from ``on`` to ``off``."""

    name = "boundary_stresses"

    def __init__(
        self,
        points: MaterialPoints,
        force: np.ndarray,
        on: np.ndarray,
        off: np.ndarray,
        exact_rotation: bool,
        time_step: float,
    ) -> None:
        super().__init__(points, force, [None] * len(points), exact_rotation)
        self.on, self.off = np.asarray(on, float), np.asarray(off, float)
        self.tolerance = TIME_TOLERANCE * time_step

    def on_blocks_replaced(self, old, new, parent_of: np.ndarray) -> None:
        """Blocks were split or removed (``parent_of[k]``: the old row of new block k): the
        loads of a removed block's edges go with it, the rest follow their blocks."""
        kept = np.isin(self.points.rows, parent_of)
        if not kept.all():
            self.points = MaterialPoints(self.points.rows[kept], self.points.positions[kept])
            self.force, self.on, self.off = self.force[kept], self.on[kept], self.off[kept]
            self.histories = [h for h, k in zip(self.histories, kept, strict=True) if k]
        super().on_blocks_replaced(old, new, parent_of)

    def factors(self, time: float) -> np.ndarray:
        """1 for the forces of a set in force over a step ending at ``time`` (those of the
        scene at t = 0 too: the equilibrium start), else 0."""
        begun = (time > self.on + self.tolerance) | (self.on == 0.0)
        return (begun & (time <= self.off + self.tolerance)).astype(float)


def boundary_stress_loads(scene, fixed: np.ndarray, exact_rotation: bool) -> BoundaryStresses:
    """The effect of ``scene.boundary_stresses``: for each, the outer edge pieces of the
    free blocks there at its time (:func:`dda.scene.edge_cover.outer_pieces`) whose
    midpoints lie in its box, loaded by σ·n at their ends."""
    polygons = [np.asarray(b.vertices, float) for b in scene.blocks]
    rows, points, forces, on, off = [], [], [], [], []
    for stress in scene.boundary_stresses:
        gone = {n for s in scene.stages if s.time <= stress.on for n in s.remove}
        present = np.array([b.name not in gone for b in scene.blocks], bool)
        pieces = outer_pieces(polygons, present)
        pieces = pieces.subset(
            np.flatnonzero(stress.selects(pieces.midpoint) & ~fixed[pieces.block])
        )
        f_start, f_end = stress.field.segment_forces(pieces.start, pieces.end, pieces.normal)
        count = 2 * len(pieces.block)
        rows.append(np.concatenate([pieces.block, pieces.block]))
        points.append(np.concatenate([pieces.start, pieces.end]))
        forces.append(np.concatenate([f_start, f_end]))
        on.append(np.full(count, stress.on))
        off.append(np.full(count, stress.off))
    return BoundaryStresses(
        MaterialPoints(np.concatenate(rows), np.concatenate(points)),
        np.concatenate(forces), np.concatenate(on), np.concatenate(off), exact_rotation,
        scene.analysis.time_step,
    )  # fmt: skip
