"""FEM convergence against a closed form: a block under self-weight.

Closed form (plane stress, tension positive). A block of width w and height
h, density ρ, gravity −g in y, free top, carried by a uniform pressure ρgh
on its base (a traction condition: the exact support of a frictionless
base that lets the base bend freely). Equilibrium, compatibility and the
boundary conditions are met by::

    σyy = −ρ g (h − y),  σxx = σxy = 0
    u = ν ρ g x (h − y) / E
    v = −ρ g (h y − y²/2) / E + ν ρ g x² / (2E)      (+ rigid motion)

with x measured from the block's vertical centre line. The rigid motion
is removed by pinning the base centre and one base corner to their exact
values; the error is measured after removing its L²-closest rigid motion,
so that it is the discretisation's error only, not that of a pin.

The displacement is quadratic, so P2 elements reproduce it to round-off
(a patch test). P1 elements do not: with mesh size H their displacement
error in L² falls as H² and their stress error in L² as H. The study runs
P1 at three sizes and reports the observed rates
``log(e_coarse / e_fine) / log(H_coarse / H_fine)``, and P2 at the coarsest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from skfem import FacetBasis, LinearForm, condense

from dda.scene import Scene, load_scene
from verify.fem.mesh import mesh_blocks
from verify.fem.statics import per_quadrature_point, uniform_elasticity, vector_basis

DENSITY, GRAVITY, YOUNG, POISSON = 2700.0, 9.81, 5.0e9, 0.25
WIDTH, HEIGHT = 1.0, 2.0


@dataclass(frozen=True)
class ConvergencePoint:
    """Errors of one mesh: relative L² errors of displacement and stress."""

    order: int
    size: float
    dofs: int
    displacement_error: float
    stress_error: float


def block_scene() -> Scene:
    """The free block of the study as a scene (plane stress, gravity)."""
    return load_scene(
        {
            "title": "self-weight closed form",
            "analysis": {"mode": "static", "gravity": [0.0, -GRAVITY]},
            "materials": {"rock": {"density": DENSITY, "young": YOUNG, "poisson": POISSON}},
            "blocks": [
                {
                    "name": "block",
                    "material": "rock",
                    "vertices": [
                        [-WIDTH / 2, 0.0],
                        [WIDTH / 2, 0.0],
                        [WIDTH / 2, HEIGHT],
                        [-WIDTH / 2, HEIGHT],
                    ],
                }
            ],
        }
    )


def exact_displacement(x: np.ndarray) -> np.ndarray:
    """Closed-form (u, v) at points ``x`` of shape (2, ...)."""
    rg = DENSITY * GRAVITY
    u = POISSON * rg * x[0] * (HEIGHT - x[1]) / YOUNG
    v = -rg * (HEIGHT * x[1] - x[1] ** 2 / 2) / YOUNG + POISSON * rg * x[0] ** 2 / (2 * YOUNG)
    return np.array([u, v])


def exact_stress(x: np.ndarray) -> np.ndarray:
    """Closed-form (σxx, σyy, σxy) at points ``x`` of shape (2, ...)."""
    zero = np.zeros_like(x[0])
    return np.array([zero, -DENSITY * GRAVITY * (HEIGHT - x[1]), zero])


def solve_closed_form_problem(order: int, size: float):
    """FEM solution of the closed-form problem; returns (basis, u, λ, μ)."""
    scene = block_scene()
    bm = mesh_blocks(scene, size)
    basis = vector_basis(bm.mesh, order)
    stiffness, lam, mu = uniform_elasticity(basis, YOUNG, POISSON)

    @LinearForm
    def gravity(v, w):
        """Body force ρg, downwards."""
        return -DENSITY * GRAVITY * v[1]

    base = FacetBasis(bm.mesh, basis.elem, facets=bm.mesh.facets_satisfying(lambda x: x[1] < 1e-12))

    @LinearForm
    def base_pressure(v, w):
        """Uniform pressure ρgh pushing the base up."""
        return DENSITY * GRAVITY * HEIGHT * v[1]

    load = gravity.assemble(basis) + base_pressure.assemble(base)
    pinned, values = pin_rigid_motion(basis)
    u = np.zeros(basis.N)
    u[pinned] = values
    u = _solve(stiffness, load, u, pinned)
    return (
        basis,
        u,
        per_quadrature_point(np.full(basis.nelems, lam), basis),
        per_quadrature_point(np.full(basis.nelems, mu), basis),
    )


def _solve(stiffness, load, u, pinned):
    A, b, x, interior = condense(stiffness, load, x=u, D=pinned)
    u = u.copy()
    u[interior] = spla.spsolve(A.tocsc(), b)
    return u


def pin_rigid_motion(basis) -> tuple[np.ndarray, np.ndarray]:
    """DOFs and exact values that remove the rigid motion: base centre (u, v), corner v."""
    p = basis.mesh.p
    nodes = [int(np.argmin(np.hypot(p[0] - x, p[1]))) for x in (0.0, -WIDTH / 2)]
    dofs = np.array(
        [
            basis.nodal_dofs[0, nodes[0]],
            basis.nodal_dofs[1, nodes[0]],
            basis.nodal_dofs[1, nodes[1]],
        ]
    )
    exact = exact_displacement(p[:, nodes])
    return dofs, np.array([exact[0, 0], exact[1, 0], exact[1, 1]])


def relative_errors(basis, u, lam, mu) -> tuple[float, float]:
    """Relative L² errors of displacement and stress over the block."""
    from skfem.helpers import sym_grad

    field = basis.interpolate(u)
    x = np.asarray(basis.global_coordinates())
    dx = basis.dx
    uh = np.asarray(field)
    ue = exact_displacement(x)
    eps = np.asarray(sym_grad(field))
    tr = eps[0, 0] + eps[1, 1]
    sh = np.array(
        [2 * mu * eps[0, 0] + lam * tr, 2 * mu * eps[1, 1] + lam * tr, 2 * mu * eps[0, 1]]
    )
    se = exact_stress(x)

    def norm(f):
        """L² norm over the block."""
        return np.sqrt((f**2 * dx).sum())

    return norm(without_rigid_motion(uh - ue, x, dx)) / norm(ue), norm(sh - se) / norm(se)


def without_rigid_motion(e: np.ndarray, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Remove from a field (2, M, q) its L²-closest rigid motion (u0, v0, rotation)."""
    zero, one = np.zeros_like(x[0]), np.ones_like(x[0])
    modes = [np.array([one, zero]), np.array([zero, one]), np.array([-x[1], x[0]])]
    gram = np.array([[(a * b * dx).sum() for b in modes] for a in modes])
    coef = np.linalg.solve(gram, [(m * e * dx).sum() for m in modes])
    return e - sum(c * m for c, m in zip(coef, modes, strict=True))


def convergence_study(sizes=(0.5, 0.25, 0.125)) -> list[ConvergencePoint]:
    """P1 at every size, P2 at the coarsest (see the module notes)."""
    points = []
    for order, run in ((1, sizes), (2, sizes[:1])):
        for size in run:
            basis, u, lam, mu = solve_closed_form_problem(order, size)
            eu, es = relative_errors(basis, u, lam, mu)
            points.append(ConvergencePoint(order, size, basis.N, eu, es))
    return points


def observed_rates(points: list[ConvergencePoint], order: int = 1) -> dict[str, float]:
    """Rates between the coarsest and finest mesh of one element order."""
    run = sorted((p for p in points if p.order == order), key=lambda p: -p.size)
    first, last = run[0], run[-1]
    h = np.log(first.size / last.size)
    return {
        "displacement": float(np.log(first.displacement_error / last.displacement_error) / h),
        "stress": float(np.log(first.stress_error / last.stress_error) / h),
    }
