"""Ground motion in motion cases: Newmark's sliding block on a level base.

Reference ``newmark`` of kind ``motion`` (:mod:`verify.references.motion`), computed from the
scene alone:

    One free block at rest on a level fixed base that follows the scene's
    ``[seismic]`` record, gravity g down, friction φ (μ = tan φ), no cohesion, no
    loads. The record is a horizontal rectangular pulse: A from t = 0 to t0, then 0
    (a ramp down of at most ``RAMP`` of t0 allowed), A > μ g. The ground's
    displacement u_g(t) is the exact double integral of the piecewise-linear record
    (times ``scale``). Friction is the only horizontal force on the block: it
    accelerates at μ g towards the ground's motion while it slides, until its speed
    reaches the ground's A t0 at t1 = A t0 / (μ g), and then moves with the ground:

        u_b = ½ μ g t²                          (t ≤ t1)
        u_b = ½ μ g t1² + A t0 (t − t1)         (t > t1)

    The slide relative to the base, u_g − u_b, ends at Newmark's
    d = (A − μ g) A t0² / (2 μ g). Rows ``motion``: the block's displacement
    (horizontal u_b, vertical 0) and rotation 0; the event ``slide`` is d.

Reference ``newmark_record``: the same block and base under any horizontal
piecewise-linear record (ramps: the ground's jerk terms). The block moves with
the ground while it sticks (u_b − u_g constant) and sticks while |a_g| ≤ μ g;
it slides at μ g towards the ground's velocity while its own differs. Within a
segment of the record a_g is linear, so the slip starts where a_g = ±μ g (a
linear root) and stops where the relative velocity w = v_g − v_b, a quadratic
in τ, returns to 0 (:func:`sliding_phases`: each root exact, no time step).

Both references add rows ``ground`` (:func:`ground_rows`): the moving base's
displacement and velocity as the engine reports them in every saved frame,
against the exact integrals of the record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda import Result, Scene
from verify.comparison.compare import Row
from verify.comparison.expect import ExpectationError
from verify.fem.interfaces import find_interfaces
from verify.references.block import Motion

# the pulse's ramp down may last at most this fraction of its length
RAMP = 1e-6


def ground_displacement(record: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(t,) ∫∫ a of the piecewise-linear record (rows t_k, a_k; zero outside it,
    the ground at rest at the start), at ``times``: on [t_k, t_k+1], τ = t − t_k,
    u = u_k + v_k τ + a_k τ²/2 + (a_k+1 − a_k) τ³/(6 h)."""
    tk, ak = record[:, 0], record[:, 1]
    h = np.diff(tk)
    dv = h * (ak[:-1] + ak[1:]) / 2
    vk = np.concatenate([[0.0], np.cumsum(dv)])
    du = vk[:-1] * h + ak[:-1] * h**2 / 2 + (ak[1:] - ak[:-1]) * h**2 / 6
    uk = np.concatenate([[0.0], np.cumsum(du)])
    t = np.clip(times, tk[0], None)
    k = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, len(tk) - 1)
    tau = t - tk[k]
    inside = k < len(tk) - 1
    jerk = np.where(inside, (ak[np.minimum(k + 1, len(tk) - 1)] - ak[k]) / np.append(h, 1.0)[k], 0)
    a = np.where(inside, ak[k], 0.0)  # after the record: its last velocity, no acceleration
    return uk[k] + vk[k] * tau + a * tau**2 / 2 + jerk * tau**3 / 6


def pulse(scene: Scene) -> tuple[float, float, np.ndarray]:
    """(A, t0, the scaled horizontal record) of a rectangular pulse, or ExpectationError."""
    s = scene.seismic
    rows = None if s is None else np.asarray(s.record, dtype=float)
    if rows is None or rows.shape[1] != 3 or np.any(rows[:, 2]) or rows[0, 0] != 0.0:
        raise ExpectationError(f"{scene.source}: reference 'newmark': a horizontal record")
    record = np.column_stack([rows[:, 0], s.scale * rows[:, 1]])
    amplitude = float(record[0, 1])
    held = record[:, 1] == amplitude
    last = int(np.flatnonzero(held).max())
    length = float(record[last, 0])
    if (
        not held[: last + 1].all()
        or np.any(record[last + 1 :, 1])
        or last + 1 >= len(record)
        or record[last + 1, 0] - length > RAMP * length
        or amplitude == 0.0
    ):
        raise ExpectationError(f"{scene.source}: reference 'newmark': a rectangular pulse")
    return amplitude, length, record


