"""Boundary stresses: the traction of a far-field stress on a model's outer edges."""

from __future__ import annotations

import numpy as np
import shapely

from dda.effects.loads import PointLoads
from dda.effects.points import MaterialPoints
from dda.scene.edge_cover import outer_pieces

# a stage's change takes effect from the step after the one ending at its time: this
# fraction of the step's time is the round-off allowed on that time
TIME_TOLERANCE = 1e-9
# a piece's vertex within this fraction of a loaded edge's length of it cuts the edge
# there when the block breaks (the crack's end on the outline)
EDGE_TOLERANCE = 1e-9


class BoundaryStresses(PointLoads):
    """F_i += T_i(x)ᵀ R f at the two ends of every loaded outer edge piece, each set on
    from ``on`` to ``off``: f the forces the traction σ·n gives them where the scene draws
    them (:meth:`dda.scene.in_situ.StressField.segment_forces`), applied at material
    points that move with the block, and R the rigid turn of the loaded boundary as a
    whole since then (:func:`rigid_turn` of the points from ``anchors``, where f was
    given).

    The far field holds a model by its boundary alone; it has no frame but the model's.
    So the forces turn with the boundary's rigid turn, and a model that they balance stays
    balanced when it turns (their sum turns with it, their moment stays zero). Forces of
    fixed directions would make that turn unstable: under compression their moment
    θ Σ f·(x − c) grows a turn θ (a free 3 m × 1 m block under 1-2 MPa, at about 37 /s).
    Against the blocks' own deformation the forces are dead: an edge that bends away
    keeps its force's direction."""

    name = "boundary_stresses"

    def __init__(
        self,
        points: MaterialPoints,
        force: np.ndarray,
        on: np.ndarray,
        off: np.ndarray,
        exact_rotation: bool,
        time_step: float,
    ) -> None:
        super().__init__(points, force, [None] * len(points), exact_rotation)
        self.on, self.off = np.asarray(on, float), np.asarray(off, float)
        self.tolerance = TIME_TOLERANCE * time_step
        self.anchors = self.points.positions.copy()

    def turned_forces(self) -> np.ndarray:
        """R f: the forces turned by the boundary's rigid turn since ``anchors``."""
        cos, sin = rigid_turn(self.anchors, self.points.positions)
        fx, fy = self.force[:, 0], self.force[:, 1]
        return np.column_stack([cos * fx - sin * fy, sin * fx + cos * fy])

    def current_forces(self, time: float) -> np.ndarray:
        return self.turned_forces() * self.factors(time)[:, None]

    def step_forces(self, start: float, end: float) -> np.ndarray:
        """The forces in force at the step's end: they switch on and off at stages, whose
        times the steps end at."""
        return self.current_forces(end)

    def on_blocks_replaced(self, old, new, parent_of: np.ndarray) -> None:
        """Blocks were split or removed (``parent_of[k]``: the old row of new block k): the
        loads of a removed block's edges go with it; an edge piece of a block that broke is
        split where the pieces' outlines cross it, each part loaded by its share of the
        traction (:func:`split_segment_forces`), the rest follow their blocks."""
        self.force = self.turned_forces()  # f as turned now, from the points as they are
        kept = np.isin(self.points.rows, parent_of)
        if not kept.all():
            self._keep(kept)
        children = np.bincount(parent_of, minlength=old.count)
        count = len(self.points) // 2  # edge piece k: points k (its start) and count + k
        old_rows = self.points.rows[:count].copy()
        broken = np.flatnonzero(children[old_rows] > 1)
        super().on_blocks_replaced(old, new, parent_of)
        if len(broken):
            self._split(broken, old_rows, new, parent_of)
        self.anchors = self.points.positions.copy()

    def _keep(self, kept: np.ndarray) -> None:
        """Keep the points ``kept`` (both ends of a piece: they share its block)."""
        self.points = MaterialPoints(self.points.rows[kept], self.points.positions[kept])
        self.force, self.on, self.off = self.force[kept], self.on[kept], self.off[kept]
        self.histories = [h for h, k in zip(self.histories, kept, strict=True) if k]

    def _split(self, broken: np.ndarray, old_rows: np.ndarray, new, parent_of) -> None:
        """Replace the edge pieces ``broken`` (of the blocks ``old_rows`` before the split)
        by their parts, each on the piece of the block it lies on."""
        count = len(old_rows)
        rows, positions = self.points.rows, self.points.positions
        start, end = positions[:count], positions[count:]
        f_start, f_end = self.force[:count], self.force[count:]
        parts = []
        for k in broken:
            children = np.flatnonzero(parent_of == old_rows[k])
            rings = [new.polygon(c) for c in children]
            parts += [
                (k, children[i], a, b) for i, a, b in crossed_intervals(start[k], end[k], rings)
            ]
        keep = np.setdiff1d(np.arange(count), broken)
        k = np.array([p[0] for p in parts], np.int64)
        a, b = (np.array([p[i] for p in parts], float)[:, None] for i in (2, 3))
        fa, fb = split_segment_forces(f_start[k], f_end[k], a, b)
        along = end[k] - start[k]
        segments = (
            np.concatenate([rows[:count][keep], np.array([p[1] for p in parts], np.int64)]),
            np.concatenate([start[keep], start[k] + a * along]),
            np.concatenate([end[keep], start[k] + b * along]),
            np.concatenate([f_start[keep], fa]),
            np.concatenate([f_end[keep], fb]),
            np.concatenate([self.on[:count][keep], self.on[:count][k]]),
            np.concatenate([self.off[:count][keep], self.off[:count][k]]),
        )
        seg_rows, seg_start, seg_end, seg_fa, seg_fb, on, off = segments
        self.points = MaterialPoints(
            np.concatenate([seg_rows, seg_rows]), np.concatenate([seg_start, seg_end])
        )
        self.force = np.concatenate([seg_fa, seg_fb])
        self.on, self.off = np.concatenate([on, on]), np.concatenate([off, off])
        self.histories = [None] * len(self.points)

    def factors(self, time: float) -> np.ndarray:
        """1 for the forces of a set in force over a step ending at ``time`` (those of the
        scene at t = 0 too: the equilibrium start), else 0."""
        begun = (time > self.on + self.tolerance) | (self.on == 0.0)
        return (begun & (time <= self.off + self.tolerance)).astype(float)


