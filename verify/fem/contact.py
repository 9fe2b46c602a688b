"""Node-to-segment penalty contact between meshed blocks (small displacements).

For every interface one block is the *slave*: its boundary nodes on the
interface (P2: vertices and mid-side nodes) are each tied to the closest
point of the other block's boundary facets, the *master* segments. A fixed
block is always the master and is rigid (its segments do not move), as in
the DDA, which removes fixed blocks from the unknowns. Between two free
blocks the side with more nodes on the interface is the slave.

Linearised gap and slip of slave point s against master point m(ξ) on the
facet with unit outward normal n and tangent t = (-n_y, n_x)::

    g = g0 + n · (u_s − Σ_k φ_k(ξ) u_k)        (g < 0: penetration)
    s =      t · (u_s − Σ_k φ_k(ξ) u_k)

with φ_k the facet's 1-D Lagrange functions (P1: 1−ξ, ξ; P2: (1−ξ)(1−2ξ),
ξ(2ξ−1), 4ξ(1−ξ)). The rows form sparse operators ``G_n``, ``G_t`` so that
the springs add ``G_nᵀ diag(k_n) G_n + G_tᵀ diag(k_t) G_t`` to the stiffness
and ``−G_nᵀ diag(k_n) g0`` to the load. Which springs act (open or
closed, sticking or slipping) is decided by :mod:`verify.fem.contact_law`.

Matching the DDA's stiffness. A DDA contact is one spring of stiffness p
(force per length, per unit thickness) at a block vertex; an interface
with ``n_c`` contacts is ``n_c p`` stiff in the normal direction. The FEM
spreads that over the interface length L as a penalty per unit length
``κ = n_c p / L``, lumped on the slave points with the weights ``w`` of the
integral of their shape functions along the slave facets (P1: h/2, h/2;
P2: Simpson's h/6, 2h/3, h/6), so that ``Σ w κ = n_c p``. A uniform
pressure q then penetrates ``q L / (n_c p)`` in both models: the same
penetration as the DDA's ``N / p`` per contact with ``N = q L / n_c``. The shear
springs use ``shear_ratio κ``, as the DDA uses ``shear_ratio p``; the joint's
cohesion c and tensile strength T become forces ``c w`` and ``T w`` per point
(the DDA: ``c l`` and ``T l`` per contact, with l half the contact vertex's edge;
both sum to c L and T L over an interface). The rotational stiffness of the
interface differs (DDA springs sit at the ends), which only matters when the
contact pressure is not uniform.

p is the scene's ``[contact] penalty`` or its documented default, and ``n_c``
the number of block vertices on the interface: nothing is read from a DDA run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import shapely
from skfem import CellBasis

from dda.scene import Scene
from verify.fem.geometry import point_segment_distance, scene_size
from verify.fem.interfaces import Interface
from verify.fem.mesh import BlockMesh


@dataclass(frozen=True)
class ContactPoints:
    """All slave points of all interfaces (struct of arrays, one row per point)."""

    interface: np.ndarray  # (m,) row in the interface list
    slave: np.ndarray  # (m,) scene index of the block the point belongs to
    points: np.ndarray  # (m, 2) slave point position
    weight: np.ndarray  # (m,) tributary length
    normal: np.ndarray  # (m, 2) master outward normal (from the master towards the slave)
    gap0: np.ndarray  # (m,) initial gap
    k_normal: np.ndarray  # (m,) normal spring of the point (κ w)
    k_shear: np.ndarray  # (m,) shear spring of the point (shear_ratio κ w)
    friction: np.ndarray  # (m,) tan φ of the joint
    cohesion: np.ndarray  # (m,) cohesion force c w of the point
    tensile: np.ndarray  # (m,) tensile force T w of the point
    g_normal: sp.csr_matrix  # (m, N) gap operator
    g_shear: sp.csr_matrix  # (m, N) slip operator

    def __len__(self) -> int:
        return len(self.interface)

    def gaps(self, u: np.ndarray) -> np.ndarray:
        """Normal gap of every point (negative: penetration)."""
        return self.gap0 + self.g_normal @ u

    def slips(self, u: np.ndarray) -> np.ndarray:
        """Tangential displacement of every point relative to its master point."""
        return self.g_shear @ u

    def stiffness(self, closed: np.ndarray, stick: np.ndarray) -> sp.csr_matrix:
        """Springs of the closed points (normal) and of the sticking ones (shear)."""
        kn = sp.diags(self.k_normal * closed)
        kt = sp.diags(self.k_shear * stick)
        return (self.g_normal.T @ kn @ self.g_normal + self.g_shear.T @ kt @ self.g_shear).tocsr()

    def load(self, normal_force0: np.ndarray, shear_force0: np.ndarray) -> np.ndarray:
        """Load vector of point forces that do not depend on u (normal, shear).

        A point force f along the normal (tangent) does the work f g (f s):
        its load is −G_nᵀ f (−G_tᵀ f).
        """
        return -(self.g_normal.T @ normal_force0) - self.g_shear.T @ shear_force0


def penalty_of(scene: Scene) -> float:
    """The normal contact penalty as the scene defines it.

    ``[contact] penalty``, else the documented default: 10 x the largest
    Young's modulus (docs/scene.md).
    """
    if scene.contact.penalty is not None:
        return float(scene.contact.penalty)
    return 10.0 * max(m.young for m in scene.materials.values())


def facet_points(bm: BlockMesh, basis: CellBasis, facets: np.ndarray) -> dict:
    """Slave points of the given facets: (x, y) DOFs, position, tributary length.

    Ends of a facet of length h get h/2 (P1) or h/6 (P2) each, a P2 mid-side
    node 2h/3: the integrals of the facet's shape functions.
    """
    mesh = bm.mesh
    ends = mesh.facets[:, facets]
    h = np.linalg.norm(mesh.p[:, ends[1]] - mesh.p[:, ends[0]], axis=0)
    quadratic = basis.facet_dofs.shape[0] > 0
    end_weight = h / 6 if quadratic else h / 2
    dofs = [basis.nodal_dofs[:, ends[0]], basis.nodal_dofs[:, ends[1]]]
    weights = [end_weight, end_weight]
    if quadratic:
        dofs.append(basis.facet_dofs[:, facets])
        weights.append(2 * h / 3)
    dof = np.hstack(dofs)  # (2, k): x and y DOF of every point
    unique, first, inverse = np.unique(dof[0], return_index=True, return_inverse=True)
    return {
        "dofs": dof[:, first].T,
        "xy": basis.doflocs[:, unique].T,
        "weight": np.bincount(inverse, weights=np.concatenate(weights)),
    }


def facets_on_line(bm: BlockMesh, block: int, line: shapely.Geometry, tol: float) -> np.ndarray:
    """Boundary facets of ``block`` whose both ends lie on ``line``."""
    facets = bm.boundary_facets(block)
    ends = bm.mesh.facets[:, facets]
    near = [shapely.distance(shapely.points(bm.mesh.p[:, e].T), line) <= tol for e in ends]
    return facets[near[0] & near[1]]


def master_segments(bm: BlockMesh, basis: CellBasis, block: int, facets: np.ndarray) -> dict:
    """Master facets of a meshed block: ends, outward normals, facet DOFs (x, y)."""
    mesh = bm.mesh
    n0, n1 = mesh.facets[:, facets]
    a, b = mesh.p[:, n0].T, mesh.p[:, n1].T
    element = mesh.f2t[0, facets]
    inside = mesh.p[:, mesh.t[:, element]].mean(axis=1).T
    normal = _unit(np.column_stack([(b - a)[:, 1], -(b - a)[:, 0]]))
    flip = np.einsum("fi,fi->f", normal, inside - a) > 0
    normal[flip] *= -1
    columns = [basis.nodal_dofs[:, n0], basis.nodal_dofs[:, n1]]
    if basis.facet_dofs.shape[0] > 0:
        columns.append(basis.facet_dofs[:, facets])
    return {"a": a, "b": b, "normal": normal, "dofs": np.stack(columns, axis=1)}


def rigid_segments(polygon: np.ndarray, line: shapely.Geometry, tol: float) -> dict:
    """Edges of a fixed (rigid) counter-clockwise polygon that lie on ``line``."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    on = (shapely.distance(shapely.points(a), line) <= tol) & (
        shapely.distance(shapely.points(b), line) <= tol
    )
    a, b = a[on], b[on]
    normal = _unit(np.column_stack([(b - a)[:, 1], -(b - a)[:, 0]]))
    return {"a": a, "b": b, "normal": normal, "dofs": np.zeros((2, 0, len(a)), dtype=int)}


