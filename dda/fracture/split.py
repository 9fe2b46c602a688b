"""Cut one polygon by straight planes through a point (paper §4).

The block is cut by one (tension) or two (shear) infinite lines through its
centroid. ``shapely.ops.split`` does the cutting; this module makes the
result safe for the engine:

* every piece is accepted (a concave block may give more than 2 or 4);
* pieces below ``min_area`` are merged into the neighbour they share the
  longest edge with (union: the area is kept); if no neighbour fits, the
  split is refused and the block stays whole; where two planes' pieces merge
  back into one (each too small), the block splits along one plane alone;
* new vertices closer than a tolerance relative to the block size to a
  parent vertex, or to each other, are snapped together, consistently in
  every piece, so the pieces still tile the parent exactly;
* pieces come out counter-clockwise, without the closing vertex, without
  repeated consecutive vertices, valid and of positive area. If that cannot
  be guaranteed the parent is returned alone.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString, Polygon
from shapely.ops import split

from dda.geometry import power_of_two_centre

log = logging.getLogger(__name__)

SNAP_RATIO = 1e-9  # snapping distance / block size
STRAIGHT_RATIO = 1e-13  # a new vertex this close (/ block size) to its chord is dropped
FOLD_SINE = 1e-6  # a vertex turning back by less than this sine is a spike tip
AREA_CHECK = 1e-9  # largest accepted relative error of the total area
DEFAULT_MIN_AREA_RATIO = 1e-3  # default smallest piece / parent area


@dataclass(frozen=True)
class SplitResult:
    """Outcome of :func:`split_polygon_detailed`.

    Attributes
    ----------
    pieces : list of (k_i, 2) counter-clockwise arrays (the parent alone if not split)
    merged : number of slivers merged into a neighbour
    refused : True when a cut was found but could not be made safely
    """

    pieces: list[np.ndarray]
    merged: int = 0
    refused: bool = False

    @property
    def split(self) -> bool:
        return len(self.pieces) > 1


def split_polygon(
    polygon: np.ndarray,
    point: np.ndarray,
    directions: np.ndarray | list[float],
    min_area: float | None = None,
) -> list[np.ndarray]:
    """Split a polygon by lines through ``point`` with the given directions.

    Parameters
    ----------
    polygon : (k, 2) counter-clockwise vertices, without the closing vertex
    point : (2,) a point on every cutting line (the centroid; may lie outside)
    directions : angles of the lines from the x axis, rad (NaN entries are ignored)
    min_area : smallest piece kept on its own; default 1e-3 of the parent area

    Returns
    -------
    list of (k_i, 2) arrays
        The children, or ``[polygon]`` when the block is not split.
    """
    return split_polygon_detailed(polygon, point, directions, min_area).pieces


def split_polygon_detailed(
    polygon: np.ndarray,
    point: np.ndarray,
    directions: np.ndarray | list[float],
    min_area: float | None = None,
) -> SplitResult:
    """As :func:`split_polygon`, also saying whether slivers were merged or the cut refused."""
    parent_xy = np.asarray(polygon, dtype=float)
    origin = _local_origin(parent_xy)
    local_xy = parent_xy - origin  # exact: see _local_origin
    parent = Polygon(local_xy)
    if min_area is None:
        min_area = DEFAULT_MIN_AREA_RATIO * parent.area
    size = _size(parent_xy)
    lines = _cutting_lines(local_xy, np.asarray(point, dtype=float) - origin, directions)
    if lines is None:
        return SplitResult([parent_xy])
    tol = SNAP_RATIO * size
    pieces = _snapped_pieces(list(split(parent, lines).geoms), local_xy, tol)
    if len(pieces) < 2:
        return SplitResult([parent_xy])
    pieces, merged = _merge_slivers(pieces, min_area)
    if pieces is None or len(pieces) < 2:
        alone = _one_plane(polygon, point, directions, min_area)
        if alone is not None:
            return alone
    if pieces is None:
        log.debug("split refused: a sliver has no neighbour to merge into")
        return SplitResult([parent_xy], merged, refused=True)
    if len(pieces) < 2:
        return SplitResult([parent_xy], merged)
    arrays = _final_rings(pieces, local_xy, tol, STRAIGHT_RATIO * size)
    if arrays is None or not _tiles_parent(arrays, parent.area):
        log.debug("split refused: cleaned pieces are not a valid tiling of the parent")
        return SplitResult([parent_xy], merged, refused=True)
    if len(arrays) < 2:
        return SplitResult([parent_xy], merged)
    return SplitResult([a + origin for a in arrays], merged)


def _one_plane(polygon, point, directions, min_area: float) -> SplitResult | None:
    """Where the pieces of two crossing planes merge back into one block (each below
    ``min_area``), the split along one of the planes alone whose smallest piece is the
    largest, or None when neither splits: a block of a few times ``min_area`` breaks
    along one shear plane rather than stay whole beyond its strength (an audit: a block
    of 3.3 ``min_area`` in compression at 1.1 C0, four pieces of 0.22-0.28 of it, stayed
    whole, unsaid)."""
    angles = np.asarray(directions, dtype=float).ravel()
    angles = angles[np.isfinite(angles)]
    if len(angles) < 2:
        return None
    results = [split_polygon_detailed(polygon, point, [angle], min_area) for angle in angles]
    split_ones = [r for r in results if r.split]
    if not split_ones:
        return None
    return max(split_ones, key=lambda r: min(_area(piece) for piece in r.pieces))


def _area(ring: np.ndarray) -> float:
    """The area of a counter-clockwise ring (the shoelace formula)."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _local_origin(xy: np.ndarray) -> np.ndarray:
    """A point near the polygon on a power-of-two grid at least as coarse as its larger
    side (:func:`dda.geometry.power_of_two_centre`): the cut is computed in small local
    coordinates, and the parent's vertices come back bit for bit."""
    low, high = xy.min(axis=0), xy.max(axis=0)
    return power_of_two_centre(low, high, float(np.max(high - low)))


