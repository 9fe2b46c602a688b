"""The frame of a rock mass's most numerous joint set, turned to lie along x.

Spatial indexes (GEOS's noder, shapely's STRtree) bound each line by its box along x
and y. Inclined parallel traces then have boxes that all overlap one another's, and
every search among them grows as the square of their number; turned into the frame
where the most numerous set lies along x, its traces have thin boxes that overlap only
their neighbours'. Large cuts (:data:`LARGE`) node the joints, find the neighbours of
small blocks and tag block edges in that frame.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda.scene.rockmass.traces import Traces

LARGE = 2_000  # joint traces (or pieces) from which searches run in the set's frame


def densest_set(traces: Traces, sources: np.ndarray | None = None) -> int:
    """The set with the most lines (``sources``: the set of each line counted; default
    every trace's)."""
    return int(np.argmax(np.bincount(traces.source if sources is None else sources)))


def set_turn(traces: Traces, k: int) -> np.ndarray:
    """R (2 × 2) with ``xy @ R`` turning row vectors by −α, α the angle of set ``k``'s
    traces; ``xy @ R.T`` turns back."""
    line = traces.lines[int(np.flatnonzero(traces.source == k)[0])]
    (x0, y0), (x1, y1) = shapely.get_coordinates(line)[[0, -1]]
    angle = np.arctan2(y1 - y0, x1 - x0)
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])
