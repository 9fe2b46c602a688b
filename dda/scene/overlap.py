"""Pairs of blocks that share area: one STRtree query, never all pairs.

Used where a scene is loaded (blocks drawn overlapping are refused) and where a run
ends (blocks that came to overlap deeper than their contacts' penetration: a contact
the run did not find, :mod:`dda.run.deep_overlap`).
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from dda.geometry import next_vertex_index, owner_of_vertex


def block_polygons(vertices: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(n,) shapely polygons of the packed blocks (``vertices[offsets[i]:offsets[i+1]]``)."""
    return shapely.polygons(shapely.linearrings(vertices, indices=owner_of_vertex(offsets)))


OVERLAY_GRID = 1e-12  # of the model's size: the grid the shared regions are snapped to


def sharing_area(
    polygons: np.ndarray,
    vertices: np.ndarray,
    offsets: np.ndarray,
    areas: np.ndarray,
    fraction: float,
    thinnest: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, shared) the pairs of blocks (left < right) whose ``polygons`` share
    more than ``fraction`` of the smaller of their ``areas``, and each pair's shared
    region (shapely polygons); where ``thinnest`` is given, only the regions that may be
    deeper than it (2 area / perimeter is at most the smaller side of the boxes' overlap:
    blocks pressed together along a face are skipped before any intersection).

    Candidate pairs come from one STRtree query ("intersects") in the frame of the
    blocks' most common edge direction (:func:`search_turn`), so the cost is near
    O(n log n); touching along an edge or at a point shares no area."""
    turn = search_turn(vertices, offsets)
    searched = polygons
    if turn is not None:
        searched = shapely.transform(polygons, lambda xy: xy @ turn)
    tree = shapely.STRtree(searched)
    left, right = tree.query(searched, predicate="intersects")
    left, right = left[left < right], right[left < right]
    limit = fraction * np.minimum(areas[left], areas[right])
    # the shared area is at most the shared bounding-box area: skip pairs below the limit
    bounds = shapely.bounds(searched)
    width, height = _box_overlap(bounds[left], bounds[right])
    possible = width * height > limit
    if thinnest > 0.0:
        possible &= np.minimum(width, height) > thinnest
    left, right, limit = left[possible], right[possible], limit[possible]
    # blocks whose interiors do not meet share nothing: GEOS 3.14's overlay returned the
    # whole of one of two blocks that share an edge whose ends differ by one ulp (an
    # audit: "overlapped by 3.77 m²" in a model that had not moved); the intersection
    # itself is snap-rounded on a grid of round-off size, which such ends cannot fool
    inside = shapely.relate_pattern(polygons[left], polygons[right], "T********")
    left, right, limit = left[inside], right[inside], limit[inside]
    grid = OVERLAY_GRID * float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    shared = shapely.intersection(polygons[left], polygons[right], grid_size=grid)
    keep = shapely.area(shared) > limit
    return left[keep], right[keep], shared[keep]


def _box_overlap(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(width, height) of the overlap of bounding boxes (xmin, ymin, xmax, ymax), row by
    row (0 where they do not overlap)."""
    width = np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
    height = np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1])
    return np.clip(width, 0.0, None), np.clip(height, 0.0, None)


def search_turn(vertices: np.ndarray, offsets: np.ndarray) -> np.ndarray | None:
    """R (2 × 2) with ``xy @ R`` turning the blocks' most common edge direction (the
    length-weighted peak of a histogram in 1° bins) to x; None when it lies along an
    axis already.

    Blocks cut by one inclined joint set are thin strips whose bounding boxes all
    overlap one another's, so a search by boxes tests every pair (4,085 strips took
    8.7 s of CPU); turned along x their boxes are thin and overlap only their
    neighbours'. Blocks of no common direction are turned harmlessly.
    """
    edge = vertices[next_vertex_index(offsets)] - vertices
    length = np.hypot(edge[:, 0], edge[:, 1])
    angle = np.mod(np.arctan2(edge[:, 1], edge[:, 0]), np.pi)  # [0, π)
    bins = np.minimum((angle * (180.0 / np.pi)).astype(np.int64), 179)
    peak = bins == np.argmax(np.bincount(bins, weights=length, minlength=180))
    if length[peak].sum() <= 0.0:
        return None
    theta = float(np.average(angle[peak], weights=length[peak]))
    if min(theta, abs(theta - 0.5 * np.pi), np.pi - theta) < 1e-9:
        return None
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])
