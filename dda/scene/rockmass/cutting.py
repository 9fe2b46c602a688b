"""Shi's block cutting with shapely: node the joints with the rock boundary, polygonize.

Dangling joint pieces (traces ending inside rock) close no ring, so they make
no cut: every block edge lies on a region or excavation boundary or on a
separating joint.

Noding finds the crossings of the joint pieces. GEOS's union (snap rounding on a fine
grid) does it for up to :data:`NODE_ALONG_SET` pieces, but grows about as n^1.8 in their
number; above that the pieces are noded by ``shapely.node`` in the frame of the most
numerous set, turned to lie along x. There the pieces of that set have thin bounding
boxes, which overlap only their neighbours' (inclined parallel traces all overlap one
another's, which makes noding quadratic), and the cut grows about as n^1.2 (one set
of 8,000 traces at 30°: 0.9 s against 8.5 s; docs/rock_masses.md).
"""

from __future__ import annotations

import logging

import numpy as np
import shapely

from dda.scene.rockmass.domain import Domain
from dda.scene.rockmass.progress import CutProgress
from dda.scene.rockmass.set_frame import LARGE, densest_set, set_turn
from dda.scene.rockmass.traces import Traces

log = logging.getLogger(__name__)

CLIP_MARGIN = 1e-3  # traces are clipped to the rock grown by this fraction of its size
GRID = 1e-12  # precision grid of the noded joints, as a fraction of the rock size
# ... and at least this fraction of the coordinates' magnitude: 45 times a double's
# relative spacing, the round-off of a point computed on a line there
ROUND_OFF = 1e-14


def cut_faces(
    domain: Domain, traces: Traces, report: CutProgress | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Cut the rock by the joint traces (stages "clipping", "noding", "polygonising" told
    to ``report``).

    Returns
    -------
    faces : (n,) shapely Polygons (they may still have holes), inside the rock
    region : (n,) int, the region each face belongs to
    """
    grown = shapely.buffer(domain.rock, CLIP_MARGIN * domain.size, join_style="mitre")
    shapely.prepare(grown)
    report = report or CutProgress(None, 0)
    chunks = report.chunks("clipping", len(traces.lines))
    clipped = np.concatenate([shapely.intersection(traces.lines[c], grown) for c in chunks])
    report.done("clipping")
    kept = ~shapely.is_empty(clipped)
    clipped, sources = clipped[kept], traces.source[kept]
    linework = np.concatenate([shapely.boundary(np.asarray(domain.parts, dtype=object)), clipped])
    grid = noding_grid(domain)
    if len(clipped) >= LARGE:
        faces = _faces_along(linework, set_turn(traces, densest_set(traces, sources)), grid, report)
    else:  # snap rounding on a fine grid: nodes closer than the grid become one
        noded = shapely.union_all(linework, grid_size=grid)
        report.done("noding")
        faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    inside = shapely.point_on_surface(faces)
    tree = shapely.STRtree(np.asarray(domain.parts, dtype=object))
    face_index, region_index = tree.query(inside, predicate="within")
    order = np.argsort(face_index, kind="stable")
    face_index, region_index = face_index[order], region_index[order]
    first = np.unique(face_index, return_index=True)[1]
    report.done("polygonising")
    log.debug(
        "%d faces from %d joint pieces, %d inside the rock", len(faces), len(clipped), len(first)
    )
    return faces[face_index[first]], region_index[first]


def noding_grid(domain: Domain) -> float:
    """The grid the joints are noded on: :data:`GRID` of the rock's size, and at least
    :data:`ROUND_OFF` of its coordinates' magnitude, rounded down to a power of ten (round
    inputs stay put). A joint drawn to end on the boundary or on another joint ends
    there to the round-off of its coordinates, which at map coordinates (4.2e6 m: 9e-10
    m between doubles) is coarser than the rock's 1e-12: it missed the line and cut
    nothing."""
    x0, y0, x1, y1 = domain.bounds
    magnitude = max(abs(x0), abs(y0), abs(x1), abs(y1))
    fine = max(GRID * domain.size, ROUND_OFF * magnitude, np.finfo(float).tiny)
    return float(10.0 ** np.floor(np.log10(fine)))


def _faces_along(
    linework: np.ndarray, to_set: np.ndarray, grid: float, report: CutProgress
) -> np.ndarray:
    """Node and polygonize ``linework`` turned by ``to_set`` (row vectors: its densest set
    along x), the faces turned back. Vertices are put on the ``grid`` before noding."""
    parts = shapely.get_parts(linework)
    lines = parts[shapely.get_dimensions(parts) == 1]  # no points of a tangent clip
    as_lines = shapely.linestrings(shapely.get_coordinates(lines), indices=_owners(lines))
    turned = shapely.transform(shapely.multilinestrings(as_lines), lambda xy: xy @ to_set)
    noded = shapely.node(shapely.set_precision(turned, grid))
    report.done("noding")
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    return shapely.transform(faces, lambda xy: xy @ to_set.T)


def _owners(lines: np.ndarray) -> np.ndarray:
    """The index of the line each coordinate of ``shapely.get_coordinates(lines)`` is of."""
    return np.repeat(np.arange(len(lines)), shapely.get_num_coordinates(lines))
