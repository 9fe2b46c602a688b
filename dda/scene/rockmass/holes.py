"""Blocks must be simple polygons: split a block that encloses a hole.

A face encloses a hole when an excavation or a region hole is not crossed by
any joint, or when joints cut an island out of it. The face is split by a
vertical line through the hole (then by a horizontal one if that fails)
until no piece has a hole. The new edges lie on no joint: they get the
default joint.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.ops import split

from dda.errors import SceneError


def split_holes(
    faces: np.ndarray, region: np.ndarray, mode: str, source: str
) -> tuple[np.ndarray, np.ndarray]:
    """Replace every face with holes by simple pieces (``mode="split"``) or refuse."""
    holed = np.flatnonzero(shapely.get_num_interior_rings(faces) > 0)
    if len(holed) == 0:
        return faces, region
    if mode == "refuse":
        x, y = shapely.get_coordinates(shapely.point_on_surface(faces[holed[0]]))[0]
        raise SceneError(
            source,
            "cutting.holes",
            f"{len(holed)} block(s) enclose a hole (one near ({x:.4g}, {y:.4g})); "
            'cross it with a joint or set cutting.holes = "split"',
        )
    new_faces, new_region = [], []
    for i in holed:
        try:
            pieces = split_face(faces[i])
        except ValueError:
            x, y = shapely.get_coordinates(shapely.point_on_surface(faces[i]))[0]
            raise SceneError(
                source,
                "cutting.holes",
                f"cannot split the block around the hole near ({x:.4g}, {y:.4g}); "
                "cross the hole with a joint line",
            ) from None
        new_faces.extend(pieces)
        new_region.extend([region[i]] * len(pieces))
    keep = np.ones(len(faces), dtype=bool)
    keep[holed] = False
    return (
        np.concatenate([faces[keep], np.array(new_faces, dtype=object)]),
        np.concatenate([region[keep], np.array(new_region, dtype=region.dtype)]),
    )


def split_face(face: shapely.Polygon) -> list[shapely.Polygon]:
    """Pieces of ``face`` without holes, cut by lines through each hole in turn."""
    todo, done = [face], []
    while todo:
        polygon = todo.pop()
        if not polygon.interiors:
            done.append(polygon)
            continue
        pieces = _cut_through_hole(polygon)
        if len(pieces) < 2:
            raise ValueError("could not split a block with a hole")
        todo.extend(pieces)
    return done


def _cut_through_hole(polygon: shapely.Polygon) -> list[shapely.Polygon]:
    hole = shapely.Polygon(polygon.interiors[0])
    cx, cy = hole.centroid.x, hole.centroid.y
    x0, y0, x1, y1 = polygon.bounds
    pad = max(x1 - x0, y1 - y0)
    for line in (
        shapely.LineString([(cx, y0 - pad), (cx, y1 + pad)]),
        shapely.LineString([(x0 - pad, cy), (x1 + pad, cy)]),
    ):
        pieces = [g for g in split(polygon, line).geoms if g.area > 0.0]
        if len(pieces) >= 2:
            return pieces
    return [polygon]
