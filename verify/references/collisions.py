"""Many free blocks colliding in space: what conservation laws say of any run.

Reference ``momentum`` of kind ``motion`` (:mod:`verify.references.motion`), computed from
the scene alone:

    Free blocks without gravity, loads, fixed blocks or springs to the ground:
    the only forces are the contact forces between them, equal and opposite at
    each contact. Whatever the blocks do, the total momentum P = Σ m_i v_i
    (m_i = ρ A_i) keeps its value at the start, the centre of mass
    X = Σ m_i x_i / M moves at P / M, and the kinetic energy cannot grow (the
    contacts store energy while they are closed and give it back at most).
    Shi's scheme keeps P exactly: a step changes M v by Δt times the
    step's generalised forces, whose translational parts sum to zero over the
    blocks; the centroids move by Δt (v0 + v1)/2, so X follows P/M exactly too.
    Contacts must also keep the blocks apart: two blocks never overlap by more
    than the penalty springs' penetration.

Rows ``momentum`` (px, py of Σ m v in every saved frame against P0, scale |P0|),
``motion`` (the centre of mass, ux and uy, against X0 + P0 t / M, scale
|P0| T / M), ``stress`` (every block's stress against the stress its vertices
imply, :func:`verify.references.motion.stress_rows`, over the largest stress of any block),
``overlap`` (the largest overlap area of two blocks over the
smaller one's area, every frame, against 0) and ``energy`` (the energy the run
created, :func:`verify.references.motion.energy_rows`, scale the kinetic energy at the
start).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import shapely

from dda import Result, Scene
from verify.comparison.compare import Row
from verify.comparison.expect import ExpectationError
from verify.references.block import block_mass
from verify.references.motion import Track, energy_rows, run_record, stress_rows


def check_scene(scene: Scene) -> None:
    """Raise ExpectationError unless nothing but contacts acts on the blocks."""
    s = scene
    if any(s.analysis.gravity) or s.loads or any(b.fixed for b in s.blocks):
        raise ExpectationError(
            f"{s.source}: reference 'momentum': free blocks only, no gravity, no loads"
        )
    if s.seismic is not None or s.bolts or any(b.fixed_points for b in s.blocks):
        raise ExpectationError(f"{s.source}: reference 'momentum': no ground motion or springs")


def masses(scene: Scene) -> np.ndarray:
    """(n,) ρ A of every scene block."""
    return np.array([block_mass(scene, i) for i in range(len(scene.blocks))])


def largest_overlap(vertices: list[np.ndarray]) -> float:
    """The largest overlap area of two blocks over the smaller block's area."""
    polygons = [shapely.Polygon(v) for v in vertices]
    tree = shapely.STRtree(polygons)
    worst = 0.0
    for i, j in tree.query(polygons, predicate="intersects").T:
        if i < j:
            common = polygons[i].intersection(polygons[j]).area
            worst = max(worst, common / min(polygons[i].area, polygons[j].area))
    return worst


def momentum_rows(scene: Scene, result: Result) -> tuple[list[Row], dict]:
    """Rows ``momentum``, ``motion`` (centre of mass), ``overlap`` and ``energy`` of a run
    (module notes) and the series the report and the picture show."""
    check_scene(scene)
    mass = masses(scene)
    total = float(mass.sum())
    start = np.array([np.asarray(b.velocity, dtype=float)[:2] for b in scene.blocks])
    p0 = mass @ start
    names = [b.name for b in scene.blocks]
    frames = result.frames
    rows_of = [[f.block(n) for n in names] for f in frames]
    times = np.array([f.time for f in frames])
    p = np.array([mass @ f.velocities[r, :2] for f, r in zip(frames, rows_of, strict=True)])
    x = np.array([mass @ f.centroids[r] / total for f, r in zip(frames, rows_of, strict=True)])
    moved = x - x[0]
    expected = np.outer(times - times[0], p0 / total)
    overlap = np.array([largest_overlap(f.vertices) for f in frames])
    p_scale = float(np.linalg.norm(p0))
    if p_scale == 0.0:
        raise ExpectationError(f"{scene.source}: reference 'momentum': some block must move")
    u_scale = p_scale * float(times[-1] - times[0]) / total
    rows = []
    for k, t in enumerate(times):
        item = f"system@{t:.6g}"
        for m, c in enumerate(("px", "py")):
            rows.append(Row("momentum", item, c, float(p[k, m]), float(p0[m]), p_scale))
        for m, c in enumerate(("ux", "uy")):
            rows.append(Row("motion", item, c, float(moved[k, m]), float(expected[k, m]), u_scale))
        rows.append(Row("overlap", item, "area", float(overlap[k]), 0.0, 1.0))
    kinetic = 0.5 * float(np.sum(mass * np.sum(start**2, axis=1)))
    spins = [b for b in scene.blocks if np.asarray(b.velocity, dtype=float)[2]]
    if spins:
        raise ExpectationError(f"{scene.source}: reference 'momentum': no initial spin")
    track = Track(*([np.zeros(0)] * 8), *run_record(result))
    rows += energy_rows(scene, "system", {1: track}, kinetic)
    stress = [r for b, n in enumerate(names) for r in stress_rows(scene, b, Track.of(result, n))]
    largest = max(r.scale for r in stress)  # one scale: the largest stress of any block
    rows += [replace(r, scale=largest) for r in stress]
    errors = {
        "px": float(np.abs(p[:, 0] - p0[0]).max()),
        "py": float(np.abs(p[:, 1] - p0[1]).max()),
        "ux": float(np.abs(moved[:, 0] - expected[:, 0]).max()),
        "uy": float(np.abs(moved[:, 1] - expected[:, 1]).max()),
    }
    series = {
        "block": "centre of mass",
        "times": times,
        "momentum": p,
        "ref_momentum": p0,
        "dda_u": moved,
        "ref_u": expected,
        "overlap": overlap,
        "valid": np.ones(len(times), bool),
        "events": {"pairs_touched": touched_pairs(result)},
        "time_steps": {1: scene.analysis.time_step},
        "errors": {1: errors},
        "orders": {},
    }
    return rows, series


def touched_pairs(result: Result) -> int:
    """How many pairs of blocks had a contact in some saved frame (the report shows it:
    the contacts between the blocks changed through the run)."""
    pairs = set()
    for f in result.frames:
        c = f.contacts
        ids = f.ids
        both = zip(ids[c.block_a], ids[c.block_b], strict=True)
        pairs |= {(int(min(a, b)), int(max(a, b))) for a, b in both}
    return len(pairs)