def facet_shape_values(xi: np.ndarray, nodes: int) -> np.ndarray:
    """1-D Lagrange shape values on a facet: (m, nodes) for ``nodes`` = 2 or 3."""
    if nodes == 2:
        return np.column_stack([1 - xi, xi])
    return np.column_stack([(1 - xi) * (1 - 2 * xi), xi * (2 * xi - 1), 4 * xi * (1 - xi)])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def choose_slave(interface: Interface, bm: BlockMesh, scene: Scene) -> tuple[int, int]:
    """(slave, master): a fixed block is the master, else the finer side is the slave."""
    a, b = interface.a, interface.b
    if scene.blocks[a].fixed:
        return b, a
    if scene.blocks[b].fixed:
        return a, b
    tol = contact_tolerance(scene)
    na = len(facets_on_line(bm, a, interface.line, tol))
    nb = len(facets_on_line(bm, b, interface.line, tol))
    return (b, a) if nb > na else (a, b)


def contact_tolerance(scene: Scene) -> float:
    """Distance under which a node counts as lying on an interface."""
    return 1e-6 * scene_size(scene)


def build_contact_points(
    scene: Scene, bm: BlockMesh, basis: CellBasis, interfaces: list[Interface]
) -> ContactPoints:
    """Slave points, springs, joint strengths and gap/slip operators of every interface.

    Everything comes from the scene: the penalty (:func:`penalty_of`), the
    shear ratio, the joint of each interface and its contact count.
    """
    tol = contact_tolerance(scene)
    penalty = penalty_of(scene)
    parts = []
    for row, interface in enumerate(interfaces):
        slave, master = choose_slave(interface, bm, scene)
        points = facet_points(bm, basis, facets_on_line(bm, slave, interface.line, tol))
        if scene.blocks[master].fixed:
            segments = rigid_segments(bm.polygons[master], interface.line, tol)
        else:
            segments = master_segments(
                bm, basis, master, facets_on_line(bm, master, interface.line, tol)
            )
        kappa = interface.contacts * penalty / interface.length
        part = _pair_rows(row, points, segments, basis.N)
        w = part["weight"]
        joint = interface.joint
        part.update(
            slave=np.full(len(w), slave),
            k_normal=kappa * w,
            k_shear=scene.contact.shear_ratio * kappa * w,
            friction=np.full(len(w), np.tan(np.radians(joint.friction_angle))),
            cohesion=joint.cohesion * w,
            tensile=joint.tensile_strength * w,
        )
        parts.append(part)
    return _stack(parts, basis.N)


