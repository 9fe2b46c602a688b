"""Apply an accepted step to the blocks: vertices, stress, velocity, totals."""

from __future__ import annotations

import math

import numpy as np

from dda.blocks import BlockSet, moments_kernel
from dda.effects.elastic import Elastic
from dda.jit import compiled, floats, kernel
from dda.kinematics import exact_position, move_points
from dda.solve.integrator import new_velocity, newmark_velocity, step_acceleration


def vertex_displacements(blocks: BlockSet, d: np.ndarray, exact_rotation: bool) -> np.ndarray:
    """(NV, 2) displacement of every vertex for the step ``d`` (with the exact rotation,
    in a run with the kernels, its compiled twin :func:`_moves`)."""
    owner = blocks.vertex_owner
    if exact_rotation and compiled(moves_kernel):
        return moves_kernel(floats(blocks.vertices), floats(blocks.centroid), floats(d), owner)
    moved = move_points(blocks.vertices, blocks.centroid[owner], d[owner], exact_rotation)
    return moved - blocks.vertices


def rotate_stress(stress: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """σ' = R σ Rᵀ for a rotation by ``angle`` (co-rotational stress)."""
    rotated = rotated_stress(np.cos(angle), np.sin(angle), stress[:, 0], stress[:, 1], stress[:, 2])
    return np.column_stack(rotated)


def rotated_stress(c, s, sxx, syy, sxy):
    """(sxx', syy', sxy') of R σ Rᵀ with c = cos, s = sin of the angle, element by element
    (arrays or numbers: the compiled update calls it on numbers)."""
    return (
        c * c * sxx - 2 * c * s * sxy + s * s * syy,
        s * s * sxx + 2 * c * s * sxy + c * c * syy,
        c * s * (sxx - syy) + (c * c - s * s) * sxy,
    )


def apply_step(
    blocks: BlockSet,
    d: np.ndarray,
    dt: float,
    elastic: Elastic,
    static: bool,
    exact_rotation: bool,
    pushed: np.ndarray | None = None,
    gamma: float = 1.0,
    moves: np.ndarray | None = None,
) -> None:
    """Move the blocks by ``d`` (n, 6) in place.

    Velocity: Newmark with β = ½ and ``gamma`` (:mod:`dda.solve.integrator`; γ = 1 is
    Shi's v1 = (2/Δt) D − v0); static: v1 = 0.
    ``pushed``: the part of D that removed overlap found this step
    (dda.contact.push_out), moved but left out of the velocity.
    Stress: σ += E ε, then rotated with the block when the rotation is exact.
    ``moves``: the step's :func:`vertex_displacements`, when the caller has them.
    """
    if moves is None:
        moves = vertex_displacements(blocks, d, exact_rotation)
    if compiled(apply_kernel):
        _apply_compiled(blocks, d, dt, elastic, static, exact_rotation, pushed, gamma, moves)
        return
    old_centroid = blocks.centroid.copy()
    blocks.stress = blocks.stress + elastic.stress_increment(blocks, d)
    if exact_rotation:
        blocks.stress = rotate_stress(blocks.stress, d[:, 2])
    blocks.vertices = blocks.vertices + moves
    blocks.update_moments()
    blocks.displacement = blocks.displacement + (blocks.centroid - old_centroid)
    blocks.rotation = blocks.rotation + d[:, 2]
    moved = d if pushed is None else d - pushed
    if static:
        blocks.velocity = np.zeros_like(blocks.velocity)
    else:
        blocks.velocity, blocks.acceleration = new_velocity(
            moved, blocks.velocity, blocks.acceleration, dt, gamma
        )
        blocks.acceleration[blocks.fixed] = 0.0
    blocks.velocity[blocks.fixed] = 0.0


def _apply_compiled(blocks, d, dt, elastic, static, exact_rotation, pushed, gamma, moves) -> None:
    """:func:`apply_step` in one compiled call (:func:`_apply`); Δσ = E ε stays numpy's
    ``einsum`` (it sums in an order of its own)."""
    d = floats(d)
    moved = d if pushed is None else d - pushed
    (
        blocks.stress, blocks.vertices, blocks.area, blocks.centroid, blocks.ixx, blocks.iyy,
        blocks.ixy, blocks.displacement, blocks.rotation, blocks.velocity, blocks.acceleration,
    ) = apply_kernel(
        floats(blocks.stress + elastic.stress_increment(blocks, d)),
        d,
        floats(moved),
        floats(blocks.vertices),
        floats(moves),
        blocks.offsets.astype(np.int64),
        floats(blocks.centroid),
        floats(blocks.displacement),
        floats(blocks.rotation),
        floats(blocks.velocity),
        floats(blocks.acceleration),
        blocks.fixed.astype(np.bool_),
        float(dt),
        float(gamma),
        bool(static),
        bool(exact_rotation),
    )  # fmt: skip


def _moves(vertices, centroid, d, owner):
    """Compiled :func:`vertex_displacements` with the exact rotation: :func:`move_points`'s
    operations, vertex by vertex, in its order (the same numbers)."""
    moves = np.empty_like(vertices)
    for k in range(vertices.shape[0]):
        i = owner[k]
        cx, cy = centroid[i, 0], centroid[i, 1]
        x, y = _exact_position(
            cx, cy, vertices[k, 0] - cx, vertices[k, 1] - cy, math.cos(d[i, 2]),
            math.sin(d[i, 2]), d[i, 0], d[i, 1], d[i, 3], d[i, 4], d[i, 5],
        )  # fmt: skip
        moves[k, 0], moves[k, 1] = x - vertices[k, 0], y - vertices[k, 1]
    return moves


def _apply(stress, d, moved, vertices, moves, offsets, centroid, displacement, rotation,
           velocity, acceleration, fixed, dt, gamma, static, exact_rotation):  # fmt: skip
    """Compiled :func:`apply_step` from σ + Δσ (``stress``) on: the stress rotated with
    the block, the vertices moved, the moments (:func:`dda.blocks._moments`), the totals,
    and the velocity of ``moved`` (D less the push-out), each as numpy computes it."""
    n = d.shape[0]
    stress = stress.copy()
    if exact_rotation:
        for i in range(n):
            stress[i, 0], stress[i, 1], stress[i, 2] = _rotated_stress(
                math.cos(d[i, 2]), math.sin(d[i, 2]), stress[i, 0], stress[i, 1], stress[i, 2]
            )
    vertices = vertices + moves
    area, new_centroid, ixx, iyy, ixy = moments_kernel(vertices, offsets)
    displacement = displacement + (new_centroid - centroid)
    rotation = rotation + d[:, 2]
    velocity, acceleration = velocity.copy(), acceleration.copy()
    for i in range(n):
        for j in range(6):
            if static:
                velocity[i, j] = 0.0
                continue
            a1 = _step_acceleration(moved[i, j], velocity[i, j], dt)
            a0 = a1 if np.isnan(acceleration[i, j]) else acceleration[i, j]
            velocity[i, j] = _newmark_velocity(velocity[i, j], a0, a1, dt, gamma)
            acceleration[i, j] = 0.0 if fixed[i] else a1
            if fixed[i]:
                velocity[i, j] = 0.0
    return (stress, vertices, area, new_centroid, ixx, iyy, ixy, displacement, rotation,
            velocity, acceleration)  # fmt: skip


# the formulas the numpy code uses, compiled for the kernels below (the same numbers)
_exact_position = kernel(exact_position) or exact_position
_rotated_stress = kernel(rotated_stress) or rotated_stress
_step_acceleration = kernel(step_acceleration) or step_acceleration
_newmark_velocity = kernel(newmark_velocity) or newmark_velocity
moves_kernel = kernel(_moves)
apply_kernel = kernel(_apply)
