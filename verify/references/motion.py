"""Motion cases: the engine at several time steps against a closed form (kind ``motion``).

A motion case is a scene the engine runs as written and again with its time
step multiplied by the expectation's ``time_steps`` (e.g. 4, 2, 1; the
duration and the times of the saved frames kept). Its reference is computed
here from the scene alone (``reference`` in the expectation file):

``free``
    blocks without loads or contacts: the centroid moves at the block's
    initial velocity and the block turns at its initial ω,
    u = v t, r = ω t, the area is kept (a spinning block through a full
    revolution tests the exact rotation update).
``slide``
    one free block on a planar interface with a fixed block: with W the
    block's weight plus its point loads plus the water table's force on it
    (:mod:`verify.references.water`), N = −W·n and T = W·t along the
    interface (unit normal n out of the fixed block, tangent t),
    the block sticks while |T| ≤ tan φ N + c L and otherwise slides with
    a = (T − sign T · tan φ N) / m along t (the cohesion is lost once it
    slips): u = ½ a t² t, r = 0. Shi's scheme is exact for a constant
    acceleration. On a brittle joint (residual cohesion below the peak) a
    rectangular block holds only if its two base corners do, one after the other
    (:func:`brittle_holds`: the uphill corner, less pressed, slips first).
``rocking``
    a rectangular block resting on one corner of its base, tilted by θ0 from
    standing on a level fixed base (Housner's rocking block), released from rest;
    rigid rotation about the corner until the first impact,
    θ'' = −(3 g / (4 R)) sin(α − θ), R the half-diagonal, α = atan(b/h), θ the
    tilt (θ0 at t = 0), integrated with scipy (rtol 1e-11) up to θ = 0. Rows
    before the impact only.
``drop``, ``overlap``
    a block dropped onto a level base, a block drawn overlapping its base
    (:mod:`verify.references.impact`, with their rows of the impact and the rebound).

Rows ``motion`` (every saved frame of the finest run: the centroid displacement
ux, uy in the case's frame and the rotation r measured from the vertices — the
angle of the polar decomposition of the affine map that moved them, so a
first-order vertex update that rotates by atan r₀ and inflates by 1 + r₀² is
seen), ``area`` (the largest |A/A₀ − 1| over the frames), ``stress`` (the
block's stress against the stress its vertices imply, :func:`stress_rows`) and
``order`` (the
observed order of accuracy in Δt of each component, log(e(f Δt)/e(Δt))/log f
between the two finest runs, e the largest |DDA − reference| over the common
frames; against the expectation's ``order`` when it states one), and where the
reference gives an energy scale ``energy`` (:func:`energy_rows`: the energy the
run created, from its energy record, at each time step).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import polar

from dda import Result, Scene
from dda.result import OPEN
from verify.comparison.compare import STRESS, Row, vector_in_frame
from verify.comparison.expect import Expectation, ExpectationError
from verify.fem.geometry import polygon_centroid
from verify.fem.interfaces import find_interfaces
from verify.references.block import Motion, block_mass, free_block
from verify.references.water import uniform_under_table, water_force


def applied_force(scene: Scene, block: int) -> np.ndarray:
    """Weight plus the point loads on the block (loads without a history) plus the
    water table's force on it (:func:`verify.references.water.water_force`; constant while the
    block stays wholly under one straight stretch of the table)."""
    b = scene.blocks[block]
    weight = block_mass(scene, block) * np.asarray(scene.analysis.gravity, dtype=float)
    loads = [np.asarray(load.force, dtype=float) for load in scene.loads if load.block == b.name]
    return weight + sum(loads, np.zeros(2)) + water_force(scene, block)


def free_motion(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """u = v t, r = ω t."""
    if any(scene.analysis.gravity) or scene.loads or len(scene.blocks) > 1:
        raise ExpectationError(f"{scene.source}: reference 'free': one block, no gravity, no loads")
    vx, vy, omega = scene.blocks[block].velocity
    u = np.outer(times, [vx, vy])
    return Motion(u, omega * times, np.ones(len(times), bool), {})


def slide(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """½ a t² along the interface, a from Coulomb's law (module notes)."""
    interfaces = [i for i in find_interfaces(scene) if block in i.pair]
    if len(interfaces) != 1 or any(scene.blocks[block].velocity):
        raise ExpectationError(f"{scene.source}: reference 'slide': one interface, at rest")
    if not uniform_under_table(scene, block):
        raise ExpectationError(
            f"{scene.source}: reference 'slide': water: the block wholly under one straight "
            "stretch of the table"
        )
    interface = interfaces[0]
    coords = np.asarray(interface.line.coords if hasattr(interface.line, "coords") else [])
    if len(coords) < 2:
        raise ExpectationError(f"{scene.source}: reference 'slide': a straight interface")
    tangent = (coords[-1] - coords[0]) / np.linalg.norm(coords[-1] - coords[0])
    normal = np.array([-tangent[1], tangent[0]])
    centre = polygon_centroid(np.asarray(scene.blocks[block].vertices, dtype=float))
    if np.dot(centre - coords[0], normal) < 0:  # n points from the base into the block
        normal = -normal
    force = applied_force(scene, block)
    pressing, drive = -float(force @ normal), float(force @ tangent)
    joint = interface.joint
    bound = np.tan(np.radians(joint.friction_angle)) * max(pressing, 0.0)
    holds = abs(drive) <= bound + joint.cohesion * interface.length
    if holds and joint.residual_cohesion < joint.cohesion:
        holds = brittle_holds(scene, block, joint, pressing, drive, tangent)
    a = 0.0 if holds else (drive - np.sign(drive) * bound) / block_mass(scene, block)
    u = np.outer(0.5 * a * times**2, tangent)
    return Motion(u, np.zeros(len(times)), np.ones(len(times), bool), {"friction": bound})


