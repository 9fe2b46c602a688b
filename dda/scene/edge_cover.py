"""Which parts of the blocks' edges another block covers, and which are outer.

An edge of a block is *covered* where another block's polygon (grown by a tolerance)
lies on it: there the two blocks touch along a joint. The rest of the edge is *outer*:
it touches no block, and a boundary stress (``[[boundary_stresses]]``) may load it.
Both are found at once for all edges with shapely (an STRtree of the grown polygons,
their intersections with the edges), as parameter intervals along each edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

# polygons grow by this fraction of the model's extent: blocks drawn or cut to share an
# edge meet to round-off, far closer than this
TOUCH = 1e-9
# a covered or outer piece shorter than this fraction of the model's extent is none (a
# corner that touches an edge covers TOUCH of it)
MIN_PIECE = 1e-7


@dataclass(frozen=True)
class EdgePieces:
    """Pieces of edges: each (block, its edge's start vertex, the piece's ends)."""

    block: np.ndarray  # (m,) row of the block whose edge it is
    vertex: np.ndarray  # (m,) the edge's start vertex, numbered within the block
    start: np.ndarray  # (m, 2) first end of the piece (along the edge's direction)
    end: np.ndarray  # (m, 2) second end
    normal: np.ndarray  # (m, 2) the edge's outward unit normal
    other: np.ndarray  # (m,) the block that covers a covered piece (-1 for outer pieces)

    @property
    def midpoint(self) -> np.ndarray:
        return 0.5 * (self.start + self.end)

    @property
    def length(self) -> np.ndarray:
        return np.linalg.norm(self.end - self.start, axis=1)

    def subset(self, rows: np.ndarray) -> EdgePieces:
        return EdgePieces(
            self.block[rows], self.vertex[rows], self.start[rows], self.end[rows],
            self.normal[rows], self.other[rows],
        )  # fmt: skip


@dataclass(frozen=True)
class _Edges:
    block: np.ndarray
    vertex: np.ndarray
    start: np.ndarray
    end: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return np.linalg.norm(self.end - self.start, axis=1)

    @property
    def extent(self) -> float:
        """The largest side of the edges' bounding box (1 without edges)."""
        return float(np.ptp(self.start, axis=0).max()) if len(self.start) else 1.0

    @property
    def normal(self) -> np.ndarray:
        """Outward unit normals (counter-clockwise polygons: the edge turned clockwise)."""
        e = self.end - self.start
        return np.column_stack([e[:, 1], -e[:, 0]]) / self.length[:, None]


def _edges(polygons: Sequence[np.ndarray]) -> _Edges:
    counts = np.array([len(p) for p in polygons])
    start = np.concatenate(polygons)
    end = np.concatenate([np.roll(p, -1, axis=0) for p in polygons])
    block = np.repeat(np.arange(len(polygons)), counts)
    vertex = np.concatenate([np.arange(c) for c in counts])
    return _Edges(block, vertex, start, end)


