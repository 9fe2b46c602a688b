"""Measurement points: the ``[[measure]]`` quantities of a run, one row per step.

Kinds of entry and their columns (``name.component``, docs/scene.md):

- a material point (moves with its block): ``displacement`` ux, uy since
  the start; ``velocity`` vx, vy of the point (T(x, y) v of docs/theory.md §1);
  ``stress`` sxx, syy, sxy of its block;
- a pair of blocks: ``contact_force`` N, the sum of the normal forces of
  the contacts between them, and fx, fy, the resultant force the second
  block exerts on the first (normal and friction forces);
- a bolt: ``bolt_force``, its tension (0 before it is installed and once broken).

Rows are kept per step (8 bytes a number, like the run's history) and handed
to the frames as they are made, so writers stream ``history_points.csv``.
"""

from __future__ import annotations

from array import array

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.rows import contact_rows
from dda.effects.points import MaterialPoints
from dda.kinematics import displacement_matrices


class Probes:
    """The measurements of a run and their log.

    Parameters
    ----------
    measures : the scene's ``[[measure]]`` entries (:class:`dda.scene.engineering.Measure`)
    blocks : the blocks at t = 0 (ids equal scene rows)
    bolt_names : names of the run's bolts, in the order of :class:`dda.effects.bolts.RockBolts`
    exact_rotation : how the points move with their blocks
    """

    def __init__(self, measures, blocks: BlockSet, bolt_names: list[str], exact_rotation: bool):
        row = {name: k for k, name in enumerate(blocks.names)}
        points = [m for m in measures if m.kind == "point"]
        self.point_quantities = [m.quantities for m in points]
        self.points = MaterialPoints(
            np.array([row[m.block] for m in points], np.int64),
            np.array([m.point for m in points], float).reshape(-1, 2),
        )
        self.initial = self.points.positions.copy()
        pairs = [m for m in measures if m.kind == "contact"]
        self.pairs = np.array([[row[b] for b in m.blocks] for m in pairs], np.int64).reshape(-1, 2)
        self.bolts = np.array([bolt_names.index(m.bolt) for m in measures if m.kind == "bolt"])
        self.bolts = self.bolts.astype(np.int64)
        order = points + pairs + [m for m in measures if m.kind == "bolt"]
        self.columns = ["step", "time", *(c for m in order for c in m.columns())]
        self.exact_rotation = exact_rotation
        self.log = {c: array("d") for c in self.columns}
        self.handed = 0  # rows given to frames so far

    def record(self, step: int, time: float, blocks: BlockSet, contacts: ContactSet, bolts) -> None:
        """Append the row of the state after ``step``."""
        values = [float(step), float(time)]
        values += self._point_values(blocks)
        values += self._pair_values(blocks, contacts)
        if len(self.bolts):
            values += bolts.tension()[self.bolts].tolist()
        for column, value in zip(self.columns, values, strict=True):
            self.log[column].append(value)

    def _point_values(self, blocks: BlockSet) -> list[float]:
        rows, x = self.points.rows, self.points.positions
        moved = x - self.initial
        t = displacement_matrices(x, blocks.centroid[rows])
        velocity = np.einsum("mkr,mr->mk", t, blocks.velocity[rows])
        out: list[float] = []
        for k, quantities in enumerate(self.point_quantities):
            parts = {"displacement": moved[k], "velocity": velocity[k],
                     "stress": blocks.stress[rows[k]]}  # fmt: skip
            for q in quantities:
                out += parts[q].tolist()
        return out

    def _pair_values(self, blocks: BlockSet, contacts: ContactSet) -> list[float]:
        if not len(self.pairs):
            return []
        if not len(contacts):
            return [0.0] * (3 * len(self.pairs))
        rows = contact_rows(blocks, contacts)
        origin_a, origin_b = blocks.origin[contacts.block_a], blocks.origin[contacts.block_b]
        force = (
            contacts.normal_force[:, None] * rows.normals
            - contacts.shear_force[:, None] * rows.tangents
        )  # fmt: skip  on block a
        out: list[float] = []
        for first, second in self.pairs:
            forward = (origin_a == first) & (origin_b == second)
            backward = (origin_a == second) & (origin_b == first)
            normal = contacts.normal_force[forward | backward].sum()
            resultant = force[forward].sum(axis=0) - force[backward].sum(axis=0)
            out += [float(normal), *resultant.tolist()]
        return out

    def take(self) -> dict[str, np.ndarray]:
        """The rows not yet handed to a frame (and they count as handed now)."""
        rows = {c: np.array(v[self.handed :]) for c, v in self.log.items()}
        self.handed = len(self.log["step"])
        return rows

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {c: np.array(v) for c, v in self.log.items()}

    def move(self, blocks: BlockSet, d: np.ndarray) -> None:
        self.points.move(blocks, d, self.exact_rotation)

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        self.points.reassign(new, parent_of)
