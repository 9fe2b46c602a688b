"""Motion and stress handed from a broken block to its pieces (paper §4).

The parent's velocity field is Shi's displacement field (THEORY §1, eq. 2)
applied to the velocity vector ``(u0', v0', r0', ex', ey', gxy')`` about the
parent centroid (x0, y0)::

    vx(x, y) = u0' − r0' (y − y0) + ex' (x − x0) + gxy' (y − y0) / 2
    vy(x, y) = v0' + r0' (x − x0) + ey' (y − y0) + gxy' (x − x0) / 2

Each child gets this field evaluated at its own centroid as its
translation rate, and the parent's rotation and strain rates. The field is
affine, so the child's field about its own centroid *is* the parent's field
restricted to the child, point by point. Consequently linear momentum,
angular momentum (about any point) and kinetic energy of the pieces equal
the parent's, up to round-off: the split dissipates nothing, as the paper
assumes. The stress is constant in a DDA block, so every child inherits it.
"""

from __future__ import annotations

import numpy as np


def velocity_at(velocity6: np.ndarray, centroid: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Velocity (vx, vy) of the parent's field (eq. 2) at ``points`` (m, 2)."""
    u, v, r, ex, ey, gxy = np.asarray(velocity6, dtype=float)
    d = np.atleast_2d(np.asarray(points, dtype=float)) - np.asarray(centroid, dtype=float)
    dx, dy = d[:, 0], d[:, 1]
    vx = u - r * dy + ex * dx + 0.5 * gxy * dy
    vy = v + r * dx + ey * dy + 0.5 * gxy * dx
    return np.column_stack([vx, vy])


def children_state(
    parent_velocity6: np.ndarray,
    parent_centroid: np.ndarray,
    parent_stress: np.ndarray,
    child_centroids: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Velocity vectors and stresses of the children of one broken block.

    Parameters
    ----------
    parent_velocity6 : (6,) (u0', v0', r0', ex', ey', gxy') about the parent centroid
    parent_centroid : (2,)
    parent_stress : (3,) sxx, syy, sxy
    child_centroids : (m, 2)

    Returns
    -------
    velocity : (m, 6) each child's six rates about its own centroid
    stress : (m, 3) the parent's stress, repeated
    """
    centroids = np.atleast_2d(np.asarray(child_centroids, dtype=float))
    m = len(centroids)
    velocity = np.repeat(np.asarray(parent_velocity6, dtype=float)[None, :], m, axis=0)
    velocity[:, :2] = velocity_at(parent_velocity6, parent_centroid, centroids)
    stress = np.repeat(np.asarray(parent_stress, dtype=float)[None, :], m, axis=0)
    return velocity, stress