def _size(xy: np.ndarray) -> float:
    """Block size: the larger side of the bounding box."""
    return float(np.max(xy.max(axis=0) - xy.min(axis=0)))


def _cutting_lines(
    xy: np.ndarray, point: np.ndarray, directions: np.ndarray | list[float]
) -> MultiLineString | None:
    """Lines through ``point`` long enough to cross the whole polygon."""
    angles = np.asarray(directions, dtype=float).ravel()
    angles = angles[np.isfinite(angles)]
    if len(angles) == 0 or not np.all(np.isfinite(point)):
        return None
    low, high = xy.min(axis=0), xy.max(axis=0)
    reach = 2.0 * (np.linalg.norm(high - low) + np.linalg.norm(point - 0.5 * (low + high))) + 1.0
    unit = np.column_stack([np.cos(angles), np.sin(angles)])
    return MultiLineString([LineString([point - reach * u, point + reach * u]) for u in unit])


def _merge_slivers(pieces: list[Polygon], min_area: float) -> tuple[list[Polygon] | None, int]:
    """Merge every piece below ``min_area`` into the neighbour with the longest shared edge."""
    pieces = list(pieces)
    merged = 0
    while len(pieces) > 1:
        areas = np.array([p.area for p in pieces])
        small = int(np.argmin(areas))
        if areas[small] >= min_area:
            break
        union = _merge_into_neighbour(pieces, small)
        if union is None:
            return None, merged
        target, polygon = union
        pieces[target] = polygon
        del pieces[small]
        merged += 1
    return pieces, merged


def _merge_into_neighbour(pieces: list[Polygon], small: int) -> tuple[int, Polygon] | None:
    """Union of piece ``small`` with its best neighbour, as (neighbour index, polygon)."""
    sliver = pieces[small]
    shared = np.array(
        [
            0.0 if k == small else sliver.boundary.intersection(other.boundary).length
            for k, other in enumerate(pieces)
        ]
    )
    for k in np.argsort(-shared):
        if shared[k] <= 0.0:
            return None
        union = shapely.union(pieces[k], sliver)
        if isinstance(union, Polygon) and not union.interiors and union.is_valid:
            return int(k), union
    return None


