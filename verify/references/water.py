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

Reference ``kinked_table`` of kind ``motion`` (:func:`kinked_table`): a block on a
level frictionless base under a table with a kink above it, where F_x changes as
the block moves: m x″ = F_x(x), integrated with scipy.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda import Scene
from verify.comparison.expect import ExpectationError
from verify.fem.interfaces import find_interfaces
from verify.references.block import Motion, block_mass


def water_force(scene: Scene, block: int) -> np.ndarray:
    """(Fx, Fy): the water pressure's resultant on the scene block (module notes)."""
    water = scene.water
    if water is None or scene.blocks[block].fixed:
        return np.zeros(2)
    return force_on(np.asarray(scene.blocks[block].vertices, dtype=float), water)


def force_on(vertices: np.ndarray, water) -> np.ndarray:
    """(Fx, Fy): the resultant of the pressure of ``water`` (a scene's ``[water]``) on the
    polygon ``vertices`` (module notes)."""
    table = np.asarray(water.table, dtype=float)
    polygon = shapely.Polygon(vertices)
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


def kinked_table(scene: Scene, block: int, times: np.ndarray):
    """Reference ``kinked_table`` of kind ``motion``: one free block at rest on a level,
    frictionless fixed base, no loads, gravity down, under a water table with kinks.
    The pressure's horizontal resultant F_x(x) = −γw Σ h′_k |W_k| changes as the block
    moves along the base (the areas of its wet part under each stretch of the table
    change); nothing else acts along the base, so m x″ = F_x(x), integrated with scipy
    (rtol 1e-11) from rest; u_y = 0 (the base carries the weight less the buoyancy,
    which must not lift the block) and r = 0 (the base's contacts carry the moment)."""
    from scipy.integrate import solve_ivp

    interfaces = [i for i in find_interfaces(scene) if block in i.pair]
    g = np.asarray(scene.analysis.gravity, dtype=float)
    if (
        scene.water is None
        or len(interfaces) != 1
        or g[0] != 0.0
        or scene.loads
        or any(scene.blocks[block].velocity)
        or interfaces[0].joint.friction_angle != 0.0
        or interfaces[0].joint.cohesion
    ):
        raise ExpectationError(
            f"{scene.source}: reference 'kinked_table': one frictionless interface, "
            "water, vertical gravity, no loads, at rest"
        )
    coords = np.asarray(interfaces[0].line.coords)
    if abs(coords[-1, 1] - coords[0, 1]) > 1e-12 * np.ptp(coords[:, 0]):
        raise ExpectationError(f"{scene.source}: reference 'kinked_table': a level interface")
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    mass = block_mass(scene, block)
    if force_on(vertices, scene.water)[1] + mass * g[1] >= 0.0:
        raise ExpectationError(f"{scene.source}: reference 'kinked_table': the block floats")

    def rhs(_t, y):
        shifted = vertices + np.array([y[0], 0.0])
        return [y[1], force_on(shifted, scene.water)[0] / mass]

    t = np.asarray(times, dtype=float)
    sol = solve_ivp(
        rhs, (0.0, float(t.max())), [0.0, 0.0], dense_output=True, rtol=1e-11, atol=1e-14
    )
    u = np.column_stack([sol.sol(t)[0], np.zeros(len(t))])
    return Motion(u, np.zeros(len(t)), np.ones(len(t), bool), {})


REFERENCES = {"kinked_table": kinked_table}