def covered_intervals(polygons: Sequence[np.ndarray], present: np.ndarray | None = None):
    """(edges, edge index, other block, t0, t1) of every stretch [t0, t1] (parameters
    along the edge, 0 at its start) that another present block covers, with the edges of
    all ``polygons`` (counter-clockwise (k, 2) arrays); ``present``: which blocks count
    (default: all)."""
    edges = _edges(polygons)
    present = np.ones(len(polygons), bool) if present is None else np.asarray(present, bool)
    extent = edges.extent
    rings = shapely.linearrings(edges.start, indices=edges.block)
    grown = shapely.buffer(shapely.polygons(rings), TOUCH * extent, join_style="mitre")
    lines = shapely.linestrings(np.stack([edges.start, edges.end], axis=1))
    edge_at, other = shapely.STRtree(grown).query(lines, predicate="intersects")
    keep = (other != edges.block[edge_at]) & present[other] & present[edges.block[edge_at]]
    edge_at, other = edge_at[keep], other[keep]
    parts, part_of = shapely.get_parts(
        shapely.intersection(lines[edge_at], grown[other]), return_index=True
    )
    coords, coord_of = shapely.get_coordinates(parts, return_index=True)
    pair = part_of[coord_of]
    e = edge_at[pair]
    direction = edges.end[e] - edges.start[e]
    t = np.einsum("ij,ij->i", coords - edges.start[e], direction) / np.einsum(
        "ij,ij->i", direction, direction
    )
    t0 = np.full(len(parts), np.inf)
    t1 = np.full(len(parts), -np.inf)
    np.minimum.at(t0, coord_of, np.clip(t, 0.0, 1.0))
    np.maximum.at(t1, coord_of, np.clip(t, 0.0, 1.0))
    edge_of_part = edge_at[part_of]
    t0, t1 = _snapped(edges, polygons, edge_of_part, other[part_of], t0, t1)
    long = (t1 - t0) * edges.length[edge_of_part] > MIN_PIECE * extent
    return edges, edge_of_part[long], other[part_of][long], t0[long], t1[long]


def _snapped(edges: _Edges, polygons, edge, other, t0, t1):
    """``t0``, ``t1`` of each covered stretch (of edge ``edge``, by block ``other``) moved
    onto the projection of a corner of ``other`` that lies on the edge (within the grown
    polygon's margin of it): the grown polygon ends a stretch ``TOUCH`` beyond the corner,
    and the outer pieces between would leave that much of the outline unloaded (a far
    field's forces on a closed outline then sum to 4e-9 of them, not to round-off)."""
    if not len(edge):
        return t0, t1
    margin = 2.0 * TOUCH * edges.extent
    counts = np.array([len(p) for p in polygons])
    offsets = np.concatenate([[0], np.cumsum(counts)])
    corners = np.concatenate(polygons)
    stretch = np.repeat(np.arange(len(edge)), counts[other])  # each stretch's corners
    index = np.arange(len(stretch)) - np.repeat(np.cumsum(counts[other]) - counts[other],
                                                counts[other])  # fmt: skip
    corner = corners[offsets[other][stretch] + index]
    start, direction = edges.start[edge][stretch], (edges.end - edges.start)[edge][stretch]
    length = np.hypot(direction[:, 0], direction[:, 1])
    along = np.einsum("ij,ij->i", corner - start, direction) / length**2
    off = np.abs(
        direction[:, 0] * (corner - start)[:, 1] - direction[:, 1] * (corner - start)[:, 0]
    )
    on_edge = (off / length <= margin) & (along > 0.0) & (along < 1.0)
    t0, t1 = t0.copy(), t1.copy()
    for ends in (t0, t1):
        near = on_edge & (np.abs(ends[stretch] - along) * length <= margin)
        ends[stretch[near]] = along[near]
    return t0, t1


def covered_pieces(polygons: Sequence[np.ndarray], present: np.ndarray | None = None):
    """The covered stretches of every edge, one piece per (edge, covering block) stretch."""
    edges, at, other, t0, t1 = covered_intervals(polygons, present)
    return _pieces(edges, at, t0, t1, other)


