"""Static linear elasticity of the free blocks in scikit-fem, with penalty contact.

The FEM model of a scene, term by term as the DDA sees it:

- elasticity per block, plane stress or plane strain as ``[analysis] plane``
  says (plane stress uses λ* = Eν/(1−ν²), μ = E/(2(1+ν)); both give the
  DDA's E matrix of docs/theory.md §3);
- gravity as the body force ρ g;
- point loads on the node at the load point (load points on a block
  boundary are mesh nodes, see :mod:`verify.fem.geometry`);
- fixed points as springs of the DDA's fixed-point penalty
  (``[analysis] fixed_point_penalty``, default 100 x the largest E) on the
  node at the point;
- fixed blocks are rigid and not meshed: the contact with them is against a
  rigid segment, as the DDA removes fixed blocks from its unknowns;
- contact between the blocks that touch in the scene: :mod:`verify.fem.contact`
  (springs from the scene's penalty, joints from the scene's joints), with
  the FEM's own contact law (:mod:`verify.fem.contact_law`): it finds which
  points are open or closed, sticking or slipping with Coulomb friction,
  cohesion and tensile strength; with the augmented-Lagrangian method the
  springs also carry multipliers, augmented until no closed point
  penetrates (and no sticking point slips) more than the scene's tolerance.

Nothing is read from a DDA run: the FEM model is the scene's.

A block held by frictionless contact only can still translate along the
contact; a mass-proportional stabiliser ``α ∫ u·v`` with
``α = stabiliser · E_max / L²`` (default 1e-8) makes the matrix regular.
It changes a loaded (elastic) displacement by about 1e-8 relative and does
nothing to an unloaded rigid mode, which then stays at zero, as in the
static DDA (it starts every step from rest).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from skfem import (
    Basis,
    BilinearForm,
    CellBasis,
    ElementTriP1,
    ElementTriP2,
    ElementVector,
    LinearForm,
)
from skfem.helpers import ddot, dot, sym_grad, trace

from dda.scene import Scene
from verify.fem.contact import ContactPoints, build_contact_points, contact_tolerance, penalty_of
from verify.fem.contact_law import ContactState, solve_with_contact
from verify.fem.geometry import geometric_tolerance, scene_size
from verify.fem.in_situ import (
    boundary_stress_load,
    contact_preload,
    excavated,
    initial_stress_load,
)
from verify.fem.interfaces import Interface, find_interfaces
from verify.fem.mesh import BlockMesh, mesh_blocks

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FemOptions:
    """Discretisation and solver settings of the FEM model."""

    order: int = 2  # 1 (P1) or 2 (P2) Lagrange elements
    size: float | None = None  # longest element edge; default: see mesh.default_size
    stabiliser: float = 1e-8  # relative mass-proportional regularisation
    max_active_set: int = 30  # active-set iterations before giving up


@dataclass
class FemSolution:
    """The solved FEM model of a scene."""

    scene: Scene
    block_mesh: BlockMesh
    basis: CellBasis
    u: np.ndarray  # (N,) displacement DOFs
    lam: np.ndarray  # (M,) Lamé λ (λ* in plane stress) per element
    mu: np.ndarray  # (M,) shear modulus per element
    interfaces: list[Interface]
    contact: ContactPoints
    state: ContactState  # open/closed, stick/slip of every contact point
    iterations: int  # linear solves (active-set iterations and augmentations)
    penalty: float

    @property
    def active(self) -> np.ndarray:
        """(m,) closed contact points."""
        return self.state.closed


def lame_parameters(young: float, poisson: float, plane: str) -> tuple[float, float]:
    """(λ, μ) for the 2-D model; ``plane`` is "stress" or "strain"."""
    mu = young / (2 * (1 + poisson))
    if plane == "strain":
        return young * poisson / ((1 + poisson) * (1 - 2 * poisson)), mu
    return young * poisson / (1 - poisson**2), mu


def element_materials(scene: Scene, bm: BlockMesh) -> dict[str, np.ndarray]:
    """Per-element λ, μ and density from each block's material."""
    table = {}
    for i in bm.blocks:
        m = scene.materials[scene.blocks[i].material]
        table[i] = (*lame_parameters(m.young, m.poisson, scene.analysis.plane), m.density)
    rows = np.array([table[i] for i in bm.element_block])
    return {"lam": rows[:, 0], "mu": rows[:, 1], "rho": rows[:, 2]}