def brittle_holds(scene: Scene, block: int, joint, pressing: float, drive: float,
                  tangent: np.ndarray) -> bool:  # fmt: skip
    """Whether a rectangular block on a brittle joint (its residual cohesion below its
    cohesion: a contact that slips loses it) holds on its two base corners.

    A rigid block of base L and height h (along and across the interface) standing on
    its base's two corners carries N = W_n / 2 ∓ W_t h / (2L) on the uphill and downhill
    corner (moment about its centroid) and, on equal shear springs, F = W_t / 2 on each.
    The uphill corner slips once W_t / 2 > tan φ N_up + c L / 2 and loses its cohesion;
    its friction tan φ N_up left, the downhill corner must carry W_t − tan φ N_up on
    tan φ N_down + c L / 2, or slips too: the block then slides on friction alone.
    (Residual cohesion and tensile strength are taken as zero, the default.)"""
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    along = vertices @ tangent
    across = vertices @ np.array([-tangent[1], tangent[0]])
    length, height = float(np.ptp(along)), float(np.ptp(across))
    tan_phi, share = np.tan(np.radians(joint.friction_angle)), joint.cohesion * length / 2.0
    lever = abs(drive) * height / (2.0 * length)
    uphill, downhill = pressing / 2.0 - lever, pressing / 2.0 + lever
    if abs(drive) / 2.0 <= tan_phi * max(uphill, 0.0) + share:
        return True
    return abs(drive) - tan_phi * max(uphill, 0.0) <= tan_phi * downhill + share


def dissipation_rows(scene: Scene, result: Result) -> list[Row]:
    """Row ``dissipation`` (reference ``slide``): the friction work the run recorded
    (``summary["friction_dissipation"]``) against tan φ N times the distance slid at
    the end (0 where the block sticks); scale tan φ N times the larger of that
    distance and ½ g t² (what gravity alone would move it)."""
    block = free_block(scene)
    end = float(result.frames[-1].time)
    ref = slide(scene, block, np.array([end]))
    friction = float(ref.events["friction"])
    slid = float(np.linalg.norm(ref.u[-1]))
    reach = max(slid, 0.5 * float(np.linalg.norm(scene.analysis.gravity)) * end**2)
    work = float(result.summary.get("friction_dissipation", float("nan")))
    name = scene.blocks[block].name
    return [Row("dissipation", name, "friction", work, friction * slid, friction * reach or 1.0)]


