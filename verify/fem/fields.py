"""Quantities read off a FEM solution: block averages, point values, contact resultants.

Block averages are exact integrals over the block's elements (no
projection). For a block in equilibrium, the average stress depends only
on the forces acting on it::

    ∫_A σ_ij dA = ∮ t_i x_j ds + ∫_A b_i x_j dA

(tractions t on the boundary, body force b), which also holds for the DDA's
constant block stress, so block averages are the like-for-like comparison.
"""

from __future__ import annotations

import numpy as np
import shapely
from skfem import ElementDG, ElementTriP1
from skfem.helpers import sym_grad

from verify.fem.contact_law import forces
from verify.fem.geometry import geometric_tolerance
from verify.fem.in_situ import initial_stress_at
from verify.fem.statics import FemSolution, nearest_node_dofs, per_quadrature_point

COMPONENTS = ("sxx", "syy", "sxy")


def stress_at_quadrature(solution: FemSolution) -> np.ndarray:
    """(3, M, q) sxx, syy, sxy at the quadrature points of every element: the in-situ
    field σ0 (:mod:`verify.fem.in_situ`) plus C ε(u)."""
    basis = solution.basis
    eps = np.asarray(sym_grad(basis.interpolate(solution.u)))
    lam = per_quadrature_point(solution.lam, basis)
    mu = per_quadrature_point(solution.mu, basis)
    tr = eps[0, 0] + eps[1, 1]
    initial = initial_stress_at(solution.scene, np.asarray(basis.global_coordinates()[1]))
    return initial + np.stack(
        [2 * mu * eps[0, 0] + lam * tr, 2 * mu * eps[1, 1] + lam * tr, 2 * mu * eps[0, 1]]
    )


def element_integrals(solution: FemSolution, values: np.ndarray) -> np.ndarray:
    """∫ over every element of values given at the quadrature points, (..., M)."""
    dx = solution.basis.dx  # (M, q) quadrature weights times |det J|
    return (values * dx).sum(axis=-1)


def block_sums(solution: FemSolution, per_element: np.ndarray) -> np.ndarray:
    """Sum per-element values (..., M) into per-scene-block totals (..., n)."""
    n = len(solution.scene.blocks)
    tags = solution.block_mesh.element_block
    flat = per_element.reshape(-1, per_element.shape[-1])
    out = np.array([np.bincount(tags, weights=row, minlength=n) for row in flat])
    return out.reshape(*per_element.shape[:-1], n)


def block_areas(solution: FemSolution) -> np.ndarray:
    """(n,) area of every scene block in the mesh (0 for fixed blocks)."""
    return block_sums(solution, element_integrals(solution, np.ones_like(solution.basis.dx)))


def block_average_stress(solution: FemSolution) -> np.ndarray:
    """(n, 3) area-averaged sxx, syy, sxy per scene block (NaN for fixed blocks)."""
    totals = block_sums(solution, element_integrals(solution, stress_at_quadrature(solution)))
    with np.errstate(invalid="ignore", divide="ignore"):
        return (totals / block_areas(solution)).T


def block_average_strain(solution: FemSolution) -> np.ndarray:
    """(n, 3) area-averaged exx, eyy, gxy per scene block (NaN for fixed blocks).

    For a homogeneous block this is the compliance times the average stress,
    whatever the field: the like-for-like counterpart of a DDA block's one
    strain.
    """
    eps = np.asarray(sym_grad(solution.basis.interpolate(solution.u)))
    strain = np.stack([eps[0, 0], eps[1, 1], 2.0 * eps[0, 1]])
    totals = block_sums(solution, element_integrals(solution, strain))
    with np.errstate(invalid="ignore", divide="ignore"):
        return (totals / block_areas(solution)).T


def block_mean_rotation(solution: FemSolution) -> np.ndarray:
    """(n,) area-averaged rotation ½ (∂v/∂x − ∂u/∂y) per scene block (NaN for fixed ones)."""
    grad = np.asarray(solution.basis.interpolate(solution.u).grad)  # (2, 2, M, q)
    spin = 0.5 * (grad[1, 0] - grad[0, 1])
    totals = block_sums(solution, element_integrals(solution, spin))
    with np.errstate(invalid="ignore", divide="ignore"):
        return totals / block_areas(solution)


def block_mean_displacement(solution: FemSolution) -> np.ndarray:
    """(n, 2) area-averaged displacement per scene block (NaN for fixed blocks).

    The DDA's centroid displacement is the mean of its linear field over the
    block, so this is its like-for-like FEM counterpart.
    """
    u = np.asarray(solution.basis.interpolate(solution.u))  # (2, M, q)
    totals = block_sums(solution, element_integrals(solution, u))
    with np.errstate(invalid="ignore", divide="ignore"):
        return (totals / block_areas(solution)).T