@BilinearForm
def elasticity(u, v, w):
    """Linear elasticity: 2μ ε(u):ε(v) + λ tr ε(u) tr ε(v)."""
    eu, ev = sym_grad(u), sym_grad(v)
    return 2.0 * w.mu * ddot(eu, ev) + w.lam * trace(eu) * trace(ev)


@BilinearForm
def vector_mass(u, v, w):
    """∫ u · v."""
    return dot(u, v)


@LinearForm
def body_force(v, w):
    """∫ ρ g · v."""
    return w.fx * v[0] + w.fy * v[1]


def per_quadrature_point(values: np.ndarray, basis: CellBasis) -> np.ndarray:
    """Spread one value per element over the element's quadrature points."""
    return np.repeat(values[:, None], basis.X.shape[1], axis=1)


def node_dof_pairs(basis: CellBasis) -> np.ndarray:
    """(2, K) x- and y-DOF of every node: mesh vertices, then P2 mid-side nodes."""
    return np.hstack([basis.nodal_dofs, basis.facet_dofs])


def nearest_node_dofs(
    basis: CellBasis, bm: BlockMesh, block: int, point, tol: float
) -> tuple[int, int]:
    """(x, y) DOFs of the node of ``block`` closest to ``point``."""
    pairs = node_dof_pairs(basis)
    own = np.unique(basis.element_dofs[:, bm.element_block == block])
    pairs = pairs[:, np.isin(pairs[0], own)]
    distance = np.linalg.norm(basis.doflocs[:, pairs[0]].T - np.asarray(point), axis=1)
    k = int(distance.argmin())
    if distance[k] > tol:
        log.warning("point %s is %.3g from the nearest node of its block", point, distance[k])
    return int(pairs[0, k]), int(pairs[1, k])


def point_load_vectors(scene: Scene, bm: BlockMesh, basis: CellBasis) -> list[np.ndarray]:
    """One load vector per ``[[loads]]`` entry, at full value, on the node at its point."""
    vectors = []
    index = {b.name: i for i, b in enumerate(scene.blocks)}
    for load in scene.loads:
        f = np.zeros(basis.N)
        block = index[load.block]
        if not scene.blocks[block].fixed:
            dx, dy = nearest_node_dofs(basis, bm, block, load.point, geometric_tolerance(scene))
            f[dx], f[dy] = load.force
        vectors.append(f)
    return vectors


def load_factor_at(scene: Scene, time: float) -> np.ndarray:
    """Factor of every load at ``time``: its history interpolated linearly (docs/scene.md)."""
    return np.array(
        [
            1.0 if ld.history is None else float(np.interp(time, *np.array(ld.history).T))
            for ld in scene.loads
        ]
    )


def fixed_point_springs(scene: Scene, bm: BlockMesh, basis: CellBasis) -> sp.csr_matrix:
    """Diagonal springs of the fixed-point penalty at every fixed point of a free block."""
    penalty = scene.analysis.fixed_point_penalty
    if penalty is None:
        penalty = 100.0 * max(m.young for m in scene.materials.values())
    diagonal = np.zeros(basis.N)
    for i in bm.blocks:
        for point in scene.blocks[i].fixed_points:
            dofs = nearest_node_dofs(basis, bm, i, point, geometric_tolerance(scene))
            diagonal[list(dofs)] += penalty
    return sp.diags(diagonal).tocsr()


def gravity_load(scene: Scene, basis: CellBasis, materials: dict) -> np.ndarray:
    """Load vector of the body force ρ g."""
    gx, gy = scene.analysis.gravity
    rho = per_quadrature_point(materials["rho"], basis)
    return body_force.assemble(basis, fx=rho * gx, fy=rho * gy)


