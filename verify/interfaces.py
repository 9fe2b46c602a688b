"""Interfaces: the pairs of blocks that touch, the joint between them and their contacts.

An interface is the part of two block boundaries that coincide (within a
tolerance). Its contact behaviour for the FEM model is either *locked*
(normal and shear springs: a DDA contact in the LOCKED state) or
*frictionless* (normal springs only: a DDA contact that slides with no
friction). Without a DDA result the state is guessed from the joint:
a joint with friction or cohesion is assumed to stick.

The DDA puts one spring at each contact vertex, so the stiffness of an
interface is ``n_contacts * penalty``. :attr:`Interface.contacts` counts the
vertices of either block that lie on the interface (coincident vertices once),
which is what the DDA's vertex-edge detection finds for touching blocks;
:func:`with_dda_contacts` replaces it by the count the DDA really reports.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import shapely

from dda.scene import Joint, Scene
from verify.geometry import block_polygons, geometric_tolerance


@dataclass(frozen=True)
class Interface:
    """Two touching blocks (scene indices ``a < b``) and how they interact."""

    a: int
    b: int
    line: shapely.Geometry  # the shared boundary (LineString or MultiLineString)
    length: float
    locked: bool  # shear springs as well as normal springs
    contacts: int  # DDA contact points on this interface

    @property
    def pair(self) -> tuple[int, int]:
        """(a, b), the key of the DDA's contact groups."""
        return (self.a, self.b)


def joint_between(scene: Scene, a: str, b: str) -> Joint:
    """Joint that applies between blocks ``a`` and ``b``.

    An ``[[interfaces]]`` entry for the pair wins, then ``[joints.default]``,
    then a joint with no friction, cohesion or tensile strength.
    """
    for interface in scene.interfaces:
        if set(interface.blocks) == {a, b}:
            return scene.joints[interface.joint]
    return scene.joints.get("default", Joint(name="default"))


def sticks(joint: Joint) -> bool:
    """Whether a joint is expected to hold (any friction or cohesion)."""
    return joint.friction_angle > 0.0 or joint.cohesion > 0.0


def count_contact_vertices(polygons: list[np.ndarray], line: shapely.Geometry, tol: float) -> int:
    """Vertices of the given polygons that lie on ``line``, coincident ones counted once."""
    points = np.concatenate(polygons)
    on_line = shapely.distance(shapely.points(points), line) <= tol
    unique: list[np.ndarray] = []
    for p in points[on_line]:
        if all(np.linalg.norm(p - q) > tol for q in unique):
            unique.append(p)
    return len(unique)


def shared_segments(a: np.ndarray, b: np.ndarray, tol: float) -> list[np.ndarray]:
    """Overlaps of the edges of two counter-clockwise polygons that touch face to face.

    Edge pairs qualify when both ends of the edge of ``b`` lie within ``tol``
    of the line of the edge of ``a`` and the edges run in opposite directions
    (as two touching counter-clockwise polygons do); the overlap of their
    projections on the edge of ``a`` is kept when it is longer than ``tol``.
    """
    out = []
    b_next = np.roll(b, -1, axis=0)
    for p, q in zip(a, np.roll(a, -1, axis=0), strict=True):
        length = np.linalg.norm(q - p)
        t = (q - p) / length
        n = np.array([-t[1], t[0]])
        off = np.abs(np.column_stack([(b - p) @ n, (b_next - p) @ n])).max(axis=1)
        opposite = (b_next - b) @ t < 0
        for k in np.flatnonzero((off <= tol) & opposite):
            s0, s1 = sorted(((b[k] - p) @ t, (b_next[k] - p) @ t))
            lo, hi = max(s0, 0.0), min(s1, length)
            if hi - lo > tol:
                out.append(np.array([p + lo * t, p + hi * t]))
    return out


def find_interfaces(scene: Scene, tol: float | None = None) -> list[Interface]:
    """Every pair of blocks whose boundaries share a segment longer than ``100 tol``."""
    tol = 10 * geometric_tolerance(scene) if tol is None else tol
    raw = block_polygons(scene)
    polygons = [shapely.Polygon(p) for p in raw]
    tree = shapely.STRtree(polygons)
    pairs = tree.query(polygons, predicate="dwithin", distance=tol)
    found = []
    for a, b in zip(*pairs, strict=True):
        if a >= b or (scene.blocks[a].fixed and scene.blocks[b].fixed):
            continue
        segments = shared_segments(raw[a], raw[b], tol)
        if not segments:
            continue
        line = shapely.line_merge(shapely.MultiLineString(segments))
        if line.length <= 100 * tol:
            continue
        joint = joint_between(scene, scene.blocks[a].name, scene.blocks[b].name)
        found.append(
            Interface(
                a=int(a),
                b=int(b),
                line=line,
                length=float(line.length),
                locked=sticks(joint),
                contacts=count_contact_vertices([raw[a], raw[b]], line, tol),
            )
        )
    return found


def with_dda_contacts(
    interfaces: list[Interface], closed: dict[tuple[int, int], tuple[int, bool]]
) -> list[Interface]:
    """Keep the interfaces the DDA closed, with its contact count and state.

    Parameters
    ----------
    interfaces : geometric interfaces (:func:`find_interfaces`)
    closed : ``(a, b) -> (number of closed contacts, any locked)`` from the DDA's
        final frame, with scene block indices ``a < b``
    """
    kept = []
    for interface in interfaces:
        if interface.pair in closed:
            count, locked = closed[interface.pair]
            kept.append(replace(interface, contacts=count, locked=locked))
    return kept
