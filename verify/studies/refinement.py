"""Block refinement: a body cut into ever smaller DDA blocks, against the continuum.

Two bodies under self-weight, plane stress, clamped by high-strength joints
to a fixed block: a 2 m x 1 m cantilever (clamped at x = 0) and an L of three
1 m squares, a leg [0, 1] x [0, 2] with an arm [1, 2] x [1, 2] (clamped at
y = 0; its re-entrant corner at (1, 1)). Every unit square is cut into k x k
cells, and the cells are the DDA blocks:

``squares``
    each cell one block;
``triangles``
    each cell cut along a diagonal (alternating, so that the pattern at k
    refines the one at k / 2) into two blocks.

Every joint is "locked": cohesion and tensile strength far above any
stress, so that no contact ever opens or slides, and the contacts' penalty p
bonds the blocks' vertices. With p large the bonds are rigid. Triangles
bonded at their vertices then have a continuous, piecewise-affine
displacement: the DDA solves exactly the constant-strain-triangle (P1) finite
element problem on its blocks, and converges as P1 does (displacement L²
error O(h²), stress O(h)). Squares bonded at their corners cannot bend: a
field that is affine in every cell and continuous at its corners is
f(x) + g(y) in each component, whose strain exx = f'(x) cannot vary across
a section; a cantilever of rigidly bonded squares carries its load in shear
only, whatever k. With a softer penalty the bonds give, the squares can bend,
and the joints add their compliance, about E / (2p) of the strain.

The reference is the continuum: P2 elements on the triangulation of the
finest k refined twice more (so that every reference element lies in one
block of every k), exact clamp (u = 0), and its own error estimated against
one more refinement. Errors, relative, over the body:

``displacement``
    L² norm of the DDA's block fields (the affine map of every block, from
    its vertices) minus the reference, over that of the reference;
``stress``
    L² norm of the DDA's constant block stresses minus the reference field;
``tip``
    the displacement at the middle of the free end (cantilever: (2, 0.5); L:
    the arm's end, (2, 1.5)) against the reference's.

The observed order between k and 2k is log2(e_k / e_2k).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
import shapely
from skfem import Basis, LinearForm, MeshTri, condense
from skfem.helpers import sym_grad

import dda
from verify.fem.statics import uniform_elasticity, vector_basis

log = logging.getLogger(__name__)

DENSITY, GRAVITY, YOUNG, POISSON = 2700.0, 9.81, 5.0e9, 0.25
STRONG = 1.0e12  # cohesion and tensile strength of the locked joints, Pa (never reached)


@dataclass(frozen=True)
class Body:
    """Unit cells of a body, its clamped side, the fixed block and the tip point."""

    name: str
    cells: tuple[tuple[int, int], ...]  # lower-left corners of the unit squares
    clamp: str  # "x" (clamped at x = 0) or "y" (at y = 0)
    support: tuple[tuple[float, float], ...]  # the fixed block
    tip: tuple[float, float]


BODIES = {
    "cantilever": Body(
        "cantilever",
        ((0, 0), (1, 0)),
        "x",
        ((-0.5, -0.5), (0, -0.5), (0, 1.5), (-0.5, 1.5)),
        (2.0, 0.5),
    ),
    "l_shape": Body(
        "l_shape",
        ((0, 0), (0, 1), (1, 1)),
        "y",
        ((-0.5, -0.5), (1.5, -0.5), (1.5, 0), (-0.5, 0)),
        (2.0, 1.5),
    ),
}


@dataclass(frozen=True)
class Series:
    """One way of cutting the body: block shape and contact penalty (x E)."""

    name: str
    shape: str  # "triangles" or "squares"
    penalty: float  # p / E


SERIES = (
    Series("triangles, p = 1e4 E", "triangles", 1.0e4),
    Series("squares, p = 10 E", "squares", 10.0),
    Series("squares, p = 1e4 E", "squares", 1.0e4),
)


@dataclass(frozen=True)
class RefinementPoint:
    """Errors of one body, series and k."""

    body: str
    series: str
    k: int
    blocks: int
    displacement: float
    stress: float
    tip: float
    seconds: float


def cell_polygons(body: Body, k: int, shape: str) -> list[np.ndarray]:
    """Counter-clockwise block polygons: k x k cells per unit square, or their triangles."""
    out = []
    h = 1.0 / k
    for cx, cy in body.cells:
        for j in range(k):
            for i in range(k):
                x0, y0 = cx + i * h, cy + j * h
                a, b, c, d = (x0, y0), (x0 + h, y0), (x0 + h, y0 + h), (x0, y0 + h)
                if shape == "squares":
                    out.append(np.array([a, b, c, d]))
                elif (cx * k + i + cy * k + j) % 2 == 0:  # diagonal a-c
                    out += [np.array([a, b, c]), np.array([a, c, d])]
                else:  # diagonal b-d
                    out += [np.array([a, b, d]), np.array([b, c, d])]
    return out


def block_scene(body: Body, k: int, series: Series) -> dda.Scene:
    """The DDA scene of one body cut at k, joints locked (module notes)."""
    blocks = [{"name": "support", "material": "rock", "fixed": True, "vertices": body.support}]
    blocks += [
        {"name": f"b{n}", "material": "rock", "vertices": p.tolist()}
        for n, p in enumerate(cell_polygons(body, k, series.shape))
    ]
    return dda.load_scene(
        {
            "title": f"{body.name}, {series.name}, k = {k}",
            "analysis": {
                "mode": "static",
                "time_step": 1.0,
                "steps": 6,
                "gravity": [0.0, -GRAVITY],
                "plane": "stress",
                "save_every": 1,
            },
            "contact": {"method": "penalty", "penalty": series.penalty * YOUNG},
            "materials": {"rock": {"density": DENSITY, "young": YOUNG, "poisson": POISSON}},
            "joints": {
                "default": {"friction_angle": 45.0, "cohesion": STRONG, "tensile_strength": STRONG}
            },
            "blocks": blocks,
        }
    )


@dataclass
class Reference:
    """The continuum solution: its basis, displacement and per-quadrature-point fields."""

    basis: Basis
    u: np.ndarray
    points: np.ndarray  # (2, M, q) quadrature points
    dx: np.ndarray  # (M, q) quadrature weights
    displacement: np.ndarray  # (2, M, q)
    stress: np.ndarray  # (3, M, q)
    tip: np.ndarray  # (2,)


def triangulation(body: Body, k: int) -> MeshTri:
    """The triangles of ``cell_polygons(body, k, "triangles")`` as one conforming mesh."""
    triangles = cell_polygons(body, k, "triangles")
    corners = np.concatenate(triangles)
    points, index = np.unique(np.round(corners * k * 4) / (k * 4), axis=0, return_inverse=True)
    return MeshTri(np.ascontiguousarray(points.T), np.ascontiguousarray(index.reshape(-1, 3).T))


def solve_continuum(body: Body, mesh: MeshTri, order: int = 2) -> Reference:
    """Linear elasticity under self-weight with the clamped side held exactly."""
    basis = vector_basis(mesh, order)
    stiffness, lam, mu = uniform_elasticity(basis, YOUNG, POISSON)

    @LinearForm
    def weight(v, w):
        """−ρ g v_y."""
        return -DENSITY * GRAVITY * v[1]

    axis = 0 if body.clamp == "x" else 1
    clamped = basis.get_dofs(lambda x: np.abs(x[axis]) < 1e-12).all()
    u = np.zeros(basis.N)
    A, b, _, interior = condense(stiffness, weight.assemble(basis), x=u, D=clamped)
    u[interior] = spla.spsolve(A.tocsc(), b)
    field = basis.interpolate(u)
    eps = np.asarray(sym_grad(field))
    tr = eps[0, 0] + eps[1, 1]
    stress = np.array(
        [2 * mu * eps[0, 0] + lam * tr, 2 * mu * eps[1, 1] + lam * tr, 2 * mu * eps[0, 1]]
    )
    tip = basis.probes(np.array(body.tip).reshape(2, 1)) @ u
    return Reference(
        basis, u, np.asarray(basis.global_coordinates()), basis.dx, np.asarray(field), stress, tip
    )


def reference(body: Body, k_max: int, levels: int = 2) -> tuple[Reference, dict[str, float]]:
    """The continuum reference and the change of its norms with one more refinement."""
    mesh = triangulation(body, k_max).refined(levels)
    coarse = solve_continuum(body, mesh)
    fine = solve_continuum(body, mesh.refined(1))

    def change(a: float, b: float) -> float:
        return abs(a - b) / abs(b)

    estimate = {
        "displacement": change(l2(coarse.displacement, coarse.dx), l2(fine.displacement, fine.dx)),
        "stress": change(l2(coarse.stress, coarse.dx), l2(fine.stress, fine.dx)),
        "tip": float(np.linalg.norm(coarse.tip - fine.tip) / np.linalg.norm(fine.tip)),
        "elements": int(coarse.basis.nelems),
        "dofs": int(coarse.basis.N),
    }
    return coarse, estimate


def l2(values: np.ndarray, dx: np.ndarray) -> float:
    """L² norm of a field (c, M, q) with quadrature weights (M, q)."""
    return float(np.sqrt((np.asarray(values) ** 2 * dx).sum()))


def block_maps(before: list[np.ndarray], after: list[np.ndarray]) -> np.ndarray:
    """(n, 2, 3) affine maps u(x) = A [1, x, y] of every block, from its vertices."""
    maps = []
    for x0, x1 in zip(before, after, strict=True):
        design = np.column_stack([np.ones(len(x0)), x0])
        maps.append(np.linalg.lstsq(design, x1 - x0, rcond=None)[0].T)
    return np.array(maps)


def locate(polygons: list[np.ndarray], points: np.ndarray, touching: bool = False) -> np.ndarray:
    """Index of the polygon holding every point (``touching``: or on its boundary)."""
    tree = shapely.STRtree([shapely.Polygon(p) for p in polygons])
    predicate = "intersects" if touching else "within"
    found, polygon = tree.query(shapely.points(points), predicate=predicate)
    owner = np.full(len(points), -1)
    owner[found[::-1]] = polygon[::-1]  # the first match of every point
    if (owner < 0).any():
        raise ValueError(f"{(owner < 0).sum()} points lie in no block")
    return owner


def field_errors(
    polygons: list[np.ndarray], maps: np.ndarray, stresses: np.ndarray, ref: Reference, body: Body
) -> dict[str, float]:
    """Relative L² displacement and stress errors and tip error of blockwise fields.

    ``maps`` (n, 2, 3): the affine displacement of every block; ``stresses``
    (n, 3): its constant stress. Every reference element lies in one block.
    """
    owner = locate(polygons, ref.points.mean(axis=2).T)
    x, y = ref.points
    u = np.einsum("mcj,jmq->cmq", maps[owner], np.array([np.ones_like(x), x, y]))
    s = stresses[owner].T[:, :, None]
    tip_block = locate(polygons, np.array([body.tip]), touching=True)[0]
    tip = maps[tip_block] @ np.array([1.0, *body.tip])
    return {
        "displacement": l2(u - ref.displacement, ref.dx) / l2(ref.displacement, ref.dx),
        "stress": l2(s - ref.stress, ref.dx) / l2(ref.stress, ref.dx),
        "tip": float(np.linalg.norm(tip - ref.tip) / np.linalg.norm(ref.tip)),
    }


def dda_point(body: Body, series: Series, k: int, ref: Reference) -> RefinementPoint:
    """Run the DDA on one body, series and k, and measure its errors."""
    scene = block_scene(body, k, series)
    start = time.perf_counter()
    result = dda.simulate(scene)
    seconds = time.perf_counter() - start
    first, final = result.frames[0], result.final
    names = [b.name for b in scene.blocks if not b.fixed]
    before = [first.vertices[first.block(n)] for n in names]
    maps = block_maps(before, [final.vertices[final.block(n)] for n in names])
    stresses = final.stresses[[final.block(n) for n in names]]
    errors = field_errors(before, maps, stresses, ref, body)
    log.info("%s, %s, k = %d: %s (%.1f s)", body.name, series.name, k, errors, seconds)
    return RefinementPoint(body.name, series.name, k, len(names), **errors, seconds=seconds)


P1_SERIES = "P1 FEM on the triangles"


def p1_point(body: Body, k: int, ref: Reference) -> RefinementPoint:
    """The P1 finite-element solution on the triangles of k, measured like a DDA run."""
    start = time.perf_counter()
    mesh = triangulation(body, k)
    p1 = solve_continuum(body, mesh, order=1)
    seconds = time.perf_counter() - start
    before = [mesh.p[:, t].T for t in mesh.t.T]
    moved = p1.u[p1.basis.nodal_dofs].T  # (nodes, 2)
    maps = block_maps(before, [b + moved[t] for b, t in zip(before, mesh.t.T, strict=True)])
    stresses = p1.stress[:, :, 0].T  # constant in every triangle
    errors = field_errors(before, maps, stresses, ref, body)
    return RefinementPoint(body.name, P1_SERIES, k, mesh.t.shape[1], **errors, seconds=seconds)


def refinement_study(
    ks: tuple[int, ...] = (1, 2, 4, 8, 16),
    bodies: tuple[str, ...] = tuple(BODIES),
    series: tuple[Series, ...] = SERIES,
    progress=None,
) -> tuple[list[RefinementPoint], dict[str, dict]]:
    """Every body, series and k; and the references' sizes and error estimates.

    ``progress``: called with a line of text as each body and k starts.
    """
    tell = progress or log.info
    points, references = [], {}
    for name in bodies:
        body = BODIES[name]
        tell(f"block refinement, {name}: the continuum reference")
        ref, estimate = reference(body, max(ks))
        references[name] = estimate
        for k in ks:
            tell(f"block refinement, {name}: k = {k}")
            points.append(p1_point(body, k, ref))
            points += [dda_point(body, s, k, ref) for s in series]
    return points, references


def observed_orders(points: list[RefinementPoint], quantity: str) -> dict[tuple, list[float]]:
    """log2(e_k / e_2k) between successive k, per (body, series)."""
    out = {}
    for key in sorted({(p.body, p.series) for p in points}):
        run = sorted((p for p in points if (p.body, p.series) == key), key=lambda p: p.k)
        errors = [getattr(p, quantity) for p in run]
        out[key] = [float(np.log2(a / b)) for a, b in zip(errors, errors[1:], strict=False)]
    return out


@dataclass(frozen=True)
class Finding:
    """One stated expectation of the refinement study, and whether it holds."""

    body: str
    claim: str
    value: float
    limit: float
    passed: bool


def series_run(points: list[RefinementPoint], body: str, series: str) -> list[RefinementPoint]:
    """Points of one body and series, by k."""
    return sorted((p for p in points if (p.body, p.series) == (body, series)), key=lambda p: p.k)


def findings(points: list[RefinementPoint]) -> list[Finding]:
    """The study's expectations (docs/verification.md derives them):

    - rigidly bonded triangles are the P1 (constant-strain triangle) FEM on
      the same triangles, up to the joints' compliance, E / (2p) = 5e-5 of
      the strain: their relative errors agree within 1e-3 at every k;
    - their displacement error falls at every doubling of k, at an observed
      order of at least 1.2 over the last doubling (P1's is 2 on a smooth
      problem; the L's re-entrant corner lowers it), once k reaches 4;
    - squares with the engine's default penalty (10 E) bend by their joints:
      their error falls at every doubling too (slowly; it levels off at the
      joints' compliance, about E / (2p) = 5 %).
    """
    out = []
    triangles, soft = SERIES[0].name, SERIES[1].name
    for body in sorted({p.body for p in points}):
        dda_run, p1_run = series_run(points, body, triangles), series_run(points, body, P1_SERIES)
        gap = max(
            abs(getattr(a, q) - getattr(b, q))
            for a, b in zip(dda_run, p1_run, strict=True)
            for q in ("displacement", "stress", "tip")
        )
        out.append(
            Finding(body, f"{triangles}: the P1 FEM on its triangles", gap, 1e-3, gap <= 1e-3)
        )
        for series in (triangles, soft):
            errors = [p.displacement for p in series_run(points, body, series)]
            ratio = max(b / a for a, b in zip(errors, errors[1:], strict=False))
            out.append(
                Finding(body, f"{series}: error falls with every doubling", ratio, 1.0, ratio < 1.0)
            )
        run = series_run(points, body, triangles)
        if run[-1].k >= 4:
            order = float(np.log2(run[-2].displacement / run[-1].displacement))
            out.append(
                Finding(body, f"{triangles}: order of the last doubling", order, 1.2, order >= 1.2)
            )
    return out
