"""Apply an accepted step to the blocks: vertices, stress, velocity, totals."""

from __future__ import annotations

import math

import numpy as np

from dda.blocks import BlockSet, moments_kernel
from dda.effects.elastic import Elastic
from dda.jit import compiled, kernel
from dda.kinematics import move_points
from dda.solve.integrator import new_velocity


def vertex_displacements(blocks: BlockSet, d: np.ndarray, exact_rotation: bool) -> np.ndarray:
    """(NV, 2) displacement of every vertex for the step ``d`` (with the exact rotation,
    in a run with the kernels, its compiled twin :func:`_moves`)."""
    owner = blocks.vertex_owner
    if exact_rotation and compiled(moves_kernel):
        return moves_kernel(_floats(blocks.vertices), _floats(blocks.centroid), _floats(d), owner)
    moved = move_points(blocks.vertices, blocks.centroid[owner], d[owner], exact_rotation)
    return moved - blocks.vertices


def rotate_stress(stress: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """σ' = R σ Rᵀ for a rotation by ``angle`` (co-rotational stress)."""
    c, s = np.cos(angle), np.sin(angle)
    sxx, syy, sxy = stress[:, 0], stress[:, 1], stress[:, 2]
    return np.column_stack(
        [
            c * c * sxx - 2 * c * s * sxy + s * s * syy,
            s * s * sxx + 2 * c * s * sxy + c * c * syy,
            c * s * (sxx - syy) + (c * c - s * s) * sxy,
        ]
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


def _floats(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _apply_compiled(blocks, d, dt, elastic, static, exact_rotation, pushed, gamma, moves) -> None:
    """:func:`apply_step` in one compiled call (:func:`_apply`); Δσ = E ε stays numpy's
    ``einsum`` (it sums in an order of its own)."""
    d = _floats(d)
    moved = d if pushed is None else d - pushed
    (
        blocks.stress, blocks.vertices, blocks.area, blocks.centroid, blocks.ixx, blocks.iyy,
        blocks.ixy, blocks.displacement, blocks.rotation, blocks.velocity, blocks.acceleration,
    ) = apply_kernel(
        _floats(blocks.stress + elastic.stress_increment(blocks, d)),
        d,
        _floats(moved),
        _floats(blocks.vertices),
        _floats(moves),
        blocks.offsets.astype(np.int64),
        _floats(blocks.centroid),
        _floats(blocks.displacement),
        _floats(blocks.rotation),
        _floats(blocks.velocity),
        _floats(blocks.acceleration),
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
        relx, rely = vertices[k, 0] - cx, vertices[k, 1] - cy
        c, s = math.cos(d[i, 2]), math.sin(d[i, 2])
        rx = c * relx - s * rely
        ry = s * relx + c * rely
        ex, ey, g = d[i, 3], d[i, 4], d[i, 5] / 2.0
        sx = ex * relx + g * rely
        sy = g * relx + ey * rely
        moves[k, 0] = (cx + d[i, 0] + rx + sx) - vertices[k, 0]
        moves[k, 1] = (cy + d[i, 1] + ry + sy) - vertices[k, 1]
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
            c, s = math.cos(d[i, 2]), math.sin(d[i, 2])
            sxx, syy, sxy = stress[i, 0], stress[i, 1], stress[i, 2]
            stress[i, 0] = c * c * sxx - 2 * c * s * sxy + s * s * syy
            stress[i, 1] = s * s * sxx + 2 * c * s * sxy + c * c * syy
            stress[i, 2] = c * s * (sxx - syy) + (c * c - s * s) * sxy
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
            a1 = 2.0 * (moved[i, j] - velocity[i, j] * dt) / (dt * dt)
            a0 = a1 if np.isnan(acceleration[i, j]) else acceleration[i, j]
            velocity[i, j] = velocity[i, j] + dt * ((1.0 - gamma) * a0 + gamma * a1)
            acceleration[i, j] = 0.0 if fixed[i] else a1
            if fixed[i]:
                velocity[i, j] = 0.0
    return (stress, vertices, area, new_centroid, ixx, iyy, ixy, displacement, rotation,
            velocity, acceleration)  # fmt: skip


moves_kernel = kernel(_moves)
apply_kernel = kernel(_apply)
