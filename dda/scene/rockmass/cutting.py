"""Shi's block cutting with shapely: node the joints with the rock boundary, polygonize.

Dangling joint pieces (traces ending inside rock) close no ring, so they make
no cut: every block edge lies on a region or excavation boundary or on a
separating joint.
"""

from __future__ import annotations

import logging

import numpy as np
import shapely

from dda.scene.rockmass.domain import Domain
from dda.scene.rockmass.traces import Traces

log = logging.getLogger(__name__)

CLIP_MARGIN = 1e-3  # traces are clipped to the rock grown by this fraction of its size
GRID = 1e-12  # precision grid of the noded joints, as a fraction of the rock size


def cut_faces(domain: Domain, traces: Traces) -> tuple[np.ndarray, np.ndarray]:
    """Cut the rock by the joint traces.

    Returns
    -------
    faces : (n,) shapely Polygons (they may still have holes), inside the rock
    region : (n,) int, the region each face belongs to
    """
    grown = shapely.buffer(domain.rock, CLIP_MARGIN * domain.size, join_style="mitre")
    shapely.prepare(grown)
    clipped = shapely.intersection(traces.lines, grown)
    clipped = clipped[~shapely.is_empty(clipped)]
    linework = np.concatenate([shapely.boundary(np.asarray(domain.parts, dtype=object)), clipped])
    # snap rounding on a fine grid: nodes closer than the grid become one
    grid = 10.0 ** np.floor(np.log10(GRID * domain.size))  # decimal: round inputs stay put
    noded = shapely.union_all(linework, grid_size=grid)
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    inside = shapely.point_on_surface(faces)
    tree = shapely.STRtree(np.asarray(domain.parts, dtype=object))
    face_index, region_index = tree.query(inside, predicate="within")
    order = np.argsort(face_index, kind="stable")
    face_index, region_index = face_index[order], region_index[order]
    first = np.unique(face_index, return_index=True)[1]
    log.debug(
        "%d faces from %d joint pieces, %d inside the rock", len(faces), len(clipped), len(first)
    )
    return faces[face_index[first]], region_index[first]
