"""Material points that move with their block (load points, fixed points)."""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.kinematics import move_points


class MaterialPoints:
    """Points attached to blocks, moved by each accepted step.

    ``rows`` index the current BlockSet; after a split each point goes to
    the child that contains it (or the nearest child).
    """

    def __init__(self, rows: np.ndarray, positions: np.ndarray) -> None:
        self.rows = np.asarray(rows, dtype=np.int64)
        self.positions = np.asarray(positions, dtype=float).reshape(-1, 2)

    def __len__(self) -> int:
        return len(self.rows)

    def move(self, blocks: BlockSet, d: np.ndarray, exact_rotation: bool) -> None:
        """Apply the step ``d`` (n, 6) of each point's block."""
        if len(self.rows):
            self.positions = move_points(
                self.positions, blocks.centroid[self.rows], d[self.rows], exact_rotation
            )

    def reassign(self, new: BlockSet, parent_of: np.ndarray) -> None:
        """Give each point to the child (of its old block) that holds it."""
        if not len(self.rows):
            return
        new_rows = np.empty_like(self.rows)
        for k, (old_row, p) in enumerate(zip(self.rows, self.positions, strict=True)):
            children = np.flatnonzero(parent_of == old_row)
            # one Polygon each: the children's rings have different lengths
            polys = [shapely.Polygon(new.polygon(c)) for c in children]
            dist = shapely.distance(polys, shapely.Point(p))
            new_rows[k] = children[int(np.argmin(dist))]
        self.rows = new_rows
