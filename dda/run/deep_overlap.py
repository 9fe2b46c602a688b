"""Blocks that overlap deeper than their contacts can account for.

Two blocks pressed together overlap by their contacts' penetration: at a contact of
depth δ along an edge of length L they share an area δ L, at a corner less. The depth
of a shared region S is taken as 2 area(S) / perimeter(S) (δ for a thin strip of
depth δ, about 0.4 δ for a corner's triangle), measured at every saved frame. A region
deeper than twice the deepest contact penetration of the run, and than
``PENETRATION_WARNING`` of the smallest free block's size, is held by no contact: the
run missed one between those blocks, and what it says near them is not to be trusted.
Only regions deeper than twice the deepest contact penetration so far are measured (a
wall's pressed faces are skipped by their boxes before any intersection), and only at
the saved frames: an overlap that comes and goes between two frames is not seen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.run.run_warnings import PENETRATION_WARNING
from dda.scene.overlap import block_polygons, sharing_area

# of the smaller block's area: pairs sharing less are not measured (round-off)
SHARED_FRACTION = 1e-9
# the shared region's depth over the deepest contact penetration beyond which no contact
# holds it (a contact's own overlap measures at most 1)
UNHELD = 2.0


@dataclass(frozen=True)
class Overlap:
    """The deepest region two blocks share at one instant."""

    depth: float  # 2 area / perimeter
    area: float
    first: str  # the blocks' names
    second: str
    time: float


def deepest_overlap(blocks: BlockSet, time: float, penetration: float = 0.0) -> Overlap | None:
    """The deepest region two blocks (not both fixed) share (module docstring) among
    those deeper than ``UNHELD`` × ``penetration`` (the deepest contact penetration so
    far: regions the contacts account for are not measured), None where there is none."""
    polygons = block_polygons(blocks.vertices, blocks.offsets)
    left, right, shared = sharing_area(
        polygons, blocks.vertices, blocks.offsets, blocks.area, SHARED_FRACTION,
        UNHELD * penetration,
    )  # fmt: skip
    moving = ~(blocks.fixed[left] & blocks.fixed[right])
    left, right, shared = left[moving], right[moving], shared[moving]
    if not len(left):
        return None
    area = shapely.area(shared)
    depth = 2.0 * area / np.maximum(shapely.length(shared), 1e-300)
    k = int(np.argmax(depth))
    if depth[k] <= UNHELD * penetration:
        return None
    names = blocks.names
    return Overlap(float(depth[k]), float(area[k]), names[left[k]], names[right[k]], time)


def deeper(found: Overlap | None, kept: Overlap | None) -> Overlap | None:
    """The deeper of two overlaps (either may be None)."""
    if found is None or (kept is not None and kept.depth >= found.depth):
        return kept
    return found


def overlap_warning(
    overlap: Overlap | None, max_penetration: float, size: float | None, units: tuple[str, str]
) -> str | None:
    """The sentence when ``overlap`` is deeper than ``UNHELD`` times the run's deepest
    contact penetration and than ``PENETRATION_WARNING`` of the smallest free block's
    ``size`` (:func:`dda.run.run_warnings.smallest_free_size`; None: no free block), else
    None. ``units``: (length, time)."""
    if overlap is None or size is None:
        return None
    if overlap.depth <= max(UNHELD * max_penetration, PENETRATION_WARNING * size):
        return None
    length, time = units
    return (
        f"blocks {overlap.first!r} and {overlap.second!r} overlapped by "
        f"{overlap.area:.3g} {length}² (about {overlap.depth:.3g} {length} deep) at "
        f"t = {overlap.time:.6g} {time}, deeper than any contact's penetration "
        f"({max_penetration:.3g} {length}): no contact held them apart there, and the "
        "run's results near them are not to be trusted"
    )