def _pair_rows(row: int, points: dict, segments: dict, ndofs: int) -> dict:
    """Gap and slip operator rows of one interface."""
    xy = points["xy"]
    distance, xi = point_segment_distance(xy, segments["a"], segments["b"])
    nearest = distance.argmin(axis=1)
    xi = xi[np.arange(len(xy)), nearest]
    n = segments["normal"][nearest]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    a, b = segments["a"][nearest], segments["b"][nearest]
    gap0 = np.einsum("mi,mi->m", xy - (a + xi[:, None] * (b - a)), n)
    cols, coef_n, coef_t = [points["dofs"]], [n], [t]
    master = segments["dofs"]  # (2, nodes, f)
    if master.shape[1]:
        phi = facet_shape_values(xi, master.shape[1])  # (m, nodes)
        cols.append(master[:, :, nearest].transpose(2, 1, 0).reshape(len(xy), -1))
        coef_n.append((-phi[:, :, None] * n[:, None, :]).reshape(len(xy), -1))
        coef_t.append((-phi[:, :, None] * t[:, None, :]).reshape(len(xy), -1))
    cols = np.hstack(cols)
    rows = np.repeat(np.arange(len(xy)), cols.shape[1])
    shape = (len(xy), ndofs)
    return {
        "interface": np.full(len(xy), row),
        "points": xy,
        "weight": points["weight"],
        "normal": n,
        "gap0": gap0,
        "g_normal": sp.csr_matrix((np.hstack(coef_n).ravel(), (rows, cols.ravel())), shape),
        "g_shear": sp.csr_matrix((np.hstack(coef_t).ravel(), (rows, cols.ravel())), shape),
    }


PER_POINT = ("weight", "gap0", "k_normal", "k_shear", "friction", "cohesion", "tensile")


def _stack(parts: list[dict], ndofs: int) -> ContactPoints:
    if not parts:
        empty = sp.csr_matrix((0, ndofs))
        return ContactPoints(
            interface=np.zeros(0, int),
            slave=np.zeros(0, int),
            points=np.zeros((0, 2)),
            normal=np.zeros((0, 2)),
            g_normal=empty,
            g_shear=empty,
            **{k: np.zeros(0) for k in PER_POINT},
        )
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if not k.startswith("g_")}
    return ContactPoints(
        g_normal=sp.vstack([p["g_normal"] for p in parts]).tocsr(),
        g_shear=sp.vstack([p["g_shear"] for p in parts]).tocsr(),
        **cat,
    )
