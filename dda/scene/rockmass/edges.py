"""Block edges: pack the faces counter-clockwise and tag each edge with its joint.

Edge k of a block runs from vertex k to vertex k+1. Its source is the joint
set or joint line whose trace passes within ``tolerance`` of the edge's
midpoint (-1: a region or excavation boundary, or a cut through a hole).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from dda.geometry import next_vertex_index, owner_of_vertex, previous_vertex_index
from dda.scene.rockmass.progress import CutProgress
from dda.scene.rockmass.set_frame import LARGE, densest_set, set_turn
from dda.scene.rockmass.traces import Traces

SEGMENTS_ACROSS = 256  # trace pieces for the edge search, per rock size
COLLINEAR = 1e-11  # a vertex this close (× rock size) to its neighbours' chord is dropped


@dataclass(frozen=True)
class PackedBlocks:
    """Block polygons packed as in :mod:`dda.geometry`, with one source per edge."""

    vertices: np.ndarray  # (NV, 2), counter-clockwise per block, no closing vertex
    offsets: np.ndarray  # (n+1,)
    edge_source: np.ndarray  # (NV,) int, source of the edge starting at each vertex

    def __len__(self) -> int:
        return len(self.offsets) - 1

    def polygon(self, i: int) -> np.ndarray:
        return self.vertices[self.offsets[i] : self.offsets[i + 1]]

    def sources(self, i: int) -> np.ndarray:
        return self.edge_source[self.offsets[i] : self.offsets[i + 1]]


def pack_faces(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Counter-clockwise exterior vertices of every face, packed, closing vertex dropped."""
    rings = shapely.get_exterior_ring(shapely.orient_polygons(faces, exterior_cw=False))
    coords, owner = shapely.get_coordinates(rings, return_index=True)
    counts = np.bincount(owner, minlength=len(faces))
    closing = np.cumsum(counts) - 1
    keep = np.ones(len(coords), dtype=bool)
    keep[closing] = False
    offsets = np.zeros(len(faces) + 1, dtype=np.int64)
    np.cumsum(counts - 1, out=offsets[1:])
    return coords[keep], offsets


def tag_edges(
    vertices: np.ndarray,
    offsets: np.ndarray,
    traces: Traces,
    tolerance: float,
    report: CutProgress | None = None,
) -> np.ndarray:
    """Source of every edge: the trace within ``tolerance`` of its midpoint, else -1
    (the edges searched in chunks, each told to ``report`` as stage "tagging")."""
    source = np.full(len(vertices), -1, dtype=np.int64)
    if len(traces.lines) == 0 or len(vertices) == 0:
        return source
    middle = 0.5 * (vertices + vertices[next_vertex_index(offsets)])
    low, high = vertices.min(axis=0) - tolerance, vertices.max(axis=0) + tolerance
    box = (*low, *high)
    if len(traces.lines) >= LARGE:  # search in the frame of the densest set (set_frame)
        pieces, owner, to_set = _pieces_in_set_frame(traces, box)
        middle = middle @ to_set
    else:
        pieces, owner = short_segments(traces, box, SEGMENTS_ACROSS)
    tree = shapely.STRtree(pieces)
    points = shapely.points(middle)
    for chunk in (report or CutProgress(None, 0)).chunks("tagging", len(points)):
        edge, piece = tree.query_nearest(points[chunk], max_distance=tolerance, all_matches=False)
        source[chunk.start + edge] = owner[piece]
    return source


def _pieces_in_set_frame(traces: Traces, box: tuple[float, float, float, float]):
    """(pieces, their sources, R): the traces inside ``box`` turned by R into the frame
    where the densest set lies along x; that set's traces whole (their boxes are thin
    there), the others' as short segments."""
    k = densest_set(traces)
    to_set = set_turn(traces, k)
    along = traces.source == k
    whole = shapely.clip_by_rect(traces.lines[along], *box)
    others = Traces(traces.lines[~along], traces.source[~along], traces.names, traces.joints)
    short, short_owner = short_segments(others, box, SEGMENTS_ACROSS)
    pieces = shapely.transform(np.concatenate([whole, short]), lambda xy: xy @ to_set)
    return pieces, np.concatenate([traces.source[along], short_owner]), to_set


def short_segments(
    traces: Traces, box: tuple[float, float, float, float], across: int
) -> tuple[np.ndarray, np.ndarray]:
    """The traces inside ``box`` as two-point segments at most 1/``across`` of its size.

    Long traces have huge envelopes that make a tree search slow; short
    pieces keep each query local.
    """
    clipped = shapely.clip_by_rect(traces.lines, *box)
    longest = max(box[2] - box[0], box[3] - box[1]) / across
    coords, index = shapely.get_coordinates(shapely.segmentize(clipped, longest), return_index=True)
    same = index[1:] == index[:-1]
    start, stop = coords[:-1][same], coords[1:][same]
    return shapely.linestrings(np.stack([start, stop], axis=1)), traces.source[index[:-1][same]]


def drop_collinear(blocks: PackedBlocks, tolerance: float) -> PackedBlocks:
    """Remove vertices lying on the straight line between two edges of the same source.

    Such vertices come from dangling joints that end on a block edge; they
    are not corners, only extra points for the contact search.
    """
    v, off = blocks.vertices, blocks.offsets
    prv, nxt = previous_vertex_index(off), next_vertex_index(off)
    a, b = v - v[prv], v[nxt] - v
    chord = v[nxt] - v[prv]
    length = np.hypot(chord[:, 0], chord[:, 1])
    cross = np.abs(a[:, 0] * chord[:, 1] - a[:, 1] * chord[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        straight = (cross <= tolerance * length) & (np.einsum("ij,ij->i", a, b) > 0.0)
    same = blocks.edge_source[prv] == blocks.edge_source
    drop = straight & same
    owner = owner_of_vertex(off)
    left = np.bincount(owner[~drop], minlength=len(off) - 1)
    if np.any(left < 3):  # never collapse a block (cannot happen for a proper polygon)
        drop &= (left >= 3)[owner]
        left = np.bincount(owner[~drop], minlength=len(off) - 1)
    offsets = np.zeros_like(off)
    np.cumsum(left, out=offsets[1:])
    return PackedBlocks(v[~drop], offsets, blocks.edge_source[~drop])
