"""Shi's first-order displacement field of a block (paper eq. 2).

For a point (x, y) of block i with reference point (x0, y0) (the centroid)::

    [u]   [1 0 -(y-y0) (x-x0) 0      (y-y0)/2] D_i = T_i(x, y) D_i
    [v] = [0 1  (x-x0) 0      (y-y0) (x-x0)/2]

with D_i = (u0, v0, r0, ex, ey, gxy).
"""

from __future__ import annotations

import numpy as np


def displacement_matrices(points: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """T(x, y) for many points at once.

    Parameters
    ----------
    points : (m, 2) positions
    centroids : (m, 2) reference point of the block each point belongs to

    Returns
    -------
    (m, 2, 6) array, ``T[k] @ D`` is the displacement of point k.
    """
    dx = points[:, 0] - centroids[:, 0]
    dy = points[:, 1] - centroids[:, 1]
    m = len(points)
    t = np.zeros((m, 2, 6))
    t[:, 0, 0] = 1.0
    t[:, 1, 1] = 1.0
    t[:, 0, 2] = -dy
    t[:, 1, 2] = dx
    t[:, 0, 3] = dx
    t[:, 1, 4] = dy
    t[:, 0, 5] = dy / 2.0
    t[:, 1, 5] = dx / 2.0
    return t


def project_rows(directions: np.ndarray, points: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """Rows ``dirᵀ T(x, y)`` (m, 6): the displacement of each point along a direction."""
    t = displacement_matrices(points, centroids)
    return np.einsum("mk,mkr->mr", directions, t)


def move_points(
    points: np.ndarray,
    centroids: np.ndarray,
    d: np.ndarray,
    exact_rotation: bool = True,
) -> np.ndarray:
    """New positions of material points after a step with unknowns ``d`` (m, 6).

    Exact update (default): rotate by r0 about the centroid, then add the
    translation and the strain part ``[[ex, gxy/2], [gxy/2, ey]] (x - x0)``;
    the rigid motion then preserves area exactly. Linear update (Shi):
    ``x + T D``, which inflates a rotating block by (1 + r0²) per step.
    """
    rel = points - centroids
    if not exact_rotation:
        return points + np.einsum("mkr,mr->mk", displacement_matrices(points, centroids), d)
    x, y = exact_position(
        centroids[:, 0], centroids[:, 1], rel[:, 0], rel[:, 1], np.cos(d[:, 2]),
        np.sin(d[:, 2]), d[:, 0], d[:, 1], d[:, 3], d[:, 4], d[:, 5],
    )  # fmt: skip
    return np.column_stack([x, y])


def exact_position(cx, cy, rel_x, rel_y, cos_r, sin_r, u0, v0, ex, ey, gxy):
    """(x, y) of the point at ``rel`` from the centroid (cx, cy) after the exact update of
    :func:`move_points` (rotation by r0, then translation and strain), element by element
    (arrays or numbers: the compiled update, :mod:`dda.solve.update`, calls it on numbers)."""
    g = gxy / 2.0
    rx = cos_r * rel_x - sin_r * rel_y
    ry = sin_r * rel_x + cos_r * rel_y
    sx = ex * rel_x + g * rel_y
    sy = g * rel_x + ey * rel_y
    return cx + u0 + rx + sx, cy + v0 + ry + sy