def rigid_turn(anchors: np.ndarray, positions: np.ndarray) -> tuple[float, float]:
    """(cos θ, sin θ) of the rigid turn θ that best takes the points ``anchors`` to
    ``positions`` (least squares, each about its mean: tan θ = Σ a × p / Σ a · p);
    (1, 0) for fewer than two points."""
    if len(anchors) < 2:
        return 1.0, 0.0
    a, p = anchors - anchors.mean(axis=0), positions - positions.mean(axis=0)
    dot = float(np.sum(a * p))
    cross = float(np.sum(a[:, 0] * p[:, 1] - a[:, 1] * p[:, 0]))
    size = np.hypot(dot, cross)
    return (dot / size, cross / size) if size > 0.0 else (1.0, 0.0)


def split_segment_forces(
    f_start: np.ndarray, f_end: np.ndarray, a: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The end forces of the part ξ ∈ [a, b] of a segment whose ends carry ``f_start`` and
    ``f_end``, the consistent forces f_s = L (t_s/3 + t_e/6), f_e = L (t_s/6 + t_e/3) of a
    traction linear along it (:meth:`dda.scene.in_situ.StressField.segment_forces`): with
    τ_s = L t_s = 4 f_s − 2 f_e, τ_e = L t_e = 4 f_e − 2 f_s and τ(ξ) linear between, the
    part's are (b − a) (τ(a)/3 + τ(b)/6) and (b − a) (τ(a)/6 + τ(b)/3), so that the parts'
    forces sum to the segment's, and so do their moments about any point."""
    tau_s, tau_e = 4.0 * f_start - 2.0 * f_end, 4.0 * f_end - 2.0 * f_start
    at_a, at_b = tau_s + a * (tau_e - tau_s), tau_s + b * (tau_e - tau_s)
    return (b - a) * (at_a / 3.0 + at_b / 6.0), (b - a) * (at_a / 6.0 + at_b / 3.0)


def crossed_intervals(
    start: np.ndarray, end: np.ndarray, pieces: list[np.ndarray]
) -> list[tuple[int, float, float]]:
    """The parts (i, a, b): [a, b] the fractions of the segment from ``start`` to ``end``
    that lie on ``pieces[i]`` (the polygons of a block that broke, the segment on its outline):
    the segment cut where the pieces' vertices lie on it, each part given to the piece
    nearest its midpoint. Parts of no length are left out."""
    along = end - start
    length2 = float(along @ along)
    if length2 == 0.0:
        return [(0, 0.0, 1.0)]
    tolerance = EDGE_TOLERANCE * np.sqrt(length2)
    cuts = [0.0, 1.0]
    for ring in pieces:
        xi = (ring - start) @ along / length2
        rel = ring - start
        off = np.abs(along[0] * rel[:, 1] - along[1] * rel[:, 0]) / np.sqrt(length2)
        cuts += list(xi[(off <= tolerance) & (xi > 0.0) & (xi < 1.0)])
    cuts = np.unique(np.round(np.sort(cuts), 12))
    polygons = [shapely.Polygon(ring) for ring in pieces]
    out = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        if b - a <= EDGE_TOLERANCE:
            continue
        middle = shapely.Point(start + 0.5 * (a + b) * along)
        nearest = int(np.argmin(shapely.distance(polygons, middle)))
        out.append((nearest, float(a), float(b)))
    return out


def boundary_stress_loads(scene, fixed: np.ndarray, exact_rotation: bool) -> BoundaryStresses:
    """The effect of ``scene.boundary_stresses``: for each, the outer edge pieces of the
    blocks there at its time (:func:`dda.scene.edge_cover.outer_pieces`) that it loads
    (:meth:`dda.scene.in_situ.BoundaryStress.loads`), by σ·n at their ends. The points
    are every piece's start, then every piece's end, in the same order (piece k: points k
    and count + k)."""
    polygons = [np.asarray(b.vertices, float) for b in scene.blocks]
    blocks, starts, ends, f_starts, f_ends, on, off = [], [], [], [], [], [], []
    for stress in scene.boundary_stresses:
        gone = {n for s in scene.stages if s.time <= stress.on for n in s.remove}
        present = np.array([b.name not in gone for b in scene.blocks], bool)
        pieces = outer_pieces(polygons, present)
        pieces = pieces.subset(np.flatnonzero(stress.loads(pieces, polygons, present, fixed)))
        f_start, f_end = stress.field.segment_forces(pieces.start, pieces.end, pieces.normal)
        blocks.append(pieces.block)
        starts.append(pieces.start)
        ends.append(pieces.end)
        f_starts.append(f_start)
        f_ends.append(f_end)
        on.append(np.full(len(pieces.block), stress.on))
        off.append(np.full(len(pieces.block), stress.off))
    rows, on, off = (np.tile(np.concatenate(v), 2) for v in (blocks, on, off))
    return BoundaryStresses(
        MaterialPoints(rows, np.concatenate(starts + ends).reshape(-1, 2)),
        np.concatenate(f_starts + f_ends).reshape(-1, 2), on, off, exact_rotation,
        scene.analysis.time_step,
    )  # fmt: skip
