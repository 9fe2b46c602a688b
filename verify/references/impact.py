"""Impacts in motion cases: a block dropped onto a base, a block drawn overlapping it.

References of kind ``motion`` (:mod:`verify.references.motion`), computed from the scene alone:

``drop``
    One free block at rest above a level fixed base, gravity down, no loads, the
    penalty method, frictionless joints, no material damping. Its lowest vertices
    (n of them, level) are h above the base's top: free fall u = (0, −½ g t²)
    until t_f = √(2 h / g) (rows ``motion`` before t_f), impact at v = √(2 g h).
    Each landing vertex is a penalty spring p: the block rings on n p at
    ω = √(n p / m) and, under gravity, stays on the springs for
    (π + 2 atan(g / (ω v))) / ω. A rigid block on an undamped linear spring
    leaves it at the speed it hit it: the rebound coefficient tends to e = 1 as
    Δt → 0, provided the block's strain modes are far faster than ω (at least
    ``STIFF_BLOCK`` ω: they follow the contact force and give their energy back;
    no friction and no damping take any). A contact as stiff as the block
    excites its strain modes and keeps part of the energy in them.
    Shi's velocity update (Newmark β = ½, γ = 1) damps the ringing by about
    ξ = ω Δt / 4, so 1 − e is first order in ω Δt. With a joint's ``restitution`` e₀
    each landing contact has a dashpot c = 2 ζ √(m p / n) beside its spring
    (dda/solve/contact_dashpots.py): the reference is then the rigid block on n springs
    and dashpots under gravity, integrated to 1e-12 (its rebound e₀ itself without
    gravity), and its time on the springs.

    Rows ``impact_time`` (the end of the first step that closed a contact
    against t_f, scale Δt, offset ½ Δt: the contact closes at the end of the step
    in which the block reaches the base, t_f ≤ t ≤ t_f + Δt, an error in
    [−½, ½]); ``contact_time`` (from the end of that step to the end of the
    first step after it that ended open, against the rigid block's time on the
    springs, scale Δt: each end is decided at the end of its step);
    ``impact_speed`` (the speed at which the block of the last frame
    before the contact reaches the base, √(|v|² + 2 g (u_y + h)), against
    √(2 g h): free flight keeps ½ |v|² + g u_y, exactly in Shi's scheme under a
    constant acceleration); ``rebound`` (e = √(|v|² + 2 g (u_y + h)) / √(2 g h)
    at the first frame in flight after the contact, component ``e@Δt`` per time
    step against 1 (with restitution, the reference's); component ``limit``:
    e(Δt) + (e(Δt) − e(f Δt)) / (f − 1) between the two finest runs, the limit of a
    first-order error, against the same)
    and ``order`` (component ``e``: the observed order of 1 − e between the two
    finest runs). Energy rows' scale: m g h.
``overlap``
    One free block at rest, no gravity, no loads, drawn overlapping a fixed
    block by d (its deepest vertex inside it), deeper than the contact
    tolerance, in a dynamic run that starts unloaded: the first step finds the
    contact already that deep, solves it from touch, and removes the overlap by
    moving the block (dda.contact.push_out), not by giving it a velocity: the
    first step's D is the least rigid motion that moves the deepest vertex out by d
    along the normal n of the nearest boundary, with no strain,
    D = M⁻¹ gᵀ d / (g M⁻¹ gᵀ) on the translation and turn, g = nᵀ T(vertex) there,
    M those rows of ρ ∫ Tᵀ T dA (Shi's first-order displacement T about the
    centroid): rows ``motion`` at t = 0 and at the end of the first step only.
    Nothing acts on the block: its energy stays at E0 + W = 0. The push counted in
    the velocity, 2 D / Δt, would give it about 2 d² / (Δt² g M⁻¹ gᵀ), of the
    order of ½ m (d / Δt)²: the scale of the rows ``energy``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.linalg import eigh

from dda import Scene
from verify.comparison.compare import Row
from verify.comparison.expect import Expectation, ExpectationError
from verify.fem.geometry import polygon_centroid
from verify.references.block import Motion, block_mass, free_block
from verify.references.motion import Track, elasticity, observed_order

# vertices within this fraction of the block's size of its lowest point land together
LEVEL = 1e-9

# a drop's block: its slowest strain mode at least this many times the contact's ω
# (1 - e of the Δt -> 0 limit, rigid block and strain modes on the springs: 1.1e-5 at
# 22 times, 1.2e-4 at 11, 1.3e-2 at 3.5; docs/verification.md)
STIFF_BLOCK = 20.0


@dataclass(frozen=True)
class Drop:
    """A block dropped from rest onto a level base (module notes)."""

    height: float  # h: its lowest vertices above the base's top
    gravity: float  # g
    mass: float
    landing: int  # n: vertices that land together
    penalty: float  # p of each contact spring
    restitution: float = 1.0  # e of the joint (1: no dashpot)

    @property
    def time(self) -> float:
        """t_f = √(2 h / g)."""
        return float(np.sqrt(2.0 * self.height / self.gravity))

    @property
    def speed(self) -> float:
        """v = √(2 g h)."""
        return float(np.sqrt(2.0 * self.gravity * self.height))

    @property
    def omega(self) -> float:
        """ω = √(n p / m) of the block on its contact springs."""
        return float(np.sqrt(self.landing * self.penalty / self.mass))

    @property
    def contact_time(self) -> float:
        """(π + 2 atan(g / (ω v))) / ω: a rigid block on the springs, under gravity;
        with a dashpot, :meth:`damped_landing`'s."""
        if self.restitution < 1.0:
            return self.damped_landing()[0]
        w = self.omega
        return float((np.pi + 2.0 * np.arctan(self.gravity / (w * self.speed))) / w)

    @property
    def rebound(self) -> float:
        """The rebound coefficient of the rigid block: 1 on undamped springs, else
        :meth:`damped_landing`'s."""
        return 1.0 if self.restitution >= 1.0 else self.damped_landing()[1]

    def damped_landing(self) -> tuple[float, float]:
        """(time on the springs, rebound speed / impact speed) of the rigid block on n
        springs p and dashpots c = 2 ζ √(m p / n), ζ = −ln e / √(π² + ln² e), under gravity:
        m ẍ = −n p x − n c ẋ + m g from x = 0, ẋ = v until x is 0 again (integrated to
        1e-12; e itself without gravity)."""
        from scipy.integrate import solve_ivp

        log_e = np.log(self.restitution) if self.restitution > 0 else -np.inf
        zeta = 1.0 if self.restitution <= 0 else -log_e / np.sqrt(np.pi**2 + log_e**2)
        k = self.landing * self.penalty
        c = 2.0 * zeta * np.sqrt(k * self.mass)
        m, g = self.mass, self.gravity

        def motion(_t, y):
            return [y[1], (-k * y[0] - c * y[1]) / m + g]

        def leaves(_t, y):
            return y[0]

        leaves.terminal, leaves.direction = True, -1
        span = 10.0 * np.pi / self.omega
        out = solve_ivp(motion, (0.0, span), [0.0, self.speed], events=leaves, rtol=1e-12,
                        atol=1e-14 * self.height, max_step=0.01 / self.omega)  # fmt: skip
        return float(out.t_events[0][0]), float(-out.y_events[0][0][1] / self.speed)


