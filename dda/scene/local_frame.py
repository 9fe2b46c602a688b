"""The frame the engine computes in: centred on the model when it lies far from the origin.

Coordinates of 1e9 m carry about 1e-7 m of round-off, and the engine's sums of
vertex products (areas, moments of inertia about the origin, then shifted to
the centroid) cancel away every digit that a step's displacements need. A
scene whose centre lies farther from the origin than its own size is
therefore translated by ``origin`` (its centre, rounded to a power of two of
its size) before the run, and the frames are translated back. The shift is
exact: ``x - origin`` of two doubles within a factor of two of each other has
no round-off (Sterbenz), so the local scene holds exactly the input's digits.
A scene near the origin is not moved (origin 0), and runs as before.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from dda.geometry import power_of_two_centre

FAR = 1.0  # a centre farther than FAR x the model's size from the origin is moved to it


def local_origin(scene: Any) -> tuple[float, float]:
    """Where the engine puts its origin for ``scene``: (0, 0), or the model's rounded centre
    (:func:`origin_of` its blocks' vertices)."""
    points = np.concatenate([np.asarray(b.vertices, float) for b in scene.blocks])
    ox, oy = origin_of(points)
    return (float(ox), float(oy))


def origin_of(points: np.ndarray) -> np.ndarray:
    """(0, 0) for points whose bounding box's centre is within ``FAR`` x its diagonal of
    the origin; else that centre, rounded to a multiple of the power of two at or above
    the diagonal (a short number; subtracting it is exact)."""
    if len(points) == 0:
        return np.zeros(2)
    low, high = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * low + 0.5 * high
    size = float(np.hypot(*(high - low)))
    if not np.all(np.isfinite(centre)) or not np.isfinite(size):
        return np.zeros(2)
    if np.hypot(*centre) <= FAR * size:
        return np.zeros(2)
    return power_of_two_centre(low, high, size) + 0.0  # no -0.0


def translated(scene: Any, origin: tuple[float, float]) -> Any:
    """``scene`` with every position less ``origin``: vertices, fixed points, load points,
    bolt ends (also the staged ones), the water table, measurement points, the boxes of
    boundary stresses; stress fields that vary with y give the same stresses there."""
    if origin == (0.0, 0.0):
        return scene
    ox, oy = origin

    def point(p):
        return None if p is None else (p[0] - ox, p[1] - oy)

    def points(ps):
        return tuple(point(p) for p in ps)

    def bolt(b):
        return dataclasses.replace(b, start=point(b.start), end=point(b.end))

    blocks = tuple(
        dataclasses.replace(b, vertices=points(b.vertices), fixed_points=points(b.fixed_points))
        for b in scene.blocks
    )
    changes: dict[str, Any] = {
        "blocks": blocks,
        "loads": tuple(dataclasses.replace(load, point=point(load.point)) for load in scene.loads),
        "bolts": tuple(bolt(b) for b in scene.bolts),
        "stages": tuple(
            dataclasses.replace(
                s,
                bolts=tuple(bolt(b) for b in s.bolts),
                boundary_stresses=tuple(b.shifted(ox, oy) for b in s.boundary_stresses),
            )
            for s in scene.stages
        ),
        "measure": tuple(dataclasses.replace(m, point=point(m.point)) for m in scene.measure),
        "boundary_stresses": tuple(b.shifted(ox, oy) for b in scene.boundary_stresses),
    }
    if scene.in_situ is not None:  # the same stresses at the same places
        changes["in_situ"] = scene.in_situ.shifted(oy)
    if scene.water is not None:
        changes["water"] = dataclasses.replace(scene.water, table=points(scene.water.table))
    return dataclasses.replace(scene, **changes)
