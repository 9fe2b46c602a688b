"""Joint traces: the line segments that cut the rock, each tagged with its source.

A joint set gives parallel traces ``n · x = offset + k * spacing`` (Shi's
block-cutting input), optionally with scattered dip and spacing and, when
``trace_length`` is given, broken into joints separated by rock bridges.
Joint lines give one polyline each. Sources are numbered joint sets first,
then joint lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from dda.errors import SceneError
from dda.scene.rockmass.spec import JointSet, RockMass

MAX_TRACES_PER_SET = 100_000  # traces across the rock
MAX_SEGMENTS = 1_000_000  # joint segments in all


@dataclass(frozen=True)
class Traces:
    """Joint geometry: ``lines[i]`` belongs to source ``source[i]``.

    ``names[k]`` and ``joints[k]`` are the name and the joint of source k.
    """

    lines: np.ndarray  # (m,) shapely LineStrings
    source: np.ndarray  # (m,) int
    names: tuple[str, ...]
    joints: tuple[str, ...]


def build_traces(mass: RockMass, bounds: tuple[float, ...], source: str) -> Traces:
    """All joint traces of the rock mass, long enough to cross the bounding box."""
    pieces, owners = [], []
    for k, js in enumerate(mass.joint_sets):
        segments = joint_set_segments(js, bounds, source)
        pieces.append(shapely.linestrings(segments))
        owners.append(np.full(len(segments), k))
    first_line = len(mass.joint_sets)
    for k, jl in enumerate(mass.joint_lines):
        pieces.append(np.array([shapely.LineString(jl.points)], dtype=object))
        owners.append(np.array([first_line + k]))
    lines = np.concatenate(pieces) if pieces else np.zeros(0, dtype=object)
    if len(lines) > MAX_SEGMENTS:
        raise SceneError(
            source, "joint_sets", f"{len(lines)} joint segments; at most {MAX_SEGMENTS}"
        )
    both = list(mass.joint_sets) + list(mass.joint_lines)
    return Traces(
        lines=lines,
        source=np.concatenate(owners) if owners else np.zeros(0, dtype=np.int64),
        names=tuple(s.name for s in both),
        joints=tuple(s.joint for s in both),
    )


def joint_set_segments(js: JointSet, bounds: tuple[float, ...], source: str) -> np.ndarray:
    """Segments (m, 2, 2) of one joint set over the bounding box ``bounds``.

    Each trace is anchored on the mean-dip line at its normal position and
    turned by its own dip; it spans the whole box (length 2 × diagonal), or
    the joints of length ``trace_length`` every ``trace_length + bridge_length``
    along it, shifted by ``stagger`` per successive trace.
    """
    x0, y0, x1, y1 = bounds
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    center = corners.mean(axis=0)
    reach = math.hypot(x1 - x0, y1 - y0)
    rng = np.random.default_rng(js.seed)
    theta = math.radians(js.dip)
    normal = np.array([-math.sin(theta), math.cos(theta)])
    along = np.array([math.cos(theta), math.sin(theta)])
    proj = corners @ normal
    index, position = _positions(js, proj.min(), proj.max(), rng, source)
    dips = np.full(len(position), theta)
    if js.dip_std > 0.0:
        dips += math.radians(js.dip_std) * rng.standard_normal(len(position))
    direction = np.column_stack([np.cos(dips), np.sin(dips)])
    anchor = position[:, None] * normal + (center @ along) * along
    s_anchor = np.einsum("ij,ij->i", anchor, direction)
    if js.trace_length is None:
        start, stop = s_anchor - reach, s_anchor + reach
        line = np.arange(len(position))
    else:
        line, start, stop = _persistence(js, index, s_anchor - reach, s_anchor + reach, rng, source)
    base = anchor[line] - s_anchor[line, None] * direction[line]
    a = base + start[:, None] * direction[line]
    b = base + stop[:, None] * direction[line]
    return np.stack([a, b], axis=1)


def _positions(
    js: JointSet, low: float, high: float, rng: np.random.Generator, source: str
) -> tuple[np.ndarray, np.ndarray]:
    """Trace index k and normal position of every trace crossing [low, high]."""
    count = (high - low) / js.spacing
    if count > MAX_TRACES_PER_SET:
        raise SceneError(
            source,
            f"{js.key}.spacing",
            f"gives {count:.0f} traces across the rock; at most {MAX_TRACES_PER_SET}",
        )
    k_first = math.ceil((low - js.offset) / js.spacing)
    if js.spacing_std == 0.0:
        k = np.arange(k_first, math.floor((high - js.offset) / js.spacing) + 1)
        return k, js.offset + k * js.spacing
    start = js.offset + k_first * js.spacing  # a trace inside the range, then random gaps
    sigma2 = math.log1p((js.spacing_std / js.spacing) ** 2)  # log-normal, mean = spacing
    mu = math.log(js.spacing) - 0.5 * sigma2

    def walk(limit: float, sign: float) -> np.ndarray:
        pos, out = start, []
        while (limit - pos) * sign >= 0.0:
            gaps = rng.lognormal(mu, math.sqrt(sigma2), size=max(8, int(count) + 8))
            steps = pos + sign * np.cumsum(gaps)
            out.append(steps)
            pos = steps[-1]
        steps = np.concatenate(out) if out else np.zeros(0)
        return steps[(limit - steps) * sign >= 0.0]

    up, down = walk(high, 1.0), walk(low, -1.0)
    position = np.concatenate([down[::-1], [start], up])
    k = k_first + np.arange(-len(down), len(up) + 1)
    return k, position


def _persistence(
    js: JointSet,
    index: np.ndarray,
    s_low: np.ndarray,
    s_high: np.ndarray,
    rng: np.random.Generator,
    source: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joints of ``trace_length`` every period along each trace: (line, start, stop)."""
    period = js.trace_length + js.bridge_length
    if js.stagger == "random":
        phase = rng.uniform(0.0, period, size=len(index))
    else:
        phase = np.mod(index * float(js.stagger), period)
    k_low = np.floor((s_low - phase) / period).astype(np.int64)
    k_high = np.ceil((s_high - phase) / period).astype(np.int64)
    counts = k_high - k_low + 1
    if counts.sum() > MAX_SEGMENTS:
        raise SceneError(
            source,
            f"{js.key}.trace_length",
            f"gives {counts.sum()} joints; at most {MAX_SEGMENTS}",
        )
    line = np.repeat(np.arange(len(index)), counts)
    k = k_low[line] + (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    start = phase[line] + k * period
    stop = start + js.trace_length
    start = np.maximum(start, s_low[line])
    stop = np.minimum(stop, s_high[line])
    keep = stop > start
    return line[keep], start[keep], stop[keep]
