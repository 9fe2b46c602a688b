"""The augmented Lagrangian's rate: multiplier updates of a step against the closed form.

One free block pressed on a fixed block through one interface of n contacts
with penalty p, tolerance τ. In the first step of a static run (unloaded, the
velocity zero) the step's matrix holds the block's translation normal to the
interface by the contact springs n p and the static damping term
K = 2 m / Δt² (docs/theory.md §3). The augmented-Lagrangian iteration
λ ← λ + p g (Uzawa's, the paper's eq. 7) then shrinks the penetration by

    ρ = K / (K + n p)

per update: the first solve penetrates g₀ = N / (K + n p) (N the load pressing
the block on the interface), the update puts the multipliers at what the
springs carried, and the next solve leaves ρ of the penetration. The step
stops at the first solve with g ≤ τ: 1 + k solves (Newton iterations, the
contacts staying closed), k = ⌈log(g₀/τ) / log(1/ρ)⌉. The engine's variable
penalty grows p only where a penetration did not shrink below ¼ of the last,
which a rate ρ < ¼ never triggers.

Row ``al_updates``: the Newton iterations of the scene's first step (the scene
run for one step) against 1 + k; its scale is 1 + k, so one solve more or less
is an error of 1/(1 + k).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

import dda
from dda import Scene
from verify.comparison.compare import Row
from verify.comparison.expect import ExpectationError
from verify.fem.interfaces import find_interfaces
from verify.references.block import block_mass, free_block
from verify.references.motion import applied_force


def predicted_solves(scene: Scene) -> tuple[int, float]:
    """(1 + k, ρ) for the scene's first static step (module notes)."""
    c, a = scene.contact, scene.analysis
    if a.mode != "static" or c.method != "augmented-lagrangian" or not c.penalty or not c.tolerance:
        raise ExpectationError(
            f"{scene.source}: al_updates: a static augmented-Lagrangian scene with "
            "[contact] penalty and tolerance written out"
        )
    block = free_block(scene)
    interfaces = [i for i in find_interfaces(scene) if block in i.pair]
    if len(interfaces) != 1 or not hasattr(interfaces[0].line, "coords"):
        raise ExpectationError(f"{scene.source}: al_updates: one straight interface")
    interface = interfaces[0]
    ends = np.asarray(interface.line.coords)
    along = (ends[-1] - ends[0]) / np.linalg.norm(ends[-1] - ends[0])
    pressing = abs(float(applied_force(scene, block) @ np.array([-along[1], along[0]])))
    held = 2.0 * block_mass(scene, block) / a.time_step**2
    springs = interface.contacts * c.penalty
    rate = held / (held + springs)
    first = pressing / (held + springs)
    updates = max(math.ceil(math.log(first / c.tolerance) / math.log(1.0 / rate)), 0)
    return 1 + updates, rate


def al_update_rows(scene: Scene) -> list[Row]:
    """Row ``al_updates`` (module notes): the scene run for one step."""
    predicted, _ = predicted_solves(scene)
    one = replace(scene, analysis=replace(scene.analysis, steps=1, duration=None, save_every=1))
    solves = dda.simulate(one).summary["newton_iterations"]
    name = scene.blocks[free_block(scene)].name
    return [Row("al_updates", name, "solves", float(solves), float(predicted), float(predicted))]
