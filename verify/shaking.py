"""Ground motion in motion cases: Newmark's sliding block on a level base.

Reference ``newmark`` of kind ``motion`` (:mod:`verify.motion`), computed from the
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
"""

from __future__ import annotations

import numpy as np

from dda import Scene
from verify.expect import ExpectationError
from verify.interfaces import find_interfaces
from verify.motion import Motion

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


def newmark(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """The block's motion on the shaken level base (module notes)."""
    interfaces = [i for i in find_interfaces(scene) if block in i.pair]
    g = -float(scene.analysis.gravity[1])
    if (
        len(interfaces) != 1
        or scene.analysis.gravity[0] != 0.0
        or scene.loads
        or any(scene.blocks[block].velocity)
    ):
        raise ExpectationError(f"{scene.source}: reference 'newmark': one interface, at rest")
    other = [b for b in interfaces[0].pair if b != block][0]
    if scene.blocks[other].name not in scene.seismic.blocks:
        raise ExpectationError(f"{scene.source}: reference 'newmark': the base must move")
    coords = np.asarray(interfaces[0].line.coords)
    if abs(coords[-1, 1] - coords[0, 1]) > 1e-12 * np.ptp(coords[:, 0]):
        raise ExpectationError(f"{scene.source}: reference 'newmark': a level interface")
    joint = interfaces[0].joint
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


REFERENCES = {"newmark": newmark}
