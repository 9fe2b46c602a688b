"""Broad phase: pairs of blocks whose grown bounding boxes overlap.

Compiled path (numba): a uniform grid with cells about the size of a
typical box; every box is entered in the cells it covers (boxes covering
very many cells, such as a long base, are tested against all boxes
instead), boxes sharing a cell are tested, and a pair is reported only by
the cell holding the lower-left corner of the two boxes' intersection, so
never twice. O(n) for blocks of similar size, O(n log n) with the sort.
Without numba: shapely's STRtree (a bounding-volume tree), also about
O(n log n). Both return the pairs sorted, so the order of the contacts does
not depend on the path.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.jit import compiled, kernel

MAX_CELLS_PER_BOX = 64  # boxes covering more cells are tested against every box


def bounding_boxes(blocks: BlockSet, margin: float = 0.0) -> np.ndarray:
    """(n, 4) xmin, ymin, xmax, ymax of every block, grown by ``margin``."""
    starts = blocks.offsets[:-1]
    lo = np.minimum.reduceat(blocks.vertices, starts, axis=0) - margin
    hi = np.maximum.reduceat(blocks.vertices, starts, axis=0) + margin
    return np.column_stack([lo, hi])


def candidate_pairs(blocks: BlockSet, margin: float) -> np.ndarray:
    """(p, 2) block rows i < j whose boxes, grown by ``margin``, overlap; sorted.

    Pairs of two fixed blocks are dropped: they never interact.
    """
    if blocks.count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    boxes = bounding_boxes(blocks, margin / 2.0)
    pairs = overlapping_pairs(boxes)
    both_fixed = blocks.fixed[pairs[:, 0]] & blocks.fixed[pairs[:, 1]]
    return pairs[~both_fixed]


class KeptPairs:
    """:func:`candidate_pairs` kept from step to step (a Verlet list).

    The pairs are found once with every box side grown by ``SLACK`` x margin
    more than asked. While no vertex has moved more than that extra growth in
    x or in y since (half of it is required: round-off to spare), every pair
    whose boxes overlap now is in the kept list (each side of a box moved by
    at most that much, the gap of a pair closed by at most twice that, and
    the two boxes were grown by twice the slack), so the pairs of a step are
    the kept ones whose boxes, grown by the asked margin only, overlap: the
    same pairs, in the same order, as a new search, for one vectorised test
    instead of the grid. A change of the blocks (fracture) or of the margin
    starts a new list.
    """

    SLACK = 0.1  # extra growth of each box side when the list is made, x margin

    def __init__(self) -> None:
        self._pairs: np.ndarray | None = None
        self._vertices: np.ndarray | None = None
        self._offsets: np.ndarray | None = None
        self._fixed: np.ndarray | None = None
        self._margin = np.nan
        self.searches = 0  # lists made (grid or tree searches)

    def pairs(self, blocks: BlockSet, margin: float) -> np.ndarray:
        """The pairs :func:`candidate_pairs` gives for ``blocks`` and ``margin``."""
        if compiled(_kept_kernel) and self._same_blocks(blocks, margin):
            valid, keep = _kept_kernel(
                np.ascontiguousarray(blocks.vertices, dtype=np.float64),
                blocks.offsets.astype(np.int64),
                self._vertices,
                self._pairs,
                margin / 2.0,
                0.5 * self.SLACK * margin,
            )
            if valid:
                return self._pairs[keep]
        elif self._valid(blocks, margin):
            return self._kept_overlapping(blocks, margin)
        self._pairs = candidate_pairs(blocks, margin * (1.0 + 2.0 * self.SLACK))
        self._vertices = np.ascontiguousarray(blocks.vertices, dtype=np.float64).copy()
        self._offsets, self._fixed = blocks.offsets.copy(), blocks.fixed.copy()
        self._margin = margin
        self.searches += 1
        return self._kept_overlapping(blocks, margin)

    def _kept_overlapping(self, blocks: BlockSet, margin: float) -> np.ndarray:
        """The kept pairs whose boxes, grown by ``margin`` / 2, overlap."""
        boxes = bounding_boxes(blocks, margin / 2.0)
        if compiled(_still_overlapping_kernel):
            return self._pairs[_still_overlapping_kernel(boxes, self._pairs)]
        a, b = boxes[self._pairs[:, 0]], boxes[self._pairs[:, 1]]
        apart = (
            (a[:, 0] > b[:, 2]) | (b[:, 0] > a[:, 2]) | (a[:, 1] > b[:, 3]) | (b[:, 1] > a[:, 3])
        )
        return self._pairs[~apart]

    def _same_blocks(self, blocks: BlockSet, margin: float) -> bool:
        """True when the list was made for these blocks (offsets, fixed) and ``margin``."""
        if self._pairs is None or margin != self._margin:
            return False
        if len(blocks.offsets) != len(self._offsets) or len(blocks.vertices) != len(self._vertices):
            return False
        return bool(
            np.array_equal(blocks.offsets, self._offsets)
            and np.array_equal(blocks.fixed, self._fixed)
        )

    def _valid(self, blocks: BlockSet, margin: float) -> bool:
        """True when the kept list holds every pair (same blocks and margin, small moves)."""
        if not self._same_blocks(blocks, margin):
            return False
        moved = float(np.abs(blocks.vertices - self._vertices).max(initial=0.0))
        return moved <= 0.5 * self.SLACK * margin  # half the growth: round-off to spare


def overlapping_pairs(boxes: np.ndarray) -> np.ndarray:
    """(p, 2) sorted pairs i < j of overlapping (touching counts) boxes (n, 4)."""
    if compiled(_grid_kernel):
        pairs = _grid_pairs(boxes)
    else:
        pairs = _tree_pairs(boxes)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order]


def _tree_pairs(boxes: np.ndarray) -> np.ndarray:
    geoms = shapely.box(boxes[:, 0], boxes[:, 1], boxes[:, 2], boxes[:, 3])
    tree = shapely.STRtree(geoms)
    left, right = tree.query(geoms, predicate="intersects")
    keep = left < right
    return np.column_stack([left[keep], right[keep]]).astype(np.int64)


def _grid_pairs(boxes: np.ndarray) -> np.ndarray:
    extent = np.maximum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    cell = float(np.median(extent))
    span = float(max(np.ptp(boxes[:, [0, 2]]), np.ptp(boxes[:, [1, 3]]), 1e-300))
    cell = max(cell, span / 4096.0, 1e-300)  # at most 4096 cells across
    i, j = _grid_kernel(np.ascontiguousarray(boxes, dtype=np.float64), cell, MAX_CELLS_PER_BOX)
    return np.column_stack([i, j])


def _apart(boxes, a, b):
    """True when boxes a and b (rows xmin, ymin, xmax, ymax) do not overlap."""
    return (
        boxes[a, 0] > boxes[b, 2]
        or boxes[b, 0] > boxes[a, 2]
        or boxes[a, 1] > boxes[b, 3]
        or boxes[b, 1] > boxes[a, 3]
    )


_apart = kernel(_apart) or _apart  # the compiled grid kernel calls the compiled twin


def _grid(boxes, cell, max_cells):
    """Compiled grid search; returns (i, j) with i < j, unsorted."""
    n = boxes.shape[0]
    x0 = boxes[:, 0].min()
    y0 = boxes[:, 1].min()
    ix0 = np.empty(n, np.int64)
    iy0 = np.empty(n, np.int64)
    ix1 = np.empty(n, np.int64)
    iy1 = np.empty(n, np.int64)
    big = np.zeros(n, np.bool_)
    entries = 0
    for k in range(n):
        ix0[k] = int((boxes[k, 0] - x0) / cell)
        iy0[k] = int((boxes[k, 1] - y0) / cell)
        ix1[k] = int((boxes[k, 2] - x0) / cell)
        iy1[k] = int((boxes[k, 3] - y0) / cell)
        count = (ix1[k] - ix0[k] + 1) * (iy1[k] - iy0[k] + 1)
        if count > max_cells:
            big[k] = True
        else:
            entries += count
    rows = iy1.max() + 2
    keys = np.empty(entries, np.int64)
    owner = np.empty(entries, np.int64)
    e = 0
    for k in range(n):
        if big[k]:
            continue
        for cx in range(ix0[k], ix1[k] + 1):
            for cy in range(iy0[k], iy1[k] + 1):
                keys[e] = cx * rows + cy
                owner[e] = k
                e += 1
    order = np.argsort(keys, kind="mergesort")
    keys = keys[order]
    owner = owner[order]
    out_i = []
    out_j = []
    start = 0
    while start < entries:
        stop = start + 1
        while stop < entries and keys[stop] == keys[start]:
            stop += 1
        key = keys[start]
        for p in range(start, stop):
            a = owner[p]
            for q in range(p + 1, stop):
                b = owner[q]
                if _apart(boxes, a, b):
                    continue
                # report from the cell of the intersection's lower-left corner only
                cx = int((max(boxes[a, 0], boxes[b, 0]) - x0) / cell)
                cy = int((max(boxes[a, 1], boxes[b, 1]) - y0) / cell)
                if cx * rows + cy != key:
                    continue
                out_i.append(min(a, b))
                out_j.append(max(a, b))
        start = stop
    for a in range(n):
        if not big[a]:
            continue
        for b in range(n):
            if b == a or (big[b] and b < a):
                continue
            if _apart(boxes, a, b):
                continue
            out_i.append(min(a, b))
            out_j.append(max(a, b))
    return np.array(out_i, dtype=np.int64), np.array(out_j, dtype=np.int64)


_grid_kernel = kernel(_grid)


def _still_overlapping(boxes, pairs):
    """Compiled: True for each pair (i, j) whose boxes overlap (touching counts)."""
    keep = np.empty(pairs.shape[0], np.bool_)
    for p in range(pairs.shape[0]):
        keep[p] = not _apart(boxes, pairs[p, 0], pairs[p, 1])
    return keep


_still_overlapping_kernel = kernel(_still_overlapping)


def _kept(vertices, offsets, kept_vertices, pairs, half_margin, allowed):
    """Compiled :meth:`KeptPairs.pairs` on a list made for these blocks: (whether no
    vertex moved more than ``allowed`` in x or y since, and then which kept pairs' boxes,
    grown by ``half_margin``, overlap: :func:`bounding_boxes` and
    :func:`_still_overlapping`)."""
    for k in range(vertices.shape[0]):
        for axis in range(2):
            if not abs(vertices[k, axis] - kept_vertices[k, axis]) <= allowed:  # NaN too
                return False, np.zeros(0, np.bool_)
    n = offsets.shape[0] - 1
    boxes = np.empty((n, 4))
    for b in range(n):
        for axis in range(2):
            low, high = vertices[offsets[b], axis], vertices[offsets[b], axis]
            for k in range(offsets[b] + 1, offsets[b + 1]):
                low, high = min(low, vertices[k, axis]), max(high, vertices[k, axis])
            boxes[b, axis], boxes[b, 2 + axis] = low - half_margin, high + half_margin
    return True, _still_overlapping_kernel(boxes, pairs)


_kept_kernel = kernel(_kept)