def _snapped_pieces(pieces: list[Polygon], parent_xy: np.ndarray, tol: float) -> list[Polygon]:
    """Raw pieces with near-duplicate vertices snapped together, spikes and empty pieces gone.

    The noding of the cut can leave new vertices one ulp from a parent
    vertex or from each other, and zero-area pieces between them.
    """
    rings = [np.asarray(shapely.orient_polygons(p).exterior.coords)[:-1] for p in pieces]
    rings = _snap_new_vertices(rings, parent_xy, tol)
    out = []
    for ring in rings:
        ring = _drop_repeats(ring)
        ring = _insert_parent_vertices_on_edges(ring, parent_xy, tol)
        for part in _split_pinches(_drop_spikes(ring, tol)):
            part = _drop_spikes(part, tol)
            if len(part) >= 3 and _signed_area(part) > 0.0:
                out.append(Polygon(part))
    return out


def _split_pinches(ring: np.ndarray) -> list[np.ndarray]:
    """Split a ring that passes twice through the same point into simple loops.

    A cut through a reflex vertex leaves a piece made of two lobes that
    touch at that vertex; they are two blocks.
    """
    for i in range(len(ring)):
        same = np.flatnonzero(np.all(ring[i + 1 :] == ring[i], axis=1))
        if len(same):
            j = i + 1 + int(same[0])
            inner = ring[i:j]
            outer = np.concatenate([ring[j:], ring[:i]])
            return _split_pinches(inner) + _split_pinches(outer)
    return [ring]


def _final_rings(
    pieces: list[Polygon], parent_xy: np.ndarray, tol: float, straight_tol: float
) -> list[np.ndarray] | None:
    """Counter-clockwise arrays of the merged pieces, or None if one is not valid.

    New vertices left straight by a merge are dropped only when they lie
    within ``straight_tol`` (round-off) of their chord, so the area is kept.
    """
    out = []
    for piece in pieces:
        ring = np.asarray(shapely.orient_polygons(piece).exterior.coords)[:-1]
        ring = _drop_spikes(_drop_repeats(ring), tol)
        ring = _drop_straight_new_vertices(ring, parent_xy, straight_tol)
        if len(ring) < 3:
            return None
        poly = Polygon(ring)
        if not poly.is_valid or poly.area <= 0.0:
            return None
        if _signed_area(ring) < 0.0:
            ring = ring[::-1].copy()
        out.append(ring)
    return out