def drop_of(scene: Scene, block: int) -> Drop:
    """The drop of ``block`` (module notes), or ExpectationError saying what is missing."""
    a, b = scene.analysis, scene.blocks[block]
    where = f"{scene.source}: reference 'drop'"
    if a.gravity[0] != 0.0 or a.gravity[1] >= 0.0 or scene.loads or any(b.velocity):
        raise ExpectationError(f"{where}: gravity down, no loads, the block at rest")
    if scene.contact.method != "penalty":
        raise ExpectationError(f"{where}: the penalty method (a linear spring at each contact)")
    lossy = any(j.friction_angle or j.cohesion for j in scene.joints.values())
    if lossy or scene.materials[b.material].damping:
        raise ExpectationError(f"{where}: frictionless joints and no material damping")
    restitutions = {j.restitution for j in scene.joints.values()}
    if len(restitutions) > 1:
        raise ExpectationError(f"{where}: one restitution (or none) for every joint")
    height, landing = landing_height(scene, block)
    if not height > 0.0:
        raise ExpectationError(f"{where}: the block's lowest vertices above a level fixed base")
    penalty = scene.contact.penalty or 10.0 * max(m.young for m in scene.materials.values())
    g = -float(a.gravity[1])
    e = restitutions.pop()
    drop = Drop(height, g, block_mass(scene, block), landing, float(penalty),
                1.0 if e is None else float(e))  # fmt: skip
    if strain_frequency(scene, block) < STIFF_BLOCK * drop.omega:
        raise ExpectationError(
            f"{where}: a block whose strain modes are {STIFF_BLOCK:g} times as fast as its "
            f"contact springs (ω = {drop.omega:.4g} rad/s): only then is e = 1 the limit"
        )
    return drop


def landing_height(scene: Scene, block: int) -> tuple[float, int]:
    """(h, n): the height of the block's lowest vertices (n of them, level) above the
    top of the fixed blocks, or (NaN, n) unless the top is a level edge under them."""
    v = np.asarray(scene.blocks[block].vertices, dtype=float)
    tol = LEVEL * float(np.ptp(v, axis=0).max())
    low = float(v[:, 1].min())
    landing = v[v[:, 1] <= low + tol]
    fixed = [np.asarray(f.vertices, dtype=float) for f in scene.blocks if f.fixed]
    if not fixed:
        return float("nan"), len(landing)
    top = max(float(f[:, 1].max()) for f in fixed)
    edge = np.concatenate([f[f[:, 1] >= top - tol, 0] for f in fixed])
    under = edge.min() < landing[:, 0].min() and landing[:, 0].max() < edge.max()
    return (low - top if under else float("nan")), len(landing)


