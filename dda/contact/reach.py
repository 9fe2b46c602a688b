"""How far a step's contact search looks: as far as the blocks can move in that step.

Shi's search distance is ``SEARCH_FACTOR`` (2.5) times the largest displacement
a step may make, u_max = ``max_displacement_ratio`` × half the model's extent:
two blocks that move towards each other by up to u_max each are found before
they touch. On a large model that is more than a block (0.52 m on the
100 × 100 wall of unit blocks, a search distance of 1.3 m), and every vertex
that close to another block's edge line becomes an open contact that each
linear solve of the step then carries (the wall's contact list grew from
40,000 to 120,000 as it rang).

The run instead bounds the coming step's vertex displacements by a reach r
and searches for gaps up to 2.5 r, with

    r = min(u_max, max(GROWTH × u_last, FLOOR × u_max)),

u_last the largest vertex displacement of the last step. A step that moves
some vertex further than r (a block released, an impact, a stage) is redone
with the same Δt after a search with Shi's full distance: nothing that can
touch within a step is missed, as with Shi's rule. Shi's distance also keeps
its other roles (the deepest penetration a new contact may have, the block
pairs of K's pattern, the broad phase's kept list).
"""

from __future__ import annotations

import numpy as np

GROWTH = 4.0  # the next step may move this many times as far as the last one
FLOOR = 1.0 / 64.0  # of the largest displacement a step may make: the smallest reach


def next_reach(moved: float, allowed: float) -> float:
    """r = min(u_max, max(GROWTH u_last, FLOOR u_max)) for ``moved`` = u_last and
    ``allowed`` = u_max (m)."""
    return min(allowed, max(GROWTH * moved, FLOOR * allowed))


def beyond(moved: float, reach: float, allowed: float) -> bool:
    """True when a step moved some vertex further than the reach its search assumed
    (only possible while the reach is below u_max: above it the step is cut instead)."""
    return reach < allowed and moved > reach * (1.0 + 1e-9)


def coming_motion(blocks, dt: float, gravity) -> np.ndarray:
    """(N, 2) each vertex's motion over a coming step of ``dt`` as its block would move
    free: its rigid velocity, v + ω × (x − c), times Δt, and ½ g Δt² on the free
    blocks. The contact search reads it for which corners meet head-on within the step
    and which edge of a corner met exactly a vertex is about to enter
    (:func:`dda.contact.narrow.detect`)."""
    owner = blocks.vertex_owner
    velocity, arm = blocks.velocity[owner], blocks.vertices - blocks.centroid[owner]
    motion = np.empty_like(blocks.vertices)
    motion[:, 0] = (velocity[:, 0] - velocity[:, 2] * arm[:, 1]) * dt
    motion[:, 1] = (velocity[:, 1] + velocity[:, 2] * arm[:, 0]) * dt
    free = ~blocks.fixed[owner]
    motion[free] += 0.5 * dt * dt * np.asarray(gravity, float)
    return motion