def outer_pieces(polygons: Sequence[np.ndarray], present: np.ndarray | None = None):
    """The stretches of the present blocks' edges that no other present block covers."""
    edges, at, _, t0, t1 = covered_intervals(polygons, present)
    # merge each edge's covered intervals into runs, all edges on one line: edge k's
    # interval [t0, t1] is [2k + t0, 2k + t1], so that no run reaches the next edge
    order = np.lexsort((t0, at))
    lo, hi = 2.0 * at[order] + t0[order], 2.0 * at[order] + t1[order]
    reach = np.maximum.accumulate(hi) if len(hi) else hi
    starts = np.ones(len(lo), bool)
    starts[1:] = lo[1:] > reach[:-1]  # this interval begins a new run
    run_lo, run_hi = lo[starts], np.append(reach[np.flatnonzero(starts)[1:] - 1], reach[-1:])
    run_edge = at[order][starts]
    gap_edge, gap_t0, gap_t1 = _gaps(len(edges.block), run_edge, run_lo, run_hi)
    present = np.ones(len(polygons), bool) if present is None else np.asarray(present, bool)
    long = (gap_t1 - gap_t0) * edges.length[gap_edge] > MIN_PIECE * edges.extent
    keep = long & present[edges.block[gap_edge]]
    return _pieces(edges, gap_edge[keep], gap_t0[keep], gap_t1[keep], np.full(keep.sum(), -1))


def _gaps(count: int, run_edge: np.ndarray, run_lo: np.ndarray, run_hi: np.ndarray):
    """(edge, t0, t1) of the stretches of ``count`` edges between the covered runs (sorted
    by edge then position; a run of edge k spans [run_lo, run_hi] - 2k)."""
    lo_t, hi_t = run_lo - 2.0 * run_edge, run_hi - 2.0 * run_edge
    first = np.ones(len(run_edge), bool)
    first[1:] = run_edge[1:] != run_edge[:-1]
    last = np.ones(len(run_edge), bool)
    last[:-1] = run_edge[1:] != run_edge[:-1]
    # before each edge's first run, between consecutive runs, after each edge's last run
    before = (run_edge[first], np.zeros(int(first.sum())), lo_t[first])
    between = (run_edge[~first], hi_t[np.flatnonzero(~first) - 1], lo_t[~first])
    after = (run_edge[last], hi_t[last], np.ones(int(last.sum())))
    bare = np.setdiff1d(np.arange(count), run_edge)
    whole = (bare, np.zeros(len(bare)), np.ones(len(bare)))
    parts = [before, between, after, whole]
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))


def _pieces(edges: _Edges, at, t0, t1, other) -> EdgePieces:
    direction = edges.end[at] - edges.start[at]
    return EdgePieces(
        block=edges.block[at],
        vertex=edges.vertex[at],
        start=edges.start[at] + t0[:, None] * direction,
        end=edges.start[at] + t1[:, None] * direction,
        normal=edges.normal[at],
        other=np.asarray(other, np.int64),
    )


def opening_walls(polygons: Sequence[np.ndarray], present: np.ndarray | None = None):
    """The walls of the openings in the mass, as one shapely MultiLineString (None where
    there is none): the holes in the union of the present blocks (its interior rings, the
    polygons grown by ``TOUCH`` of the model's extent so that blocks that share an edge
    make one region), as an excavation drawn in the mass leaves; not the model's outline."""
    return _walls(polygons, present, TOUCH * _edges(polygons).extent)


def on_openings(
    polygons: Sequence[np.ndarray], present: np.ndarray | None, points: np.ndarray
) -> np.ndarray:
    """Which ``points`` lie on the wall of an opening (:func:`opening_walls`)."""
    margin = TOUCH * _edges(polygons).extent
    walls = _walls(polygons, present, margin) if len(points) else None
    if walls is None:
        return np.zeros(len(points), bool)
    return shapely.distance(walls, shapely.points(points)) <= 4.0 * margin


def _walls(polygons: Sequence[np.ndarray], present: np.ndarray | None, margin: float):
    """:func:`opening_walls` with the polygons grown by ``margin``."""
    present = np.ones(len(polygons), bool) if present is None else np.asarray(present, bool)
    kept = [shapely.Polygon(p) for p, here in zip(polygons, present, strict=True) if here]
    union = shapely.union_all(shapely.buffer(kept, margin, join_style="mitre"))
    holes = [ring for part in shapely.get_parts(union) for ring in part.interiors]
    if not holes:
        return None
    return shapely.multilinestrings([np.asarray(ring.coords) for ring in holes])
