"""Scene sections for the stress a rock mass stands in: ``[in_situ]`` and ``[[boundary_stresses]]``.

Both give a stress field σ(y) = ``stress`` + ``gradient`` · y (components sxx, syy, sxy,
tension positive, the blocks' own convention; y in the scene's frame), the field of
UDEC's ``insitu`` and ``bound stress``:

* ``[in_situ]`` is the stress of every block at t = 0 (at its centroid, added to the
  block's own ``stress``), which the contacts that touch at t = 0 carry
  (:mod:`dda.run.in_situ`);
* each ``[[boundary_stresses]]`` entry loads the outer edges (touching no other block,
  :mod:`dda.scene.edge_cover`) whose midpoints lie in its ``box`` with the traction σ·n,
  from t = 0 or, given in a ``[[stages]]`` entry, from that stage on; a stage's
  ``remove_boundary_stresses`` lists the names of those it takes away.

The checks at load time: finite values, three of each; a box that selects no outer
edge is refused; so is in-situ tension across a joint weaker in tension (the joint
would open at t = 0), named with its blocks and where.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from dda.scene.checks import Checker, Spec, checked_fields, require, vector
from dda.scene.edge_cover import EdgePieces, covered_pieces, on_openings, outer_pieces

log = logging.getLogger(__name__)

IN_SITU_KEYS = ("in_situ", "boundary_stresses")
# tension across a joint up to this fraction of the field's largest component is round-off
TENSION_TOLERANCE = 1e-9


@dataclass(frozen=True)
class StressField:
    """σ(y) = ``stress`` + ``gradient`` · y: (sxx, syy, sxy), tension positive."""

    stress: tuple[float, float, float]
    gradient: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def at(self, y: np.ndarray) -> np.ndarray:
        """(m, 3) the stress at heights ``y``."""
        y = np.asarray(y, float).reshape(-1)
        return np.asarray(self.stress) + np.outer(y, self.gradient)

    def traction(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(m, 2) σ·n at ``points`` on surfaces of unit (outward) normals ``normals``."""
        s = self.at(np.asarray(points, float)[:, 1])
        nx, ny = normals[:, 0], normals[:, 1]
        return np.column_stack([s[:, 0] * nx + s[:, 2] * ny, s[:, 2] * nx + s[:, 1] * ny])

    def normal_stress(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """n·σ·n (tension positive) at ``points`` for unit normals ``normals``."""
        return np.einsum("ij,ij->i", self.traction(points, normals), normals)

    def segment_forces(
        self, start: np.ndarray, end: np.ndarray, normals: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The two point forces at the ends a, b of each segment that do the work of the
        traction t = σ·n (linear along it) against any linear displacement, as Shi's
        first-order fields are: f_a = L (t_a/3 + t_b/6), f_b = L (t_a/6 + t_b/3)."""
        t_a, t_b = self.traction(start, normals), self.traction(end, normals)
        length = np.linalg.norm(np.asarray(end) - np.asarray(start), axis=1)[:, None]
        return length * (t_a / 3.0 + t_b / 6.0), length * (t_a / 6.0 + t_b / 3.0)

    def shifted(self, dy: float) -> StressField:
        """The same field in a frame whose y is this one's less ``dy``."""
        moved = tuple(s + g * dy for s, g in zip(self.stress, self.gradient, strict=True))
        return replace(self, stress=moved)

    @property
    def scale(self) -> float:
        return max(max(abs(s) for s in self.stress), 1e-300)


@dataclass(frozen=True)
class BoundaryStress:
    """``[[boundary_stresses]]``: the traction σ·n on the outer edges whose midpoints lie
    in ``box`` = (xmin, ymin, xmax, ymax), from time ``on`` (0, or its stage's time) to
    ``off`` (the time of the stage that removes it, else never)."""

    name: str
    field: StressField
    box: tuple[float, float, float, float]
    on: float = 0.0
    off: float = math.inf
    # the walls of the openings in the mass (holes in the blocks' union) are loaded too: a
    # support pressure; by default a far field loads the model's outline only
    openings: bool = False

    def selects(self, points: np.ndarray) -> np.ndarray:
        x0, y0, x1, y1 = self.box
        x, y = points[:, 0], points[:, 1]
        return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)

    def loads(self, pieces: EdgePieces, polygons, present, fixed) -> np.ndarray:
        """Which outer edge ``pieces`` of the ``present`` blocks it loads: those of free
        blocks whose midpoints lie in its box, an opening's walls only with
        ``openings`` (an audit: a box over a section with an excavation drawn in it
        pressed the far field onto the opening's walls, which then held it, unsaid)."""
        midpoint = pieces.midpoint
        chosen = self.selects(midpoint) & ~np.asarray(fixed, bool)[pieces.block]
        if not self.openings and chosen.any():
            chosen &= ~on_openings(polygons, present, midpoint)
        return chosen

    def shifted(self, dx: float, dy: float) -> BoundaryStress:
        x0, y0, x1, y1 = self.box
        box = (x0 - dx, y0 - dy, x1 - dx, y1 - dy)
        return replace(self, field=self.field.shifted(dy), box=box)


def _stress_field(chk: Checker, value: object, key: str, extra: Mapping[str, Spec]) -> dict:
    specs: dict[str, Spec] = {"stress": vector(3), "gradient": vector(3), **extra}
    values = checked_fields(chk, value, key, specs)
    require(chk, values, key, ("stress",))
    values["field"] = StressField(values.pop("stress"), values.pop("gradient", (0.0, 0.0, 0.0)))
    return values


def _box(chk: Checker, value: object, key: str) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = chk.vector(value, key, 4)
    if not (x1 > x0 and y1 > y0):
        chk.fail(key, "expected [xmin, ymin, xmax, ymax] with xmax > xmin and ymax > ymin")
    return (x0, y0, x1, y1)


def _name(chk: Checker, value: object, key: str) -> str:
    """A boundary stress's name: text that is not blank (a stage takes it away by it)."""
    name = chk.text(value, key)
    if not name.strip():
        chk.fail(key, "is blank: name it, or leave the key out (its key names it then)")
    return name


def boundary_stress(chk: Checker, value: object, key: str, on: float = 0.0) -> BoundaryStress:
    """One ``[[boundary_stresses]]`` table (in the scene or in a stage starting at ``on``)."""
    specs = {"box": _box, "name": _name, "openings": Checker.boolean}
    values = _stress_field(chk, value, key, specs)
    require(chk, values, key, ("box",))
    return BoundaryStress(values.get("name", key), values["field"], values["box"], on,
                          openings=values.get("openings", False))  # fmt: skip


def parse_in_situ(chk: Checker, raw: Mapping[str, Any], blocks: Sequence[Any],
                  stages: Sequence[Any], joints: Mapping[str, Any], interfaces: Sequence[Any],
                  young: Mapping[str, float]) -> dict[str, Any]:  # fmt: skip
    """The Scene fields ``in_situ`` and ``boundary_stresses`` (every one, those of the
    stages included, with the times they are on), checked against the blocks (``young``:
    each material's Young's modulus, which no stress of the field may reach)."""
    in_situ = None
    if "in_situ" in raw:
        in_situ = _stress_field(chk, raw["in_situ"], "in_situ", {})["field"]
    listed = (
        chk.listed(raw["boundary_stresses"], "boundary_stresses")
        if "boundary_stresses" in raw
        else ()
    )
    given = [
        boundary_stress(chk, value, f"boundary_stresses[{k}]") for k, value in enumerate(listed)
    ]
    timeline = _timeline(chk, given, stages)
    if not (in_situ or timeline):
        return {"in_situ": None, "boundary_stresses": ()}
    polygons = [np.asarray(b.vertices, float) for b in blocks]
    fixed = np.array([bool(b.fixed) for b in blocks])
    moduli = np.array([young[b.material] for b in blocks])
    for stress, key in timeline:
        present = _present_at(blocks, stages, stress.on)
        _check_selects(chk, stress, key, polygons, present, fixed)
        _check_magnitude(chk, stress.field, key, blocks, polygons, moduli)
    found = _Joints.of(blocks, polygons, joints, interfaces)
    _say_pulling(timeline, found, blocks)
    if in_situ is not None:
        _check_magnitude(chk, in_situ, "in_situ", blocks, polygons, moduli)
        _check_tension(chk, in_situ, found, blocks)
        _say_unheld(chk, in_situ, [s for s, _ in timeline], blocks, polygons, fixed)
    return {"in_situ": in_situ, "boundary_stresses": tuple(s for s, _ in timeline)}


# an outer edge whose field traction is above this fraction of the field's largest stress
# pushes on the mass: unheld, it is said as the scene loads
UNHELD_TRACTION = 1e-3


def _say_unheld(chk, field: StressField, stresses, blocks, polygons, fixed) -> None:
    """Say, as the scene loads, where the field pushes on the outer edges of free blocks
    that no boundary stress loads at t = 0 (the walls of drawn openings aside): nothing
    holds it there, and the equilibrium start relaxes it, or cannot settle and the run
    starts unloaded (an audit: a 55-block section in an 11.5 MPa field without boundary
    stresses, 1,505 Newton iterations, the start given up and the field set loose as
    motion, 1.8 m/s, the warning blaming friction)."""
    outer = outer_pieces(polygons)
    free = ~np.asarray(fixed, bool)[outer.block]
    held = np.zeros(len(free), bool)
    for stress in stresses:
        if stress.on == 0.0:
            held |= stress.loads(outer, polygons, None, fixed)
    traction = np.linalg.norm(field.traction(outer.midpoint, outer.normal), axis=1)
    largest = float(np.abs(field.at(np.concatenate(polygons)[:, 1])).max())
    pushed = free & ~held & (traction > UNHELD_TRACTION * largest)
    if pushed.any():
        pushed &= ~on_openings(polygons, None, outer.midpoint)
    if not pushed.any():
        return
    k = int(np.flatnonzero(pushed)[np.argmax(traction[pushed])])
    x, y = outer.midpoint[k]
    log.warning(
        "%s: in_situ: the field pushes on %d outer edge piece(s) of free blocks that no "
        "[[boundary_stresses]] loads (the most, %.3g Pa, on block %r at (%.6g, %.6g)): "
        "nothing holds it there, so the equilibrium start relaxes it, or cannot settle and "
        "the run starts unloaded, setting it loose as motion; give those edges "
        "[[boundary_stresses]] with the field, or fix the blocks beside them",
        chk.source, int(pushed.sum()), traction[k], blocks[outer.block[k]].name, x, y,
    )  # fmt: skip


def _timeline(chk: Checker, given: list[BoundaryStress], stages: Sequence[Any]):
    """(boundary stress, its key) of the scene's and the stages' entries, each with the
    time a stage removes it."""
    entries = [(s, f"boundary_stresses[{k}]") for k, s in enumerate(given)]
    where = {}
    for k, (stress, key) in enumerate(entries):
        _unique(chk, stress.name, key, where)
        where[stress.name] = k
    for i, stage in enumerate(stages):
        removed = set()
        for name in stage.remove_boundary_stresses:
            key = f"stages[{i}].remove_boundary_stresses"
            if name in removed:
                chk.fail(key, f"lists {name!r} twice")
            removed.add(name)
            if name not in where or entries[where[name]][0].off != math.inf:
                chk.fail(key, f"{name!r} is no boundary stress in force before this stage")
            stress, old_key = entries[where[name]]
            entries[where[name]] = (replace(stress, off=stage.time), old_key)
        for k, stress in enumerate(stage.boundary_stresses):
            key = f"stages[{i}].boundary_stresses[{k}]"
            _unique(chk, stress.name, key, where)
            where[stress.name] = len(entries)
            entries.append((stress, key))
    return entries


def _unique(chk: Checker, name: str, key: str, where: Mapping[str, int]) -> None:
    if name in where:
        chk.fail(f"{key}.name", f"{name!r} names another boundary stress already")


def _present_at(blocks: Sequence[Any], stages: Sequence[Any], time: float) -> np.ndarray:
    """Which blocks are there at ``time`` (a stage at that time has removed its blocks)."""
    gone = {name for s in stages if s.time <= time for name in s.remove}
    return np.array([b.name not in gone for b in blocks], bool)


def _check_selects(chk, stress: BoundaryStress, key: str, polygons, present, fixed) -> None:
    """Refuse a box that loads nothing: no outer edge of a free block there at that time
    (a fixed block takes no boundary stress)."""
    outer = outer_pieces(polygons, present)
    if not np.any(stress.loads(outer, polygons, present, fixed)):
        chk.fail(f"{key}.box", "holds the midpoint of no outer edge (an edge that touches "
                 "no other block) of the free blocks there at that time (a fixed block "
                 "takes no boundary stress; the walls of an opening only with openings = "
                 "true)")  # fmt: skip


def _check_magnitude(chk, field: StressField, key: str, blocks, polygons, moduli) -> None:
    """Refuse a field that reaches a block's Young's modulus at one of its corners (the
    field is linear in y: its extremes on a block are at corners): a strain of 1 or more,
    no stress rock stands in (and beyond the floating-point range, numbers overflow)."""
    for k, ring in enumerate(polygons):
        with np.errstate(over="ignore", invalid="ignore"):
            signed = field.at(ring[:, 1])
            values = np.abs(signed)
        if not values.max() >= moduli[k]:
            continue
        corner = int(np.argmax(values.max(axis=1)))
        x, y = ring[corner]
        largest = signed[corner, int(np.argmax(values[corner]))]  # with its sign
        bad = "gradient" if np.abs(field.stress).max() < moduli[k] else "stress"
        chk.fail(f"{key}.{bad}", f"gives {largest:.3g} at ({x:.6g}, {y:.6g}), a "
                 f"corner of block {blocks[k].name!r}: as large as the Young's modulus "
                 f"{moduli[k]:.3g} of its material {blocks[k].material!r} (a strain of 1 or "
                 "more), no stress rock stands in")  # fmt: skip


@dataclass(frozen=True)
class _Joints:
    """The covered edge pieces between blocks (:func:`covered_pieces`), each with its
    joint's name and tensile strength: found once for every field checked against them."""

    pieces: EdgePieces
    names: list[str]
    tensile: np.ndarray

    @classmethod
    def of(cls, blocks, polygons, joints, interfaces) -> _Joints:
        pieces = covered_pieces(polygons)
        names = _piece_joints(pieces, blocks, joints, interfaces)
        return cls(pieces, names, np.array([joints[n].tensile_strength for n in names]))


def _worst_tension(field: StressField, found: _Joints, blocks):
    """(where, σn, the joint, its tensile strength, the piece's normal, its y) of the
    largest tension over strength the field puts across a joint between blocks
    (``where``: the two blocks' names and the point), or None where every joint holds
    it."""
    pieces, tensile = found.pieces, found.tensile
    sigma = field.normal_stress(pieces.midpoint, pieces.normal)
    scale = float(np.abs(field.at(pieces.midpoint[:, 1])).max(initial=0.0))
    over = sigma - tensile > TENSION_TOLERANCE * scale
    if not np.any(over):
        return None
    k = int(np.argmax(np.where(over, sigma - tensile, -np.inf)))
    x, y = pieces.midpoint[k]
    a, b = blocks[pieces.block[k]].name, blocks[pieces.other[k]].name
    where = f"between blocks {a!r} and {b!r} at ({x:.6g}, {y:.6g})"
    return where, float(sigma[k]), found.names[k], float(tensile[k]), pieces.normal[k], float(y)


def _check_tension(chk, field: StressField, found: _Joints, blocks) -> None:
    """Refuse in-situ tension across a joint whose tensile strength is below it, naming
    the part of the field that puts it there (:func:`_tension_key`)."""
    worst = _worst_tension(field, found, blocks)
    if worst is None:
        return
    where, sigma, joint, tensile, normal, y = worst
    key, hint = _tension_key(field, normal, y, sigma)
    chk.fail(key, f"puts a tension of {sigma:.6g} across joint {joint!r} (tensile_strength "
             f"{tensile:g}) {where}: the joint would open at t = 0{hint}")  # fmt: skip


def _say_pulling(timeline, found: _Joints, blocks) -> None:
    """Warn of a boundary stress whose field, as the mass's state, would put tension
    across a joint beyond its strength: it pulls the blocks it loads apart (an audit: 1 MPa
    of tension across joints of T = 0 sent two columns off at 7.7 m/s, unsaid, where the
    same field as [in_situ] is refused)."""
    for stress, key in timeline:
        worst = _worst_tension(stress.field, found, blocks)
        if worst is not None:
            where, sigma, joint, tensile, _, _ = worst
            log.warning("%s: its field would put a tension of %.6g across joint %r "
                        "(tensile_strength %g) %s: it pulls the blocks it loads apart",
                        key, sigma, joint, tensile, where)  # fmt: skip


def _tension_key(field: StressField, normal: np.ndarray, y: float, sigma: float):
    """(key, hint): ``in_situ.gradient`` where the gradient's part of n·σ·n at height y
    is the larger tension (with the sign convention that explains it), else
    ``in_situ.stress``."""
    constant = StressField(field.stress).normal_stress(np.zeros((1, 2)), normal[None, :])[0]
    if sigma - constant <= constant:
        return "in_situ.stress", ""
    return "in_situ.gradient", (
        " (the stress at height y is stress + gradient · y, tension positive: below y = 0 "
        "a compressive field that grows with depth has a positive gradient)"
    )


def _piece_joints(pieces: EdgePieces, blocks, joints, interfaces) -> list[str]:
    """The joint of each covered piece: an interface of its two blocks, else its edge's
    joint, else ``default``."""
    pairs = {frozenset(i.blocks): i.joint for i in interfaces}
    names = []
    for block, vertex, other in zip(pieces.block, pieces.vertex, pieces.other, strict=True):
        b = blocks[block]
        own = b.edge_joints[vertex] if b.edge_joints else None
        pair = pairs.get(frozenset((b.name, blocks[other].name)))
        names.append(pair or own or "default")
    return names


def in_situ_stress(field: StressField | None, centroids: np.ndarray) -> np.ndarray:
    """(n, 3) the in-situ stress at the blocks' ``centroids`` (zeros without a field)."""
    if field is None:
        return np.zeros((len(centroids), 3))
    return field.at(np.asarray(centroids, float)[:, 1])
