"""Broad phase: pairs of blocks whose grown bounding boxes overlap.

A bounding-volume tree (shapely's STRtree over the boxes) keeps the search
near O(n log n); no all-pairs loop.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet


def bounding_boxes(blocks: BlockSet, margin: float = 0.0) -> np.ndarray:
    """(n, 4) xmin, ymin, xmax, ymax of every block, grown by ``margin``."""
    starts = blocks.offsets[:-1]
    lo = np.minimum.reduceat(blocks.vertices, starts, axis=0) - margin
    hi = np.maximum.reduceat(blocks.vertices, starts, axis=0) + margin
    return np.column_stack([lo, hi])


def candidate_pairs(blocks: BlockSet, margin: float) -> np.ndarray:
    """(p, 2) block rows i < j whose boxes, grown by ``margin``, overlap.

    Pairs of two fixed blocks are dropped: they never interact.
    """
    if blocks.count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    boxes = bounding_boxes(blocks, margin / 2.0)
    geoms = shapely.box(boxes[:, 0], boxes[:, 1], boxes[:, 2], boxes[:, 3])
    tree = shapely.STRtree(geoms)
    left, right = tree.query(geoms, predicate="intersects")
    keep = left < right
    pairs = np.column_stack([left[keep], right[keep]]).astype(np.int64)
    both_fixed = blocks.fixed[pairs[:, 0]] & blocks.fixed[pairs[:, 1]]
    return pairs[~both_fixed]
