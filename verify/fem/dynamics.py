"""The FEM model in time, with the engine's time integrator: displacement histories.

The DDA integrates with Shi's constant-acceleration scheme (Newmark β = 1/2;
docs/theory.md §3): over a step Δt the displacement D solves

    (K + 2M/Δt²) D = F(t + Δt) − f_int + (2/Δt) M v,

and the velocity follows Newmark's update with the scene's
``[analysis] newmark_gamma`` γ (1: Shi's v ← 2D/Δt − v)::

    a₊ = 2 (D − v Δt) / Δt²,     v ← v + Δt ((1 − γ) a + γ a₊)

(a: the last step's a₊; on the first step a = a₊).

with M the mass matrix, K the stiffness and f_int the internal force at the
step start. The FEM side here does the same with its own matrices: the
consistent mass M = ∫ ρ N·N, the elastic stiffness and fixed-point springs
of :mod:`verify.fem.statics`, and its own contact law solved in every step
(:mod:`verify.fem.contact_law`, slip carried from step to step). In total
displacements (linear elasticity, f_int = K u)::

    (K + 2M/Δt²) u₊ = F(t + Δt) + (2M/Δt²) u + (2/Δt) M v

The scheme is exact for a constant acceleration (free fall) for every γ; at
γ = 1 it damps an oscillation of frequency ω by (1 + (ωΔt)²/2)^(−1/2) per
step while ωΔt < 4, less beyond, and a mode much stiffer than 1/Δt² not at
all (docs/theory.md §3). Both models share the scheme, so their histories
can be compared step for step.

Time steps: the scene's ``time_step``, ``steps`` of them (or ``duration``
divided into steps of at most ``time_step``). Initial velocities: the
scene's ``velocity`` (vx, vy, ω at the centroid) of every block. Loads: the
point loads times their history at the end of each step.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
from skfem import BilinearForm
from skfem.helpers import dot

from dda import Scene
from verify.fem import fields
from verify.fem.contact import build_contact_points, contact_tolerance, penalty_of
from verify.fem.contact_law import ContactState, after_step, solve_with_contact
from verify.fem.geometry import polygon_centroid
from verify.fem.interfaces import find_interfaces
from verify.fem.mesh import mesh_blocks
from verify.fem.statics import (
    FemOptions,
    FemSolution,
    base_system,
    contact_tolerance_of,
    element_materials,
    gravity_load,
    load_factor_at,
    make_basis,
    node_dof_pairs,
    per_quadrature_point,
    point_load_vectors,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FemHistory:
    """Block means of the FEM model at every step (step 0: the start)."""

    times: np.ndarray  # (s + 1,)
    displacements: np.ndarray  # (s + 1, n, 2) block mean displacements
    rotations: np.ndarray  # (s + 1, n) block mean rotations
    stresses: np.ndarray  # (s + 1, n, 3) block average stresses
    final: FemSolution  # the last step, for fields and pictures


@BilinearForm
def density_mass(u, v, w):
    """∫ ρ u · v."""
    return w.rho * dot(u, v)


def time_steps(scene: Scene) -> np.ndarray:
    """End times of the steps: ``steps`` x ``time_step``, or ``duration`` in equal steps."""
    a = scene.analysis
    if a.steps is not None:
        return a.time_step * np.arange(1, a.steps + 1)
    duration = 1.0 if a.duration is None else a.duration
    count = int(np.ceil(duration / a.time_step - 1e-9))
    return duration * np.arange(1, count + 1) / count


def initial_velocity(scene: Scene, basis, element_block: np.ndarray) -> np.ndarray:
    """DOF vector of every block's rigid velocity (vx − ω (y − yc), vy + ω (x − xc))."""
    v = np.zeros(basis.N)
    pairs = node_dof_pairs(basis)
    for i, block in enumerate(scene.blocks):
        if block.fixed or not any(block.velocity):
            continue
        vx, vy, omega = block.velocity
        own = pairs[:, np.isin(pairs[0], basis.element_dofs[:, element_block == i])]
        x, y = basis.doflocs[:, own[0]]
        xc, yc = polygon_centroid(np.asarray(block.vertices, dtype=float))
        v[own[0]] = vx - omega * (y - yc)
        v[own[1]] = vy + omega * (x - xc)
    return v


def block_record(solution: FemSolution) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Block mean displacement, mean rotation and average stress of one step."""
    return (
        fields.block_mean_displacement(solution),
        fields.block_mean_rotation(solution),
        fields.block_average_stress(solution),
    )


def integrate(scene: Scene, options: FemOptions | None = None) -> FemHistory:
    """Integrate the FEM model of ``scene`` with the engine's scheme (module notes)."""
    options = options or FemOptions()
    interfaces = find_interfaces(scene)
    bm = mesh_blocks(scene, options.size)
    basis = make_basis(bm, options.order)
    # no stabiliser: the mass makes the matrix regular
    stiffness, _, materials = base_system(scene, bm, basis, replace(options, stabiliser=0.0), 0.0)
    rho = per_quadrature_point(element_materials(scene, bm)["rho"], basis)
    mass = density_mass.assemble(basis, rho=rho).tocsr()
    gravity = gravity_load(scene, basis, materials)
    loads = point_load_vectors(scene, bm, basis)
    contact = build_contact_points(scene, bm, basis, interfaces)
    state = ContactState.initial(contact, contact_tolerance(scene))
    tolerance = contact_tolerance_of(scene)
    u = np.zeros(basis.N)
    v = initial_velocity(scene, basis, bm.element_block)
    gamma = scene.analysis.newmark_gamma
    a = None  # the last step's acceleration

    def solution(u_now: np.ndarray, state_now: ContactState, solves: int) -> FemSolution:
        return FemSolution(
            scene,
            bm,
            basis,
            u_now,
            materials["lam"],
            materials["mu"],
            interfaces,
            contact,
            state_now,
            solves,
            penalty_of(scene),
        )

    records = [block_record(solution(u, state, 0))]
    t0, solves, factorisations = 0.0, 0, {}
    ends = time_steps(scene)
    for t in ends:
        dt = t - t0
        if factorisations.get("dt") != dt:
            factorisations = {"dt": dt}
            effective = (stiffness + (2.0 / dt**2) * mass).tocsr()
        load = gravity + sum(
            (f * k for f, k in zip(loads, load_factor_at(scene, t), strict=True)),
            np.zeros(basis.N),
        )
        load = load + mass @ ((2.0 / dt**2) * u + (2.0 / dt) * v)
        new_u, state, count = solve_with_contact(
            effective, load, contact, state, options.max_active_set, tolerance, factorisations
        )
        solves += count
        state = after_step(contact, state, new_u)
        a_new = 2.0 * (new_u - u - v * dt) / dt**2
        v = v + dt * ((1.0 - gamma) * (a_new if a is None else a) + gamma * a_new)
        a = a_new
        u, t0 = new_u, t
        records.append(block_record(solution(u, state, solves)))
    log.info("FEM %s: %d steps, %d DOFs, %d solves", scene.title, len(ends), basis.N, solves)
    return FemHistory(
        times=np.concatenate([[0.0], ends]),
        displacements=np.array([r[0] for r in records]),
        rotations=np.array([r[1] for r in records]),
        stresses=np.array([r[2] for r in records]),
        final=solution(u, state, solves),
    )