def displacement_at_point(solution: FemSolution, block: int, point) -> np.ndarray:
    """Displacement at a point inside a block (NaN when the point is outside it)."""
    polygon = shapely.Polygon(solution.block_mesh.polygons[block])
    if not polygon.buffer(geometric_tolerance(solution.scene)).contains(shapely.Point(point)):
        return np.full(2, np.nan)
    tags = solution.block_mesh.element_block
    mesh = solution.block_mesh.mesh
    p = mesh.p[:, mesh.t[:, tags == block]]  # (2, 3, m)
    inside = _barycentric_inside(p, np.asarray(point, dtype=float))
    element = int(np.flatnonzero(tags == block)[inside])
    return _evaluate_in_element(solution, element, point)


def _barycentric_inside(p: np.ndarray, x: np.ndarray) -> int:
    """Index (among the given triangles) of the one that contains x."""
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    l1 = ((x[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (x[1] - a[1])) / det
    l2 = ((b[0] - a[0]) * (x[1] - a[1]) - (x[0] - a[0]) * (b[1] - a[1])) / det
    outside = -np.minimum(np.minimum(l1, l2), 1 - l1 - l2)
    return int(outside.argmin())


def _evaluate_in_element(solution: FemSolution, element: int, point) -> np.ndarray:
    basis = solution.basis
    mapping = basis.mapping
    x = np.asarray(point, dtype=float).reshape(2, 1, 1)
    local = mapping.invF(x, tind=np.array([element]))[:, 0, :]
    values = np.zeros(2)
    for k in range(basis.Nbfun):
        phi = basis.elem.gbasis(mapping, local, k, tind=np.array([element]))[0]
        values += np.asarray(phi)[:, 0, 0] * solution.u[basis.element_dofs[k, element]]
    return values


def vertex_displacements(solution: FemSolution, block: int, vertices: np.ndarray) -> np.ndarray:
    """(k, 2) displacement of the nodes at the given vertices of one block."""
    tol = 10 * geometric_tolerance(solution.scene)
    out = []
    for v in np.asarray(vertices, dtype=float):
        dx, dy = nearest_node_dofs(solution.basis, solution.block_mesh, block, v, tol)
        out.append(solution.u[[dx, dy]])
    return np.array(out)


def interface_forces(solution: FemSolution) -> list[dict]:
    """Per interface: resultant force, mean overlap and the points' states.

    ``force`` is the resultant (x, y) on the interface's higher-index block
    ``b``: a slave point feels N n − f_t t (:mod:`verify.fem.contact_law`), its
    master the opposite. ``penetration`` is the overlap of the closed points
    integrated along the interface over its length (the DDA's counterpart:
    the sum of its contacts' penetrations over their number); both are
    N / (n_c p) for a resultant N, however the pressure is distributed.
    """
    contact, u, state = solution.contact, solution.u, solution.state
    f = forces(contact, state, u)
    t = np.column_stack([-contact.normal[:, 1], contact.normal[:, 0]])
    on_slave = f.normal[:, None] * contact.normal - f.shear[:, None] * t
    overlap = np.where(state.closed, -contact.gaps(u), 0.0)
    out = []
    for row, interface in enumerate(solution.interfaces):
        on = contact.interface == row
        sign = np.where(contact.slave[on] == interface.b, 1.0, -1.0)[:, None]
        weight = contact.weight[on]
        out.append(
            {
                "blocks": (interface.a, interface.b),
                "force": (sign * on_slave[on]).sum(axis=0),
                "normal_force": float(f.normal[on].sum()),
                "penetration": float((weight * overlap[on]).sum() / weight.sum()),
                "max_penetration": float(overlap[on].max(initial=0.0)),
                "closed_fraction": float(weight[state.closed[on]].sum() / weight.sum()),
                "slip_fraction": float(
                    weight[state.slip[on]].sum() / max(weight[state.closed[on]].sum(), 1e-300)
                ),
            }
        )
    return out


def stress_field(solution: FemSolution) -> np.ndarray:
    """(3, M, 3) stress projected on discontinuous P1, at each element's vertices."""
    basis_dg = solution.basis.with_element(ElementDG(ElementTriP1()))
    sigma = stress_at_quadrature(solution)
    dofs = basis_dg.element_dofs  # (3, M), in the order of mesh.t
    return np.stack([basis_dg.project(s)[dofs].T for s in sigma])


def nodal_displacement(solution: FemSolution) -> np.ndarray:
    """(N_nodes, 2) displacement at the mesh vertices."""
    return solution.u[solution.basis.nodal_dofs].T
