"""Apply an accepted step to the blocks: vertices, stress, velocity, totals."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.effects.elastic import Elastic
from dda.kinematics import move_points
from dda.solve.integrator import new_velocity


def vertex_displacements(blocks: BlockSet, d: np.ndarray, exact_rotation: bool) -> np.ndarray:
    """(NV, 2) displacement of every vertex for the step ``d``."""
    owner = blocks.vertex_owner
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
    old_centroid = blocks.centroid.copy()
    blocks.stress = blocks.stress + elastic.stress_increment(blocks, d)
    if exact_rotation:
        blocks.stress = rotate_stress(blocks.stress, d[:, 2])
    if moves is None:
        moves = vertex_displacements(blocks, d, exact_rotation)
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
