"""A block on a pretensioned rock bolt: harmonic oscillation along the bolt.

Reference ``bolt`` of kind ``motion`` (:mod:`verify.references.motion`), computed from the
scene alone:

    One free block at rest, no gravity, no loads, no contact (it touches no
    other block), released unloaded (``[analysis] start = "unloaded"``: the
    equilibrium start would preload the bolt to hold the block where it is drawn),
    held by one bolt of stiffness k and pretension f0 to a fixed
    block, the bolt's line through the block's centroid. The bolt pulls the
    block along its line n (from the block's end to the fixed end) with
    T = f0 − k s, s the displacement along n (the bolt's length falls by s),
    and its moment about the centroid is zero: the block oscillates about
    s = f0 / k without turning,

        u = (f0 / k) (1 − cos ω t) n,   ω = √(k / m),   r = 0

    (the bolt goes into compression −f0 at s = 2 f0 / k: a linear spring).
    Shi's scheme (Newmark β = ½, γ = 1) damps and shifts the oscillation at
    first order in ω Δt. Energy rows' scale: the spring's ½ f0² / k.
"""

from __future__ import annotations

import numpy as np
import shapely

from dda import Scene
from verify.comparison.expect import ExpectationError
from verify.fem.geometry import polygon_centroid
from verify.references.block import Motion, block_mass

# the bolt's line passes within this fraction of the block's size of its centroid
THROUGH = 1e-9


def bolt(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """The block's oscillation on its bolt (module notes)."""
    b = scene.blocks[block]
    bolts = list(scene.bolts)
    polygons = [shapely.Polygon(np.asarray(x.vertices, dtype=float)) for x in scene.blocks]
    touching = any(
        k != block and polygons[block].distance(p) == 0.0 for k, p in enumerate(polygons)
    )
    if (
        len(bolts) != 1
        or any(scene.analysis.gravity)
        or scene.loads
        or any(b.velocity)
        or touching
        or bolts[0].capacity is not None
        or scene.analysis.start != "unloaded"
    ):
        raise ExpectationError(
            f"{scene.source}: reference 'bolt': one bolt without capacity, no gravity, "
            "no loads, no contact, at rest, start = 'unloaded'"
        )
    anchor = bolts[0]
    if b.name not in anchor.blocks:
        raise ExpectationError(f"{scene.source}: reference 'bolt': the bolt holds the block")
    on_block, fixed_end = (
        (anchor.start, anchor.end) if anchor.blocks[0] == b.name else (anchor.end, anchor.start)
    )
    p, q = np.asarray(on_block, dtype=float), np.asarray(fixed_end, dtype=float)
    n = (q - p) / np.linalg.norm(q - p)
    vertices = np.asarray(b.vertices, dtype=float)
    arm = polygon_centroid(vertices) - p
    if abs(arm[0] * n[1] - arm[1] * n[0]) > THROUGH * float(np.ptp(vertices, axis=0).max()):
        raise ExpectationError(f"{scene.source}: reference 'bolt': a bolt through the centroid")
    k, f0 = anchor.stiffness, anchor.pretension
    mass = block_mass(scene, block)
    omega = float(np.sqrt(k / mass))
    s = f0 / k * (1.0 - np.cos(omega * np.asarray(times, dtype=float)))
    events = {"period": 2.0 * np.pi / omega, "amplitude": f0 / k}
    return Motion(np.outer(s, n), np.zeros(len(s)), np.ones(len(s), bool), events, 0.5 * f0**2 / k)


REFERENCES = {"bolt": bolt}
