"""Blocks smaller than ``min_block_area`` join the neighbour of their own region (material,
drawn fixed shape) they share the longest edge with.

Slivers come from joints crossing very close to each other or to a corner;
they would make the contact solver stiff and the time step tiny. A small block with no
neighbour of its region (a thin seam of another material, a small drawn fixed shape) is
kept as it is, with a warning: joined to another region it would have taken that
region's material, and the seam or the fixed shape would be gone without a word.
"""

from __future__ import annotations

import logging

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from dda.errors import SceneError

log = logging.getLogger(__name__)

MAX_ROUNDS = 20
KEPT_SAID = 5  # small blocks kept as they are, said one by one; the rest counted


def merge_small(
    faces: np.ndarray,
    region: np.ndarray,
    min_area: float,
    mode: str,
    source: str,
    turn: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Merge (``mode="merge"``) or refuse (``"refuse"``) blocks below ``min_area``;
    ``turn``: the frame the neighbour search runs in (``xy @ turn``; a large cut's
    densest-set frame, :mod:`dda.scene.rockmass.set_frame`), default as given."""
    kept = np.zeros(len(faces), bool)  # small blocks with no neighbour of their region
    for _ in range(MAX_ROUNDS):
        area = shapely.area(faces)
        small = np.flatnonzero((area < min_area) & ~kept)
        if len(small) == 0:
            return faces, region
        if mode == "refuse":
            _refuse(faces, area, small, min_area, source)
        target = _best_neighbours(faces, region, small, min_area, source, turn)
        alone = target < 0
        _say_kept(faces[small[alone]], region[small[alone]], min_area, source)
        kept[small[alone]] = True
        small, target = small[~alone], target[~alone]
        faces, region, kept = _union_groups(faces, region, small, target, kept)
        log.info("merged %d block(s) smaller than %g", len(small), min_area)
    raise SceneError(source, "cutting.min_block_area", "blocks still too small after merging")


def _say_kept(faces: np.ndarray, region: np.ndarray, min_area: float, source: str) -> None:
    """Warn of the small blocks kept as they are, :data:`KEPT_SAID` by name and place, the
    rest counted."""
    for face, home in zip(faces[:KEPT_SAID], region[:KEPT_SAID], strict=False):
        x, y = shapely.get_coordinates(shapely.point_on_surface(face))[0]
        log.warning(
            "%s: a block of area %.3g near (%.4g, %.4g), smaller than cutting.min_block_area "
            "%g, is kept as it is: no neighbour of its own region (regions[%d]: its "
            "material, or a drawn fixed shape) to join",
            source, face.area, x, y, min_area, home,
        )  # fmt: skip
    if len(faces) > KEPT_SAID:
        log.warning("%s: %d more small blocks kept as they are", source, len(faces) - KEPT_SAID)


def _refuse(
    faces: np.ndarray, area: np.ndarray, small: np.ndarray, min_area: float, source: str
) -> None:
    worst = small[np.argmin(area[small])]
    x, y = shapely.get_coordinates(shapely.point_on_surface(faces[worst]))[0]
    raise SceneError(
        source,
        "cutting.min_block_area",
        f"{len(small)} block(s) smaller than {min_area:g} (smallest {area[worst]:.3g} "
        f"near ({x:.4g}, {y:.4g})); move the joints, lower min_block_area "
        'or set cutting.small_blocks = "merge"',
    )


def _best_neighbours(
    faces: np.ndarray,
    region: np.ndarray,
    small: np.ndarray,
    min_area: float,
    source: str,
    turn: np.ndarray | None = None,
) -> np.ndarray:
    """For each small face, the neighbour of its own region sharing the longest edge, -1
    where it has none (a face of another region shares one); the candidates are searched
    in the frame ``turn`` (rotation keeps shared edges shared: both faces' copies of a
    vertex turn alike)."""
    searched = faces if turn is None else shapely.transform(faces, lambda xy: xy @ turn)
    tree = shapely.STRtree(searched)
    rows, other = tree.query(searched[small], predicate="intersects")
    mine = small[rows]
    keep = mine != other
    rows, mine, other = rows[keep], mine[keep], other[keep]
    shared = shapely.length(
        shapely.intersection(shapely.boundary(faces[mine]), shapely.boundary(faces[other]))
    )
    score = shared.copy()
    score[(shared <= 0.0) | (region[mine] != region[other])] = -1.0
    best = np.full(len(small), -1)
    best_score = np.full(len(small), -1.0)
    order = np.argsort(score, kind="stable")  # later (higher) scores overwrite
    best[rows[order]] = other[order]
    best_score[rows[order]] = score[order]
    touching = np.zeros(len(small), bool)  # sharing an edge with a face of any region
    touching[rows[shared > 0.0]] = True
    lonely = np.flatnonzero(~touching)
    best[best_score < 0.0] = -1
    if len(lonely):
        face = faces[small[lonely[0]]]
        x, y = shapely.get_coordinates(shapely.point_on_surface(face))[0]
        raise SceneError(
            source,
            "cutting.min_block_area",
            f"a block of area {face.area:.3g} near ({x:.4g}, {y:.4g}) is smaller than "
            f"{min_area:g} and shares no edge with another block",
        )
    return best


def _union_groups(
    faces: np.ndarray, region: np.ndarray, small: np.ndarray, target: np.ndarray, kept
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Union every connected group of (small face -> target) links into one face (all of
    one region); ``kept`` follows the faces left alone."""
    n = len(faces)
    graph = coo_matrix((np.ones(len(small)), (small, target)), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    sizes = np.bincount(label, minlength=count)
    area = shapely.area(faces)
    out_faces, out_region = [], []
    for group in np.flatnonzero(sizes > 1):
        members = np.flatnonzero(label == group)
        merged = shapely.union_all(faces[members])
        out_faces.extend(shapely.get_parts(merged))
        dominant = region[members[np.argmax(area[members])]]
        out_region.extend([dominant] * shapely.get_num_geometries(merged))
    alone = sizes[label] == 1
    return (
        np.concatenate([faces[alone], np.array(out_faces, dtype=object)]),
        np.concatenate([region[alone], np.array(out_region, dtype=region.dtype)]),
        np.concatenate([kept[alone], np.zeros(len(out_faces), bool)]),
    )
