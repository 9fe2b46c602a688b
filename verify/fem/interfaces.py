"""Interfaces: the pairs of blocks that touch, the joint between them and their contacts.

An interface is the part of two block boundaries that coincide (within a
tolerance) in the scene. Everything the FEM needs to know about it comes
from the scene: the shared line, its length, the joint that applies (an
``[[interfaces]]`` entry, else the joint of the edges it lies on, else the
default joint) and the number of DDA contact points on it.

The DDA puts one spring at each contact vertex, so the stiffness of an
interface is ``n_contacts * penalty``. :attr:`Interface.contacts` counts the
vertices of either block that lie on the interface (coincident vertices
once), which is what the engine's vertex-edge detection finds for blocks
that touch face to face (docs/verification.md). Whether the interface is
open, sticking or slipping is not known here: the FEM's contact law finds
that itself (:mod:`verify.fem.contact_law`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from dda.scene import Joint, Scene
from verify.fem.geometry import block_polygons, geometric_tolerance


@dataclass(frozen=True)
class Interface:
    """Two touching blocks (scene indices ``a < b``) and the joint between them."""

    a: int
    b: int
    line: shapely.Geometry  # the shared boundary (LineString or MultiLineString)
    length: float
    joint: Joint
    contacts: int  # DDA contact points on this interface

    @property
    def pair(self) -> tuple[int, int]:
        """(a, b), the key of the DDA's contact groups."""
        return (self.a, self.b)


def default_joint(scene: Scene) -> Joint:
    """``[joints.default]``, or the frictionless joint the engine adds without one."""
    return scene.joints.get("default", Joint(name="default"))


def interface_joint(scene: Scene, a: int, b: int, line: shapely.Geometry, tol: float) -> Joint:
    """Joint that applies between blocks ``a`` and ``b`` along ``line``.

    An ``[[interfaces]]`` entry for the pair wins; then the ``edge_joints``
    of an edge of either block that carries the line; then the default
    joint (docs/scene.md).
    """
    names = {scene.blocks[a].name, scene.blocks[b].name}
    for interface in scene.interfaces:
        if set(interface.blocks) == names:
            return scene.joints[interface.joint]
    for k in (b, a):
        joint = _edge_joint(scene, k, line, tol)
        if joint is not None:
            return joint
    return default_joint(scene)


def _edge_joint(scene: Scene, block: int, line: shapely.Geometry, tol: float) -> Joint | None:
    """Joint named by the edge of ``block`` that carries ``line`` (None without one)."""
    edge_joints = scene.blocks[block].edge_joints
    if not edge_joints:
        return None
    vertices = np.asarray(scene.blocks[block].vertices, dtype=float)
    ends = np.roll(vertices, -1, axis=0)
    midpoint = shapely.line_interpolate_point(line, 0.5, normalized=True)
    for k, name in enumerate(edge_joints):
        edge = shapely.LineString([vertices[k], ends[k]])
        if name and shapely.distance(edge, midpoint) <= tol:
            return scene.joints[name]
    return None


def count_contact_vertices(polygons: list[np.ndarray], line: shapely.Geometry, tol: float) -> int:
    """Vertices of the given polygons that lie on ``line``, coincident ones counted once."""
    points = np.concatenate(polygons)
    on_line = points[shapely.distance(shapely.points(points), line) <= tol]
    if not len(on_line):
        return 0
    distance = np.linalg.norm(on_line[:, None] - on_line[None], axis=2)
    first = np.argmax(distance <= tol, axis=1)  # the first point each one coincides with
    return int(np.count_nonzero(first == np.arange(len(on_line))))


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
        found.append(
            Interface(
                a=int(a),
                b=int(b),
                line=line,
                length=float(line.length),
                joint=interface_joint(scene, int(a), int(b), line, tol),
                contacts=count_contact_vertices([raw[a], raw[b]], line, tol),
            )
        )
    return found