def base_system(
    scene: Scene, bm: BlockMesh, basis: CellBasis, options: FemOptions, load_factor: float = 1.0
):
    """Stiffness (elastic + fixed points + stabiliser) and load without contact.

    The point loads are taken at ``load_factor`` times their full value.
    """
    materials = element_materials(scene, bm)
    lam = per_quadrature_point(materials["lam"], basis)
    mu = per_quadrature_point(materials["mu"], basis)
    stiffness = elasticity.assemble(basis, lam=lam, mu=mu)
    young = max(m.young for m in scene.materials.values())
    alpha = options.stabiliser * young / scene_size(scene) ** 2
    stiffness = stiffness + alpha * vector_mass.assemble(basis)
    stiffness = stiffness + fixed_point_springs(scene, bm, basis)
    load = gravity_load(scene, basis, materials)
    load = load + load_factor * sum(point_load_vectors(scene, bm, basis), np.zeros(basis.N))
    return stiffness.tocsr(), load, materials


def make_basis(bm: BlockMesh, order: int) -> CellBasis:
    """Vector Lagrange basis of the given order on the block mesh."""
    return vector_basis(bm.mesh, order)


def vector_basis(mesh, order: int) -> CellBasis:
    """Vector Lagrange basis, P1 or P2, on a triangle mesh."""
    return Basis(mesh, ElementVector(ElementTriP2() if order == 2 else ElementTriP1()))


def uniform_elasticity(
    basis: CellBasis, young: float, poisson: float, plane: str = "stress"
) -> tuple[sp.csr_matrix, float, float]:
    """Stiffness of one homogeneous material on the whole basis, and its (λ, μ)."""
    lam, mu = lame_parameters(young, poisson, plane)
    ones = np.ones((basis.nelems, basis.X.shape[1]))
    return elasticity.assemble(basis, lam=lam * ones, mu=mu * ones).tocsr(), lam, mu


def contact_tolerance_of(scene: Scene) -> float | None:
    """The scene's augmented-Lagrangian tolerance (None for the pure penalty method).

    ``[contact] tolerance``, else its documented default: 1e-4 of the model's
    larger extent (docs/scene.md).
    """
    if scene.contact.method != "augmented-lagrangian":
        return None
    if scene.contact.tolerance is not None:
        return float(scene.contact.tolerance)
    points = np.concatenate([np.asarray(b.vertices) for b in scene.blocks])
    return 1e-4 * float((points.max(axis=0) - points.min(axis=0)).max())


def solve_fem(
    scene: Scene,
    options: FemOptions | None = None,
    load_factor: float = 1.0,
) -> FemSolution:
    """Mesh and solve the free blocks of a scene (static, small displacements).

    Parameters
    ----------
    scene : the scene (its analysis is treated as static)
    options : element order, size, stabiliser
    load_factor : factor on the point loads (their history is not used)

    With ``[in_situ]``, ``[[boundary_stresses]]`` and stages that remove blocks, the
    state after the last stage (:mod:`verify.fem.in_situ`); the solution's scene is then
    the scene without the removed blocks.
    """
    options = options or FemOptions()
    if any(any(b.stress) for b in scene.blocks):
        log.warning("initial block stresses are ignored by the FEM model")
    written, scene = scene, excavated(scene)  # the state after the stages' excavations
    interfaces = find_interfaces(scene)
    bm = mesh_blocks(scene, options.size)
    basis = make_basis(bm, options.order)
    stiffness, load, materials = base_system(scene, bm, basis, options, load_factor)
    load = load + initial_stress_load(scene, basis)
    boundary = boundary_stress_load(written, bm, basis.elem)
    if len(boundary):
        load = load + boundary
    contact = build_contact_points(scene, bm, basis, interfaces)
    state = ContactState.initial(contact, contact_tolerance(scene))
    lam_n, lam_t = contact_preload(scene, contact)  # the in-situ field across the joints
    state = replace(state, lam_n=lam_n * state.closed, lam_t=lam_t * state.closed)
    u, state, iterations = solve_with_contact(
        stiffness, load, contact, state, options.max_active_set, contact_tolerance_of(scene)
    )
    log.info(
        "FEM %s: %d DOFs, %d contact points (%d closed, %d slipping), %d solves",
        scene.title,
        basis.N,
        len(contact),
        state.closed.sum(),
        state.slip.sum(),
        iterations,
    )
    return FemSolution(
        scene=scene,
        block_mesh=bm,
        basis=basis,
        u=u,
        lam=materials["lam"],
        mu=materials["mu"],
        interfaces=interfaces,
        contact=contact,
        state=state,
        iterations=iterations,
        penalty=penalty_of(scene),
    )