def rocking(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """Housner's rigid rocking about the lowest corner until the first impact."""
    v = np.asarray(scene.blocks[block].vertices, dtype=float)
    if len(v) != 4 or scene.analysis.gravity[0] != 0.0:
        raise ExpectationError(f"{scene.source}: reference 'rocking': a rectangle, vertical g")
    g = -float(scene.analysis.gravity[1])
    pivot_index = int(np.argmin(v[:, 1]))
    pivot = v[pivot_index]
    centre = polygon_centroid(v)
    arm = centre - pivot
    radius = float(np.linalg.norm(arm))
    edges = [v[(pivot_index + 1) % 4] - pivot, v[pivot_index - 1] - pivot]
    slopes = [abs(e[1]) / max(abs(e[0]), 1e-300) for e in edges]
    base_edge, side = edges if slopes[0] < slopes[1] else edges[::-1]
    width, height = np.linalg.norm(base_edge), np.linalg.norm(side)
    alpha = float(np.arctan2(width / 2, height / 2))
    tilt0 = float(np.arctan(slopes[0] if slopes[0] < slopes[1] else slopes[1]))
    sense = np.sign(arm[0])  # +1: centroid right of the pivot, the block turns clockwise back
    p2 = 3.0 * g / (4.0 * radius)

    def rhs(_t, y):
        return [y[1], -p2 * np.sin(alpha - y[0])]

    def impact(_t, y):
        return y[0]

    impact.terminal, impact.direction = True, -1
    end = float(times[-1])
    sol = solve_ivp(
        rhs,
        (0.0, 2.0 * end + 1.0),
        [tilt0, 0.0],
        events=impact,
        dense_output=True,
        rtol=1e-11,
        atol=1e-14,
    )
    t_impact = float(sol.t_events[0][0]) if len(sol.t_events[0]) else np.inf
    valid = times < t_impact
    tilt = np.where(valid, sol.sol(np.minimum(times, sol.t[-1]))[0], 0.0)
    r = sense * (tilt - tilt0)  # anticlockwise positive
    c, s = np.cos(r), np.sin(r)
    turned = np.column_stack([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]])
    return Motion(turned - arm, r, valid, {"impact": t_impact})


# the stress rows' smallest scale, as a strain (about the elastic strains of the cases):
# a block that carries no stress is not judged on the round-off of its vertices
STRAIN_FLOOR = 1e-6

# errors below this fraction of their scale are round-off (no order is measured from them)
ROUND_OFF = 1e-10

REFERENCES = {"free": free_motion, "slide": slide, "rocking": rocking}


def with_time_step(scene: Scene, factor: int) -> Scene:
    """The scene with its time step × ``factor``, the same duration and frame times."""
    a = scene.analysis
    if a.save_every % factor or (a.steps is not None and a.steps % factor):
        raise ExpectationError(
            f"{scene.source}: time_steps: {factor} must divide save_every and steps"
        )
    steps = None if a.steps is None else a.steps // factor
    analysis = replace(
        a, time_step=a.time_step * factor, steps=steps, save_every=a.save_every // factor
    )
    return replace(scene, analysis=analysis)


def vertex_motion(before: np.ndarray, after: np.ndarray, near: float) -> tuple[float, np.ndarray]:
    """Rotation and strain of the affine map F = V R that took ``before`` to ``after``
    (left polar decomposition): the angle of R, the multiple of 2π nearest to ``near``
    added, and (exx, eyy, gxy) of V − I, in the current axes."""
    x0 = before - before.mean(axis=0)
    x1 = after - after.mean(axis=0)
    gradient = np.linalg.lstsq(x0, x1, rcond=None)[0].T
    turn, stretch = polar(gradient, side="left")
    angle = float(np.arctan2(turn[1, 0], turn[0, 0]))
    e = stretch - np.eye(2)
    strain = np.array([e[0, 0], e[1, 1], 2.0 * e[0, 1]])
    return angle + 2.0 * np.pi * round((near - angle) / (2.0 * np.pi)), strain


def elasticity(scene: Scene, block: int) -> np.ndarray:
    """The 3 × 3 plane stress or plane strain matrix of the block's material."""
    m = scene.materials[scene.blocks[block].material]
    e, nu = m.young, m.poisson
    if scene.analysis.plane == "strain":
        f = e / ((1 + nu) * (1 - 2 * nu))
        return f * np.array([[1 - nu, nu, 0], [nu, 1 - nu, 0], [0, 0, (1 - 2 * nu) / 2]])
    f = e / (1 - nu * nu)
    return f * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])