def strain_frequency(scene: Scene, block: int) -> float:
    """ω_s of the block's slowest strain mode: √ of the smallest eigenvalue of
    K_s = S C against the strain part of M (S the area, C the elasticity matrix)."""
    b = scene.blocks[block]
    vertices = np.asarray(b.vertices, dtype=float)
    mass = mass_matrix(vertices, scene.materials[b.material].density)[3:, 3:]
    stiffness = shapely.Polygon(vertices).area * elasticity(scene, block)
    return float(np.sqrt(eigh(stiffness, mass, eigvals_only=True).min()))


def free_fall(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """u = (0, −½ g t²) before t_f; events: t_f, v, ω and the contact time."""
    drop = drop_of(scene, block)
    u = np.column_stack([np.zeros(len(times)), -0.5 * drop.gravity * times**2])
    events = {
        "impact": drop.time,
        "impact_speed": drop.speed,
        "omega": drop.omega,
        "contact_time": drop.contact_time,
    }
    scale = drop.mass * drop.gravity * drop.height
    return Motion(u, np.zeros(len(times)), times < drop.time, events, scale)


@dataclass(frozen=True)
class Overlap:
    """The deepest vertex of a block inside a fixed block."""

    depth: float  # d: its distance to that block's boundary (0: no vertex inside)
    vertex: np.ndarray  # (2,) where it is
    normal: np.ndarray  # (2,) unit: the way out, towards the nearest boundary point


def deepest_vertex(scene: Scene, block: int) -> Overlap:
    """The vertex of ``block`` deepest inside a fixed block (:class:`Overlap`)."""
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    points = shapely.points(vertices)
    best = Overlap(0.0, vertices[0], np.zeros(2))
    for other in (b for b in scene.blocks if b.fixed):
        polygon = shapely.Polygon(other.vertices)
        for k in np.flatnonzero(shapely.contains(polygon, points)):
            depth = float(shapely.distance(polygon.exterior, points[k]))
            if depth > best.depth:
                _, out = shapely.shortest_line(points[k], polygon.exterior).coords
                best = Overlap(depth, vertices[k], (np.array(out) - vertices[k]) / depth)
    return best


def displacement_matrix(point: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Shi's T (2 × 6) at ``point``: (u, v) from (u0, v0, r0, εx, εy, γxy) about ``centre``."""
    x, y = np.asarray(point, dtype=float) - centre
    return np.array([[1.0, 0.0, -y, x, 0.0, y / 2.0], [0.0, 1.0, x, 0.0, y, x / 2.0]])


def mass_matrix(vertices: np.ndarray, density: float) -> np.ndarray:
    """M = ρ ∫ Tᵀ T dA (6 × 6) of a polygon about its centroid: TᵀT is quadratic, and
    the midpoints of a triangle's edges integrate a quadratic exactly (a fan of
    triangles from the centroid, with signed areas)."""
    centre = polygon_centroid(vertices)
    total = np.zeros((6, 6))
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0), strict=True):
        (ax, ay), (bx, by) = a - centre, b - centre
        area = 0.5 * float(ax * by - ay * bx)
        for p in ((a + b) / 2.0, (a + centre) / 2.0, (b + centre) / 2.0):
            t = displacement_matrix(p, centre)
            total += area / 3.0 * t.T @ t
    return density * total


def least_push(scene: Scene, block: int, overlap: Overlap) -> np.ndarray:
    """D (6,) that moves the deepest vertex out by d along the normal with the least rigid
    motion and no strain (a push moves the block without setting it moving, so a rigid
    motion costs no energy and a strain its spring-back): D = M⁻¹ gᵀ d / (g M⁻¹ gᵀ) on
    the translation and turn, M their rows of the mass matrix, g = nᵀ T(vertex) there."""
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    density = scene.materials[scene.blocks[block].material].density
    rigid = mass_matrix(vertices, density)[:3, :3]
    g = (overlap.normal @ displacement_matrix(overlap.vertex, polygon_centroid(vertices)))[:3]
    weighted = np.linalg.solve(rigid, g)
    push = np.zeros(6)
    push[:3] = weighted * overlap.depth / float(g @ weighted)
    # the solve's round-off (a symmetric block's turn) is no motion to scale by
    return np.where(np.abs(push) > 1e-12 * np.abs(push).max(), push, 0.0)


