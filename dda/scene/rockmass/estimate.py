"""How many blocks a rock mass will cut into, estimated before any cutting.

For joint sets of spacing ``s_i`` and dip ``θ_i`` over rock of area ``A``
whose extent across set i is ``w_i`` (the rock projected on the set's
normal), the traces of set i cross the rock about ``w_i / s_i`` times and
two sets meet about ``A |sin(θ_i - θ_j)| / (s_i s_j)`` times. In a line
arrangement every crossing trace adds a block and every meeting point adds
one more (Euler), so

    blocks ≈ 1 + Σ_i p_i w_i / s_i + Σ_{i<j} p_i p_j A |sin(θ_i - θ_j)| / (s_i s_j) + lines

with ``p_i = trace_length / (trace_length + bridge_length)`` the persistence
(1 for persistent sets). Each region and each joint line adds at least one.
Dangling joints cut nothing, so the estimate is an upper bound for
non-persistent sets; for persistent sets it is within a few per cent.

A scene whose estimate exceeds ``cutting.max_blocks`` (default
``DEFAULT_MAX_BLOCKS``) is refused before cutting: noding parallel traces
costs time growing with the square of their number, so a mistyped spacing
(0.001 m for 1 m) would otherwise run for hours without a word.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from dda.errors import SceneError
from dda.scene.rockmass.domain import Domain
from dda.scene.rockmass.spec import JointSet, RockMass


def estimated_blocks(mass: RockMass, domain: Domain) -> int:
    """The estimated number of blocks of the cut rock mass (see the module docstring)."""
    rock = domain.rock
    corners = np.asarray(shapely.get_coordinates(shapely.convex_hull(rock)))
    area = float(rock.area)
    sets = mass.joint_sets
    crossings = [_persistence(js) * _width(corners, js.dip) / js.spacing for js in sets]
    total = len(mass.regions) + sum(crossings) + len(mass.joint_lines)
    for i, a in enumerate(sets):
        for b in sets[i + 1 :]:
            sine = abs(math.sin(math.radians(a.dip - b.dip)))
            total += _persistence(a) * _persistence(b) * area * sine / (a.spacing * b.spacing)
    return int(math.ceil(total))


def check_block_count(mass: RockMass, domain: Domain, source: str) -> int:
    """The estimate, or a SceneError when it exceeds ``cutting.max_blocks``.

    The error names the spacing of the set with the most traces across the rock
    (the likely typo) and says how to raise the limit.
    """
    estimate = estimated_blocks(mass, domain)
    limit = mass.options.max_blocks
    if estimate <= limit:
        return estimate
    key = "cutting.max_blocks"
    if mass.joint_sets:
        corners = np.asarray(shapely.get_coordinates(shapely.convex_hull(domain.rock)))
        densest = max(mass.joint_sets, key=lambda js: _width(corners, js.dip) / js.spacing)
        key = f"{densest.key}.spacing"
    spacings = ", ".join(f"{js.key}.spacing = {js.spacing:g}" for js in mass.joint_sets)
    raise SceneError(
        source,
        key,
        f"the joints ({spacings}) would cut the rock into about {estimate:,} blocks, more "
        f"than cutting.max_blocks = {limit:,}; check the spacings, or raise "
        "cutting.max_blocks (dda cut --max-blocks) to cut it",
    )


def _width(points: np.ndarray, dip: float) -> float:
    """Extent of ``points`` along the normal of traces dipping ``dip`` degrees."""
    theta = math.radians(dip)
    proj = points @ np.array([-math.sin(theta), math.cos(theta)])
    return float(proj.max() - proj.min())


def _persistence(js: JointSet) -> float:
    """Fraction of a trace that is joint: ``trace / (trace + bridge)``, 1 when persistent."""
    if js.trace_length is None:
        return 1.0
    return js.trace_length / (js.trace_length + js.bridge_length)