def turned_stress(stress: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(t, 3) R σ Rᵀ of one stress (sxx, syy, sxy) for each angle (anticlockwise)."""
    sigma = np.array([[stress[0], stress[2]], [stress[2], stress[1]]])
    c, s = np.cos(angle), np.sin(angle)
    turn = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (t, 2, 2)
    out = turn @ sigma @ np.swapaxes(turn, -1, -2)
    return np.stack([out[:, 0, 0], out[:, 1, 1], out[:, 0, 1]], -1)


@dataclass(frozen=True)
class Track:
    """One block through one run: times, centroid displacement, rotation, area, and the
    run's contact and energy record."""

    times: np.ndarray
    u: np.ndarray
    r: np.ndarray
    area: np.ndarray
    stress: np.ndarray  # (t, 3)
    strain: np.ndarray  # (t, 3) V − I from the vertices, current axes
    velocity: np.ndarray  # (t, 3) vx, vy, ω
    closed: np.ndarray  # (t,) bool: a contact of the block is closed in that frame
    step_times: np.ndarray  # (s,) the end of every step of the run
    step_closed: np.ndarray  # (s,) bool: the step ended with a closed contact
    energy_gain: float  # largest E − E0 − W over the run's steps (NaN: no record)

    @classmethod
    def of(cls, result: Result, name: str) -> Track:
        """The block called ``name`` in every saved frame of ``result``."""
        first = result.frames[0]
        v0 = first.vertices[first.block(name)]
        times, u, r, area, stress, strain, velocity, closed = ([] for _ in range(8))
        for f in result.frames:
            k = f.block(name)
            times.append(f.time)
            u.append(f.displacements[k])
            angle, e = vertex_motion(v0, f.vertices[k], float(f.rotations[k]))
            r.append(angle)
            strain.append(e)
            area.append(f.areas[k])
            stress.append(f.stresses[k])
            velocity.append(f.velocities[k])
            c = f.contacts
            closed.append(bool(np.any(((c.block_a == k) | (c.block_b == k)) & (c.state != OPEN))))
        arrays = (times, u, r, area, stress, strain, velocity, closed)
        return cls(*(np.array(a) for a in arrays), *run_record(result))


def run_record(result: Result) -> tuple[np.ndarray, np.ndarray, float]:
    """From ``result.history``: the end of every step, whether it ended with a closed
    contact (its largest penetration > 0), and the largest T + V + U + C − E0 − W
    over the steps (dda.run.energy; E0 the summary's ``initial_energy``)."""
    h = result.history
    times = np.asarray(h.get("time", ()), dtype=float)
    if not len(times):
        return times, np.zeros(0, bool), float("nan")
    closed = np.asarray(h["max_penetration"]) > 0.0
    excess = np.asarray(h["total_energy"]) - np.asarray(h["external_work"])
    return times, closed, float(np.max(excess) - result.summary["initial_energy"])


def errors_at(track: Track, reference, frame: float, times: np.ndarray) -> dict[str, float]:
    """Largest |DDA − reference| of ux, uy (in ``frame``) and r over ``times``."""
    keep = np.isin(np.round(track.times, 9), np.round(times, 9))
    ref = reference(track.times[keep])
    du = vector_in_frame(track.u[keep][ref.valid] - ref.u[ref.valid], frame)
    dr = track.r[keep][ref.valid] - ref.r[ref.valid]
    if not len(dr):
        return {"ux": float("nan"), "uy": float("nan"), "r": float("nan")}
    return {
        "ux": float(np.abs(du[:, 0]).max()),
        "uy": float(np.abs(du[:, 1]).max()),
        "r": float(np.abs(dr).max()),
    }


def observed_order(coarse: float, fine: float, ratio: float) -> float:
    """log(e_coarse / e_fine) / log(ratio); NaN when an error is zero or not finite."""
    if not (np.isfinite(coarse) and np.isfinite(fine)) or coarse <= 0.0 or fine <= 0.0:
        return float("nan")
    return float(np.log(coarse / fine) / np.log(ratio))


def stress_rows(scene: Scene, block: int, track: Track) -> list[Row]:
    """Rows ``stress``: the block's stress against the stress its vertices imply,
    σ = R σ₀ Rᵀ + C ε (σ₀ the first frame's stress turned with the block by the
    rotation since, ε the strain of the vertices since the first frame, current axes).
    A constant-strain block's stress is C times its strain whatever moves it. Scale:
    the largest stress of either side, at least C₁₁ × ``STRAIN_FLOOR``."""
    stiffness = elasticity(scene, block)
    implied = turned_stress(track.stress[0], track.r) + track.strain @ stiffness.T
    floor = STRAIN_FLOOR * float(stiffness[0, 0])  # a block without stress: not round-off
    scale = max(float(np.abs(track.stress).max()), float(np.abs(implied).max()), floor)
    name = scene.blocks[block].name
    return [
        Row("stress", f"{name}@{t:.6g}", c, float(track.stress[k, m]), float(implied[k, m]), scale)
        for k, t in enumerate(track.times)
        for m, c in enumerate(STRESS)
    ]


def energy_rows(scene: Scene, name: str, tracks: dict[int, Track], scale: float) -> list[Row]:
    """Rows ``energy``, one per time step: the largest T + V + U + C − E0 − W over the
    run's steps where it is positive (energy the run created; 0 where it only
    dissipated), over ``scale``."""
    return [
        Row(
            "energy",
            name,
            f"gain@{factor * scene.analysis.time_step:g}",
            max(track.energy_gain, 0.0) if np.isfinite(track.energy_gain) else float("nan"),
            0.0,
            scale,
        )
        for factor, track in sorted(tracks.items())
    ]


def motion_rows(
    scene: Scene, expectation: Expectation, tracks: dict[int, Track], references=None
) -> tuple[list[Row], dict]:
    """Rows ``motion``, ``area``, ``order`` and, where the reference gives their scale,
    ``energy`` (module notes) and the study's series. ``references``: name → closed
    form (default :data:`REFERENCES`)."""
    references = REFERENCES if references is None else references
    block = free_block(scene)
    name = scene.blocks[block].name
    try:
        function = references[expectation.reference]
    except KeyError:
        raise ExpectationError(
            f"{expectation.reference!r} is not a motion reference ({', '.join(references)})"
        ) from None

    def reference(times: np.ndarray) -> Motion:
        return function(scene, block, times)

    finest = tracks[min(tracks)]
    ref = reference(finest.times)
    frame = expectation.frame
    dda_u = vector_in_frame(finest.u, frame)
    ref_u = vector_in_frame(ref.u, frame)
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    half_diagonal = 0.5 * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    last = float(finest.times[ref.valid].max()) if ref.valid.any() else 0.0
    u_scale = float(np.abs(ref_u[ref.valid]).max(initial=0.0))
    if u_scale == 0.0:  # at rest: what gravity would move it in that time
        u_scale = 0.5 * float(np.linalg.norm(scene.analysis.gravity)) * last**2 or 1.0
    r_scale = float(np.abs(ref.r[ref.valid]).max(initial=0.0)) or u_scale / half_diagonal
    rows = []
    for k in np.flatnonzero(ref.valid):
        item = f"{name}@{finest.times[k]:.6g}"
        values = [
            ("ux", dda_u[k, 0], ref_u[k, 0], u_scale),
            ("uy", dda_u[k, 1], ref_u[k, 1], u_scale),
        ]
        values.append(("r", finest.r[k], ref.r[k], r_scale))
        for component, d, f, scale in values:
            rows.append(Row("motion", item, component, float(d), float(f), scale))
    drift = float(np.abs(finest.area / finest.area[0] - 1.0).max())
    rows.append(Row("area", name, "area", drift, 0.0, 1.0))
    rows += stress_rows(scene, block, finest)
    common = tracks[max(tracks)].times
    errors = {f: errors_at(t, reference, frame, common) for f, t in sorted(tracks.items())}
    floor = {"ux": ROUND_OFF * u_scale, "uy": ROUND_OFF * u_scale, "r": ROUND_OFF * r_scale}
    for e in errors.values():  # an error at round-off has no order: 0 makes it NaN
        e.update({c: (0.0 if v < floor[c] else v) for c, v in e.items()})
    factors = sorted(tracks)
    orders = {}
    if len(factors) > 1:
        fine, coarse = factors[0], factors[1]
        expected = float("nan") if expectation.order is None else expectation.order
        for component in ("ux", "uy", "r"):
            p = observed_order(errors[coarse][component], errors[fine][component], coarse / fine)
            orders[component] = p
            rows.append(Row("order", name, component, p, expected, 1.0))
    if ref.energy_scale is not None:
        rows += energy_rows(scene, name, tracks, ref.energy_scale)
    rows = [row.with_offset(expectation.offsets) for row in rows]
    series = {
        "block": name,
        "times": finest.times,
        "dda_u": dda_u,
        "ref_u": ref_u,
        "dda_r": finest.r,
        "ref_r": ref.r,
        "valid": ref.valid,
        "events": ref.events,
        "time_steps": {f: f * scene.analysis.time_step for f in factors},
        "errors": errors,
        "orders": orders,
    }
    return rows, series
