"""Joint of each edge of a fragment: the parent's where it lies on a parent edge, else a crack."""

from __future__ import annotations

import numpy as np

ON_EDGE_RATIO = 1e-8  # distance / block size under which a point lies on a parent edge


def fragment_edge_joints(
    parent: np.ndarray,
    parent_joints: np.ndarray,
    fragment: np.ndarray,
    crack_joint: int,
) -> np.ndarray:
    """Joint row of every edge of ``fragment`` (edge k runs from vertex k to k+1).

    An edge whose two ends lie on the same parent edge (within a distance
    relative to the parent's size) is part of that parent edge and keeps its
    joint; any other edge is a new crack and gets ``crack_joint``.

    Parameters
    ----------
    parent : (k, 2) parent polygon
    parent_joints : (k,) joint row of each parent edge (-1: default)
    fragment : (m, 2) child polygon, cut from ``parent``
    crack_joint : joint row for the new crack surfaces (-1: default)
    """
    tol = ON_EDGE_RATIO * float(np.max(np.ptp(parent, axis=0)))
    start, end = fragment, np.roll(fragment, -1, axis=0)
    on_start = _on_segments(start, parent, tol)  # (m, k)
    on_end = _on_segments(end, parent, tol)
    both = on_start & on_end
    found = both.any(axis=1)
    which = np.argmax(both, axis=1)
    return np.where(found, np.asarray(parent_joints)[which], crack_joint).astype(np.int64)


def _on_segments(points: np.ndarray, polygon: np.ndarray, tol: float) -> np.ndarray:
    """(m, k) True where point i lies within ``tol`` of edge j of ``polygon``."""
    a = polygon
    edge = np.roll(polygon, -1, axis=0) - a
    length2 = np.maximum(np.einsum("ij,ij->i", edge, edge), np.finfo(float).tiny)
    rel = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("ijk,jk->ij", rel, edge) / length2, 0.0, 1.0)
    nearest = a[None, :, :] + t[:, :, None] * edge[None, :, :]
    return np.linalg.norm(points[:, None, :] - nearest, axis=2) <= tol