def _snap_new_vertices(
    rings: list[np.ndarray], parent_xy: np.ndarray, tol: float
) -> list[np.ndarray]:
    """Move new vertices within ``tol`` of a parent vertex onto it, then cluster the rest.

    Every occurrence of the same coordinates is moved to the same place, so
    pieces that shared a vertex still share it: the tiling is kept.
    """
    points = np.concatenate(rings)
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    target = unique.copy()
    is_parent = _matches_any(unique, parent_xy)
    dist = np.linalg.norm(unique[:, None, :] - parent_xy[None, :, :], axis=2)
    nearest = np.argmin(dist, axis=1)
    snap = ~is_parent & (dist[np.arange(len(unique)), nearest] <= tol)
    target[snap] = parent_xy[nearest[snap]]
    free = np.flatnonzero(~is_parent & ~snap)
    for a_pos, a in enumerate(free):
        for b in free[a_pos + 1 :]:
            if np.all(target[b] == unique[b]) and np.linalg.norm(unique[b] - target[a]) <= tol:
                target[b] = target[a]
    moved = target[inverse]
    bounds = np.cumsum([0] + [len(r) for r in rings])
    return [moved[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _matches_any(points: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """True where a point equals (exactly) one of the reference points."""
    return np.any(np.all(points[:, None, :] == reference[None, :, :], axis=2), axis=1)


def _drop_repeats(ring: np.ndarray) -> np.ndarray:
    """Remove consecutive (cyclic) repeated vertices."""
    if len(ring) == 0:
        return ring
    keep = np.any(ring != np.roll(ring, 1, axis=0), axis=1)
    if not keep.any():
        return ring[:1]
    return ring[keep]


def _insert_parent_vertices_on_edges(
    ring: np.ndarray, parent_xy: np.ndarray, tol: float
) -> np.ndarray:
    """Make a parent vertex lying (within ``tol``) inside an edge of a piece a vertex of it.

    It happens when a cut runs along a parent edge: the piece's cut edge then
    covers a parent edge and part of the cut, and only the parent vertex
    separates them (needed to give each part its own joint).
    """
    start, end = ring, np.roll(ring, -1, axis=0)
    edge = end - start
    length2 = np.einsum("ij,ij->i", edge, edge)
    rel = parent_xy[None, :, :] - start[:, None, :]  # (edges, parents, 2)
    t = np.einsum("ijk,ik->ij", rel, edge) / np.maximum(length2, np.finfo(float).tiny)[:, None]
    cross = edge[:, None, 0] * rel[:, :, 1] - edge[:, None, 1] * rel[:, :, 0]
    dist = np.abs(cross) / np.sqrt(np.maximum(length2, np.finfo(float).tiny))[:, None]
    length = np.sqrt(length2)[:, None]
    on_edge = (dist <= tol) & (t * length > tol) & ((1.0 - t) * length > tol)
    if not on_edge.any():
        return ring
    out = []
    for k in range(len(ring)):
        out.append(ring[k])
        hits = np.flatnonzero(on_edge[k])
        out.extend(parent_xy[hits[np.argsort(t[k, hits])]])
    return _drop_repeats(np.array(out))


def _drop_spikes(ring: np.ndarray, tol: float) -> np.ndarray:
    """Remove zero-width spikes: vertices where the boundary folds straight back."""
    while len(ring) >= 3:
        prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
        incoming, outgoing = ring - prev, nxt - ring
        cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
        len_in, len_out = np.linalg.norm(incoming, axis=1), np.linalg.norm(outgoing, axis=1)
        thin = np.abs(cross) <= tol * np.maximum(len_in, len_out)  # tip within tol of the line
        sharp = np.abs(cross) <= FOLD_SINE * len_in * len_out  # and the turn is a U-turn
        folded = thin & sharp & (np.einsum("ij,ij->i", incoming, outgoing) < 0)
        if not folded.any():
            break
        ring = _drop_repeats(np.delete(ring, int(np.flatnonzero(folded)[0]), axis=0))
    return ring


def _drop_straight_new_vertices(ring: np.ndarray, parent_xy: np.ndarray, tol: float) -> np.ndarray:
    """Remove new (non-parent) vertices lying on the chord of their neighbours.

    They are left by merged slivers (a former cut end on a parent edge). A
    parent vertex is never removed, so the parent boundary is kept exactly.
    """
    while len(ring) > 3:
        prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
        chord = nxt - prev
        cross = chord[:, 0] * (ring[:, 1] - prev[:, 1]) - chord[:, 1] * (ring[:, 0] - prev[:, 0])
        offset = np.abs(cross) / np.maximum(np.linalg.norm(chord, axis=1), np.finfo(float).tiny)
        inside = np.einsum("ij,ij->i", ring - prev, chord) > 0.0
        inside &= np.einsum("ij,ij->i", nxt - ring, chord) > 0.0
        straight = (offset <= tol) & inside & ~_matches_any(ring, parent_xy)
        if not straight.any():
            break
        ring = np.delete(ring, int(np.flatnonzero(straight)[0]), axis=0)
    return ring


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _tiles_parent(rings: list[np.ndarray], parent_area: float) -> bool:
    """Total area of the pieces equals the parent's (relative ``AREA_CHECK``)."""
    total = sum(Polygon(r).area for r in rings)
    return abs(total - parent_area) <= AREA_CHECK * parent_area
