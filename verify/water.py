"""The water table's force on a block, from the scene alone.

With the phreatic line y = h(x) (``[water] table``, linear between its points,
level beyond its ends) and γw its unit weight, the pressure is
p = γw ⟨h(x) − y⟩₊ on every edge of a free block. p vanishes on the table, so
by the divergence theorem the resultant of the pressure on the block's
boundary is the integral of −∇p over its wet part W (below the table):

    F = −∫∫_W ∇p dA = γw (−∫∫_W h′(x) dA, |W|)

h′ is constant on each stretch of the table (0 beyond its ends): the integral is
a sum of h′_k times the area of W in each stretch. A block wholly under one
straight stretch feels the constant γw |A| (−h′, 1), through its centroid.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda import Scene


def water_force(scene: Scene, block: int) -> np.ndarray:
    """(Fx, Fy): the water pressure's resultant on the scene block (module notes)."""
    water = scene.water
    if water is None or scene.blocks[block].fixed:
        return np.zeros(2)
    table = np.asarray(water.table, dtype=float)
    polygon = shapely.Polygon(np.asarray(scene.blocks[block].vertices, dtype=float))
    x0, y0, x1, y1 = polygon.bounds
    far = 10.0 * (x1 - x0 + y1 - y0 + np.ptp(table[:, 0]) + np.ptp(table[:, 1])) + 1.0
    left, right = min(x0, table[0, 0]) - far, max(x1, table[-1, 0]) + far
    line = np.vstack([[left, table[0, 1]], table, [right, table[-1, 1]]])
    bottom = min(y0, table[:, 1].min()) - far
    below = shapely.Polygon(np.vstack([line, [[right, bottom], [left, bottom]]]))
    wet = polygon.intersection(below)
    fx = 0.0
    for (xa, ya), (xb, yb) in zip(line[:-1], line[1:], strict=True):
        stretch = shapely.box(xa, bottom - far, xb, max(y1, line[:, 1].max()) + far)
        fx -= (yb - ya) / (xb - xa) * wet.intersection(stretch).area
    return water.unit_weight * np.array([fx, wet.area])


def uniform_under_table(scene: Scene, block: int) -> bool:
    """Whether the block lies wholly under one straight stretch of the table (or there
    is no water): its water force is then the same wherever it moves in that stretch."""
    if scene.water is None:
        return True
    table = np.asarray(scene.water.table, dtype=float)
    v = np.asarray(scene.blocks[block].vertices, dtype=float)
    head = np.interp(v[:, 0], table[:, 0], table[:, 1])
    inside = np.searchsorted(table[:, 0], v[:, 0])
    same = inside.min() == inside.max() and 0 < inside[0] < len(table)
    return bool(np.all(head > v[:, 1]) and same)
