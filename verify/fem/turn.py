"""A scene turned rigidly: the FEM model of a case whose block comes to rest turned.

A block that turns by a large angle while it carries its load (a hung block
swinging down to where it hangs, in a static run) ends in the state of the
scene turned by that angle. The FEM, small-strain, solves the turned scene;
the DDA's displacements and strains are measured from the turned scene's
geometry (:class:`verify.comparison.dda_side.DdaSide`), and its stress, in the current
axes, is compared as it is. Blocks, fixed points and load points turn; load
vectors and gravity do not (they keep their direction in space).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from dda import Scene


def turn_points(points, degrees: float, about) -> tuple[tuple[float, float], ...]:
    """Points turned anticlockwise by ``degrees`` about ``about``."""
    if not len(points):
        return ()
    a = np.radians(degrees)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    centre = np.asarray(about, dtype=float)
    moved = (np.asarray(points, dtype=float) - centre) @ turn.T + centre
    return tuple((float(x), float(y)) for x, y in moved)


def turned_scene(scene: Scene, degrees: float, about) -> Scene:
    """``scene`` with every block, fixed point and load point turned by ``degrees``."""
    if not degrees:
        return scene
    blocks = tuple(
        replace(
            b,
            vertices=turn_points(b.vertices, degrees, about),
            fixed_points=turn_points(b.fixed_points, degrees, about),
        )
        for b in scene.blocks
    )
    loads = tuple(
        replace(load, point=turn_points([load.point], degrees, about)[0]) for load in scene.loads
    )
    return replace(scene, blocks=blocks, loads=loads)