def _level_base(scene: Scene, block: int, reference: str):
    """(joint, g) of the block's one interface, with a moving base under it: the block at
    rest, no loads, gravity straight down, the interface level; else ExpectationError."""
    interfaces = [i for i in find_interfaces(scene) if block in i.pair]
    if (
        len(interfaces) != 1
        or scene.analysis.gravity[0] != 0.0
        or scene.loads
        or any(scene.blocks[block].velocity)
    ):
        raise ExpectationError(f"{scene.source}: reference '{reference}': one interface, at rest")
    other = [b for b in interfaces[0].pair if b != block][0]
    if scene.blocks[other].name not in scene.seismic.blocks:
        raise ExpectationError(f"{scene.source}: reference '{reference}': the base must move")
    coords = np.asarray(interfaces[0].line.coords)
    if abs(coords[-1, 1] - coords[0, 1]) > 1e-12 * np.ptp(coords[:, 0]):
        raise ExpectationError(f"{scene.source}: reference '{reference}': a level interface")
    return interfaces[0].joint, -float(scene.analysis.gravity[1])


def newmark(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """The block's motion on the shaken level base (module notes)."""
    joint, g = _level_base(scene, block, "newmark")
    mu_g = np.tan(np.radians(joint.friction_angle)) * g
    amplitude, length, record = pulse(scene)
    if joint.cohesion or abs(amplitude) <= mu_g:
        raise ExpectationError(f"{scene.source}: reference 'newmark': A > g tan φ, no cohesion")
    sense = np.sign(amplitude)
    speed = abs(amplitude) * length  # the ground's speed after the pulse
    t1 = speed / mu_g
    t = np.asarray(times, dtype=float)
    ub = np.where(t <= t1, 0.5 * mu_g * t**2, 0.5 * mu_g * t1**2 + speed * (t - t1))
    u = np.column_stack([sense * ub, np.zeros(len(t))])
    slide = (abs(amplitude) - mu_g) * abs(amplitude) * length**2 / (2 * mu_g)
    ground = ground_displacement(record, t)
    events = {"stop": t1, "slide": slide, "slide_at_end": float(ground[-1] - u[-1, 0])}
    return Motion(u, np.zeros(len(t)), np.ones(len(t), bool), events)


def _horizontal_record(scene: Scene) -> np.ndarray:
    """(k, 2) rows t, a_x of the scaled horizontal record (ExpectationError otherwise)."""
    s = scene.seismic
    rows = None if s is None else np.asarray(s.record, dtype=float)
    if rows is None or rows.shape[1] != 3 or np.any(rows[:, 2]) or rows[0, 0] < 0.0:
        raise ExpectationError(f"{scene.source}: reference 'newmark_record': a horizontal record")
    return np.column_stack([rows[:, 0], s.scale * rows[:, 1]])


def ground_velocity(record: np.ndarray, t: float) -> float:
    """v_g(t): the exact integral of the piecewise-linear record (its last value after it)."""
    tk, ak = record[:, 0], record[:, 1]
    if t <= tk[0]:
        return 0.0
    h = np.diff(tk)
    vk = np.concatenate([[0.0], np.cumsum(h * (ak[:-1] + ak[1:]) / 2)])
    if t >= tk[-1]:
        return float(vk[-1])
    k = int(np.searchsorted(tk, t, side="right")) - 1
    tau = t - tk[k]
    return float(vk[k] + ak[k] * tau + (ak[k + 1] - ak[k]) * tau**2 / (2 * h[k]))


def _first_root(coefficients: list[float], longest: float) -> float | None:
    """Smallest real root x in (0, longest] of the polynomial (highest power first)."""
    c = np.asarray(coefficients, dtype=float)
    c = c[np.argmax(np.abs(c) > 0) :] if np.any(c) else c[-1:]
    if len(c) < 2:
        return None
    roots = np.roots(c)
    real = roots[np.abs(roots.imag) <= 1e-9 * max(np.abs(roots).max(), 1e-300)].real
    real = real[(real > 1e-12 * longest) & (real <= longest)]
    return float(real.min()) if len(real) else None


@dataclass(frozen=True)
class Phase:
    """The block from t0 to t1: stuck (sense 0) or sliding at sense · μ g."""

    t0: float
    t1: float
    sense: int
    u0: float  # block displacement at t0
    v0: float  # block velocity at t0


def _segments(record: np.ndarray, end: float) -> list[tuple[float, float, float]]:
    """(start, length, jerk, a at start) of the pieces on which a_g is linear, up to end."""
    tk, ak = record[:, 0], record[:, 1]
    cuts = np.unique(np.clip(np.concatenate([[0.0], tk, [end]]), 0.0, end))
    out = []
    for t0, t1 in zip(cuts[:-1], cuts[1:], strict=True):
        inside = tk[0] <= t0 < tk[-1]
        a0 = float(np.interp(t0, tk, ak)) if inside else 0.0
        a1 = float(np.interp(t1, tk, ak)) if inside else 0.0
        if inside and t0 in tk:  # right-hand value at a record point
            a0 = float(ak[np.flatnonzero(tk == t0)[-1]])
        out.append((float(t0), float(t1 - t0), (a1 - a0) / (t1 - t0), a0))
    return out


def sliding_phases(record: np.ndarray, mu_g: float, end: float) -> list[Phase]:
    """The block's stuck and sliding phases from rest (stuck) at t = 0 up to ``end``."""
    phases: list[Phase] = []
    t, u_b, v_b, sense, start, u_start, v_start = 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0
    for t0, length, jerk, a0 in _segments(record, end):
        while t < t0 + length * (1 - 1e-13):
            left = t0 + length - t
            a_now = a0 + jerk * (t - t0)
            if sense == 0:
                beyond = abs(a_now) > mu_g * (1 + 1e-12)
                at_and_rising = abs(a_now) >= mu_g * (1 - 1e-12) and jerk * a_now > 0
                if beyond or at_and_rising:  # the slip starts
                    phases.append(Phase(start, t, 0, u_start, v_start))
                    sense, start, u_start, v_start = int(np.sign(a_now)), t, u_b, v_b
                    continue
                hits = [(c * mu_g - a_now) / jerk for c in (1, -1)] if jerk else []
                hits = [x for x in hits if 0.0 < x <= left]
                x = min(hits) if hits else left
                ug = ground_displacement(record, np.array([t, t + x]))
                u_b += float(ug[1] - ug[0])
                t += x
                v_b = ground_velocity(record, t)
                continue
            w0 = ground_velocity(record, t) - v_b  # relative velocity v_g - v_b
            root = _first_root([jerk / 2, a_now - sense * mu_g, w0], left)
            x = left if root is None else root
            u_b += v_b * x + 0.5 * sense * mu_g * x**2
            v_b += sense * mu_g * x
            t += x
            if root is not None:  # the block has the ground's velocity: it sticks
                phases.append(Phase(start, t, sense, u_start, v_start))
                sense, start, u_start, v_start = 0, t, u_b, ground_velocity(record, t)
                v_b = v_start
    phases.append(Phase(start, max(end, t), sense, u_start, v_start))
    return phases


def block_displacement(
    record: np.ndarray, mu_g: float, phases: list[Phase], times: np.ndarray
) -> np.ndarray:
    """u_b at ``times`` from the phases: the ground's steps while stuck, μ g while sliding."""
    out = np.empty(len(times))
    for k, t in enumerate(times):
        p = next((p for p in phases if t <= p.t1), phases[-1])
        if p.sense == 0:
            ug = ground_displacement(record, np.array([p.t0, t]))
            out[k] = p.u0 + ug[1] - ug[0]
        else:
            x = t - p.t0
            out[k] = p.u0 + p.v0 * x + 0.5 * p.sense * mu_g * x**2
    return out


def newmark_record(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """The block on the level base under any horizontal record (module notes)."""
    joint, g = _level_base(scene, block, "newmark_record")
    if joint.cohesion:
        raise ExpectationError(f"{scene.source}: reference 'newmark_record': no cohesion")
    mu_g = np.tan(np.radians(joint.friction_angle)) * g
    record = _horizontal_record(scene)
    t = np.asarray(times, dtype=float)
    phases = sliding_phases(record, mu_g, float(t.max()))
    ub = block_displacement(record, mu_g, phases, t)
    events = {f"phase{k}_{'slide' if p.sense else 'stick'}": p.t0 for k, p in enumerate(phases)}
    ground = ground_displacement(record, t)
    events["slide_at_end"] = float(ground[-1] - ub[-1])
    u = np.column_stack([ub, np.zeros(len(t))])
    return Motion(u, np.zeros(len(t)), np.ones(len(t), bool), events)


def ground_rows(scene: Scene, result: Result) -> list[Row]:
    """Rows ``ground``: every moving base's displacement and velocity as the engine reports
    them in each saved frame (ux, uy, vx, vy) against the exact integrals of the record
    (the ground at rest before it, its last velocity after it); scales the largest
    ground displacement and speed over the frames."""
    s = scene.seismic
    rows = np.asarray(s.record, dtype=float)
    record = np.column_stack([rows[:, 0], s.scale * rows[:, 1:3]])
    times = np.array([f.time for f in result.frames])
    u = np.column_stack([ground_displacement(record[:, [0, 1 + m]], times) for m in range(2)])
    v = np.array([[ground_velocity(record[:, [0, 1 + m]], t) for m in range(2)] for t in times])
    u_scale = float(np.abs(u).max()) or 1.0
    v_scale = float(np.abs(v).max()) or 1.0
    out = []
    for name in s.blocks:
        for k, f in enumerate(result.frames):
            j, item = f.block(name), f"{name}@{times[k]:.6g}"
            du, dv = f.displacements[j], f.velocities[j, :2]
            for m, c in enumerate(("x", "y")):
                out.append(Row("ground", item, f"u{c}", float(du[m]), float(u[k, m]), u_scale))
                out.append(Row("ground", item, f"v{c}", float(dv[m]), float(v[k, m]), v_scale))
    return out


REFERENCES = {"newmark": newmark, "newmark_record": newmark_record}
# rows from the whole run beside the free block's (verify.harness.runners.run_motion)
RUN_ROWS = {"newmark": ground_rows, "newmark_record": ground_rows}