def placed(scene: Scene, block: int, times: np.ndarray) -> Motion:
    """At rest at t = 0, pushed out by the least rigid push at the end of the first
    step; energy scale ½ m (d / Δt)² (module notes)."""
    a, b = scene.analysis, scene.blocks[block]
    if any(a.gravity) or scene.loads or any(b.velocity) or a.start != "unloaded":
        raise ExpectationError(
            f"{scene.source}: reference 'overlap': a run that starts unloaded, no gravity, "
            "no loads, the block at rest"
        )
    overlap = deepest_vertex(scene, block)
    tolerance = scene.contact.tolerance
    if tolerance is None or not overlap.depth > tolerance:
        raise ExpectationError(
            f"{scene.source}: reference 'overlap': an overlap ({overlap.depth:g}) deeper than "
            "the [contact] tolerance, written out"
        )
    push = least_push(scene, block, overlap)
    first = np.isclose(times, a.time_step, rtol=1e-9, atol=0.0)
    u = np.where(first[:, None], push[:2], 0.0)
    r = np.where(first, push[2], 0.0)
    scale = 0.5 * block_mass(scene, block) * (overlap.depth / a.time_step) ** 2
    events = {"overlap": overlap.depth, "push": push.tolist()}
    return Motion(u, r, (times <= 0.0) | first, events, scale)


REFERENCES = {"drop": free_fall, "overlap": placed}


def crossing_speed(track: Track, k: int, drop: Drop) -> float:
    """√(|v|² + 2 g (u_y + h)) at frame ``k``: the speed at which the block in free
    flight there crosses the height where it touches the base."""
    vx, vy = track.velocity[k, :2]
    return float(np.sqrt(vx * vx + vy * vy + 2.0 * drop.gravity * (track.u[k, 1] + drop.height)))


def flight_frames(track: Track) -> tuple[int | None, int | None]:
    """(last frame before the first contact, first frame in flight after it); None
    where there is none."""
    closed = np.flatnonzero(track.closed)
    if not len(closed) or closed[0] == 0:
        return None, None
    after = np.flatnonzero(~track.closed[closed[0] :])
    return int(closed[0] - 1), (int(closed[0] + after[0]) if len(after) else None)


def contact_span(track: Track) -> tuple[float, float]:
    """(end of the first step that closed a contact, end of the first step after it
    that ended open); NaN where there is none."""
    closed = np.flatnonzero(track.step_closed)
    if not len(closed):
        return float("nan"), float("nan")
    opened = np.flatnonzero(~track.step_closed[closed[0] :])
    end = track.step_times[closed[0] + opened[0]] if len(opened) else float("nan")
    return float(track.step_times[closed[0]]), float(end)


def drop_rows(
    scene: Scene, expectation: Expectation, tracks: dict[int, Track], series: dict
) -> list[Row]:
    """Rows ``impact_time``, ``contact_time``, ``impact_speed``, ``rebound`` and ``order`` (e)
    of the drop (module notes); adds the rebound to ``series`` (its errors 1 − e,
    its order, ``rebound``: e per time-step factor)."""
    block = free_block(scene)
    name = scene.blocks[block].name
    drop = drop_of(scene, block)
    rows, e = [], {}
    for factor, track in sorted(tracks.items()):
        dt = factor * scene.analysis.time_step
        before, after = flight_frames(track)
        speed = float("nan") if before is None else crossing_speed(track, before, drop)
        e[factor] = float("nan") if after is None else crossing_speed(track, after, drop)
        e[factor] /= drop.speed
        start, end = contact_span(track)
        rows += [
            Row("impact_time", name, f"t@{dt:g}", start, drop.time, dt, offset=dt / 2),
            Row("contact_time", name, f"t@{dt:g}", end - start, drop.contact_time, dt),
            Row("impact_speed", name, f"v@{dt:g}", speed, drop.speed, drop.speed),
            Row("rebound", name, f"e@{dt:g}", e[factor], drop.rebound, 1.0),
        ]
        series["errors"][factor]["e"] = abs(drop.rebound - e[factor])
    factors = sorted(tracks)
    limit = float("nan")
    if len(factors) > 1:
        fine, coarse = factors[0], factors[1]
        ratio = coarse / fine
        limit = e[fine] + (e[fine] - e[coarse]) / (ratio - 1.0)
        order = observed_order(drop.rebound - e[coarse], drop.rebound - e[fine], ratio)
        series["orders"]["e"] = order
        expected = float("nan") if expectation.order is None else expectation.order
        rows.append(Row("order", name, "e", order, expected, 1.0))
    rows.append(Row("rebound", name, "limit", limit, drop.rebound, 1.0))
    series["rebound"] = {"e": e, "limit": limit}
    return rows


# rows beyond verify.references.motion's, per reference
ROWS = {"drop": drop_rows}
