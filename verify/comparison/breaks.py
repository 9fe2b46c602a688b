"""The rows of a fracture case: when each block broke, what its pieces start with, and
along which planes it broke, against the criterion on the FEM's stress.

``onset``
    Per breakable block, the load factor at the step the engine broke it against the
    FEM's onset factor (:func:`verify.fem.fracture.onset_factors`). A block that broke
    on one side only reads ``inf`` on the other: the row fails. Both sides unbroken is
    an agreement (the row is left out).
``children``
    The pieces of the first break start with the stress their parent met the criterion
    with (a DDA block's stress is constant, docs/fracture.md).
``crack``
    Per broken block, the directions of its cracks measured from its pieces (the edges
    two pieces share), in degrees from the x axis, against the planes of the criterion
    on the FEM's average stress at its onset: θ1 ± (45° − φ/2) in shear, θ1 in tension,
    θ1 the direction of the most compressive principal stress σ1 (Lin et al. 1994, §4).
    Component ``planes`` compares how many there are (2 in shear, 1 in tension).
"""

from __future__ import annotations

import numpy as np
import shapely

from dda import Frame, Result, Scene
from verify.comparison.compare import STRESS, Row
from verify.comparison.expect import Expectation, ExpectationError
from verify.fem.fracture import Onset, crack_planes, strength_of
from verify.fem.statics import load_factor_at

SHARED_EDGE = 1e-9  # a piece's edge lies on another piece's boundary within this x block size
RIGHT_ANGLE = 90.0  # the scale of a crack direction row, degrees


def common_factor(scene: Scene, time: float) -> float:
    """The one load factor of all loads at ``time`` (the case's loads share a history)."""
    factors = load_factor_at(scene, time)
    if not len(factors) or np.ptp(factors) > 1e-12 * max(1.0, abs(factors).max()):
        raise ExpectationError(
            f"{scene.source}: loads: a fracture case needs loads with one common history"
        )
    return float(factors[0])


def planned_largest_factor(scene: Scene) -> float:
    """The largest load factor the scene's run reaches as planned: its history's points up
    to the planned end (``duration``, or ``steps`` at the longest ``time_step``), and the
    end itself. It depends on the scene alone, not on where the engine broke."""
    end = scene.analysis.run_length
    times = {0.0, end}
    for load in scene.loads:
        if load.history is not None:
            times.update(t for t, _ in load.history if t <= end)
    return max(common_factor(scene, t) for t in times)


def frame_before_break(result: Result) -> int:
    """Index of the last frame before the first fracture event (the last frame if none)."""
    if not result.fracture_events:
        return len(result.frames) - 1
    step = result.fracture_events[0].step
    return max(k for k, f in enumerate(result.frames) if f.step < step)


def broken_factors(result: Result, scene: Scene) -> dict[str, float]:
    """Load factor at the step each scene block first broke."""
    out: dict[str, float] = {}
    for event in result.fracture_events:
        if event.parent not in out:
            out[event.parent] = common_factor(scene, event.time)
    return out


def onset_rows(result: Result, scene: Scene, onset: Onset, expectation: Expectation) -> list[Row]:
    """Row ``onset`` per breakable block that broke on either side: the DDA's break factor
    against the FEM's onset factor, ``inf`` on the side where it did not break."""
    broke = broken_factors(result, scene)
    rows = []
    for i, factor in onset.factors.items():
        name = scene.blocks[i].name
        dda_factor = broke.get(name, np.inf)
        fem_factor = factor if np.isfinite(factor) else np.inf
        if np.isinf(dda_factor) and np.isinf(fem_factor):
            continue  # neither breaks within the run: they agree
        scale = min(dda_factor, fem_factor)
        row = Row("onset", name, "factor", dda_factor, fem_factor, scale)
        rows.append(row.with_offset(expectation.offsets))
    return rows


def frame_of(result: Result, event) -> Frame | None:
    """The first frame at or after ``event``'s step (the pieces just made), or None."""
    return next((f for f in result.frames if f.step >= event.step), None)


def children_rows(result: Result) -> list[Row]:
    """Rows ``children``: each piece of the first break in the first frame at or after
    its step against the stress its parent met the criterion with; scale the largest of
    that."""
    if not result.fracture_events:
        return []
    event = result.fracture_events[0]
    frame = frame_of(result, event)
    parent = np.asarray(event.stress, float)
    if frame is None or parent.size != 3:
        return []
    scale = float(np.abs(parent).max()) or 1.0
    rows = []
    for child in event.children:
        stress = frame.stresses[frame.block(child)]
        rows += [Row("children", child, name, float(value), float(expected), scale)
                 for name, value, expected in zip(STRESS, stress, parent, strict=True)]  # fmt: skip
    return rows


def crack_directions(pieces: list[np.ndarray]) -> np.ndarray:
    """Directions (degrees in [0, 180)) of the cracks between ``pieces``: the distinct
    directions of the edges that lie on another piece's boundary."""
    size = max(float(np.ptp(np.vstack(pieces), axis=0).max()), 1e-300)
    rings = [shapely.LinearRing(p) for p in pieces]
    found: list[float] = []
    for k, piece in enumerate(pieces):
        ends = np.roll(piece, -1, axis=0)
        for start, end in zip(piece, ends, strict=True):
            middle = shapely.Point((start + end) / 2)
            others = (r for j, r in enumerate(rings) if j != k)
            if not any(r.distance(middle) <= SHARED_EDGE * size for r in others):
                continue
            angle = float(np.degrees(np.arctan2(*(end - start)[::-1]))) % 180.0
            if not any(_angle_gap(angle, seen) < 1e-6 for seen in found):
                found.append(angle)
    return np.sort(found)


def _signed_gap(a: float, b: float) -> float:
    """a − b between two line directions, degrees, in [−90, 90) (directions modulo 180)."""
    return (a - b + 90.0) % 180.0 - 90.0


def _angle_gap(a: float, b: float) -> float:
    """|a − b| between two line directions, degrees (modulo 180)."""
    return abs(_signed_gap(a, b))


def crack_rows(result: Result, scene: Scene, onset: Onset) -> list[Row]:
    """Rows ``crack`` of every block's first break: how many planes, and each measured
    direction against the nearest plane of the criterion on the FEM's stress at onset."""
    rows = []
    names = [b.name for b in scene.blocks]
    seen = set()
    for event in result.fracture_events:
        if event.parent in seen or event.parent not in names:
            continue
        seen.add(event.parent)
        i = names.index(event.parent)
        factor = onset.factors.get(i, np.nan)
        strength = strength_of(scene, i)
        frame = frame_of(result, event)
        if frame is None or strength is None:
            continue
        measured = crack_directions([frame.vertices[frame.block(c)] for c in event.children])
        expected = crack_planes(onset.stress_at(i, factor), strength) if np.isfinite(factor) else []
        count = Row("crack", event.parent, "planes", float(len(measured)), float(len(expected)), 1)
        rows.append(count)
        for k, angle in enumerate(expected):
            nearest = min(measured, key=lambda m, a=angle: _angle_gap(m, a), default=np.inf)
            value = angle + _signed_gap(nearest, angle) if np.isfinite(nearest) else nearest
            rows.append(Row("crack", event.parent, f"plane{k + 1}", value, angle, RIGHT_ANGLE))
    return rows
