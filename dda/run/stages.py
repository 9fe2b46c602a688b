"""Staged excavation: at given times, remove blocks, install bolts and divide the
strengths; the run goes on.

A stage takes effect at the end of the step that reaches its time (the time
loop shortens that step to end there exactly). Removing blocks makes a new
block set without them, as fracture makes one with fragments
(:func:`dda.fracture.fragments.replace_blocks`): the effects and the
measurement points follow their blocks to their new rows, and the contacts
between the blocks that stay keep their history (state, multipliers, shear
force: they are matched by their keys, which do not depend on rows). The
energy of what was removed leaves the account (``summary["excavated_energy"]``).
Then the stage's bolts are installed where their points are given, in the
blocks the scene found for them (or, after a fracture, the fragment nearest
to the point); an end that lies outside its block then (the block moved or
broke since the scene was drawn) is said, among the run's warnings. A stage's
``strength_factor`` F divides the scene's joint strengths from then on
(tan φ / F, c / F, T / F; :class:`dda.contact.joints.JointTable`), and with
``intact`` the breakable materials' Mohr–Coulomb strengths the same way; a
later stage's F replaces it. A contact whose shear force exceeds its reduced
bound is brought back to it by the contact law at the next step: it slips.
"""

from __future__ import annotations

import logging

import numpy as np
import shapely

from dda.blocks import BlockSet
from dda.contact.contact_set import carried_over
from dda.fracture.effect import Strength
from dda.fracture.fragments import replace_blocks
from dda.run.floating import note_unbalanced
from dda.scene.stage_plan import StagePlan

log = logging.getLogger(__name__)

TIME_TOLERANCE = 1e-9  # of the largest time step: a step ending this close reaches the stage
# a bolt end this fraction of its length or more outside the block it is anchored in is said
OUTSIDE = 1e-4


def apply_due_stages(run) -> None:
    """Apply every stage whose time the run has reached (``run``: dda.run.simulation's run)."""
    plan = run.model.stages
    tolerance = TIME_TOLERANCE * run.model.max_time_step
    applied = []
    while run.stages_done < len(plan.times) and run.time >= plan.times[run.stages_done] - tolerance:
        k = run.stages_done
        applied.append(k)
        if len(plan.removed[k]):
            _remove(run, plan.removed[k])
        if len(plan.bolts[k]):
            _install(run, plan, plan.bolts[k])
        run.stages_done += 1
        if not np.isnan(plan.strength_factors[k]):
            set_strengths(run)
        log.info("stage %d applied at t = %.6g", k + 1, run.time)
    if applied:  # once all of this step's stages are in (each may add or take loads)
        names = ", ".join(f"stages[{k}]" for k in applied)
        note_unbalanced(run, f"after {names} (t = {run.shown_time:.6g} s)")


def set_strengths(run) -> None:
    """Give the run the strengths in force after its ``stages_done`` stages (also for a
    run resumed from a checkpoint, whose model is rebuilt with the scene's own)."""
    factor, intact = run.model.stages.strength_after(run.stages_done)
    if run.model.contact is not None:
        run.model.contact.joints.factor = factor
    fracture = run.model.fracture
    if fracture is not None:
        given = Strength.from_scene(run.model.scene)
        fracture.strength = _divided(given, factor) if intact else given
    log.info("strengths divided by %g (intact rock: %s)", factor, "yes" if intact else "no")


def _divided(strength: Strength, factor: float) -> Strength:
    """c / F, atan(tan φ / F), T / F of every material (NaN, unbreakable, stays NaN)."""
    return Strength(
        cohesion=strength.cohesion / factor,
        friction_angle=np.arctan(np.tan(strength.friction_angle) / factor),
        tensile_strength=strength.tensile_strength / factor,
    )


def _remove(run, ids: np.ndarray) -> None:
    old = run.blocks
    gone = np.isin(old.origin, ids)
    before = run.energy.measure(old, run.contacts).total
    keep = np.flatnonzero(~gone)
    new = replace_blocks(old, [], gone)
    for effect in run.model.effects:
        effect.on_blocks_replaced(old, new, keep)
    if run.probes is not None:
        run.probes.on_blocks_replaced(old, new, keep)
    run.contacts = carried_over(run.contacts, old, new, np.where(gone, -1, np.cumsum(~gone) - 1))
    run.blocks = new
    run.excavated_energy += before - run.energy.measure(new, run.contacts).total
    log.info("removed %d block(s)", int(gone.sum()))


def _install(run, plan: StagePlan, bolts: np.ndarray) -> None:
    first = bolts - (len(run.model.bolts) - len(plan.hosts))  # rows of plan.hosts / points
    points = plan.points[first]
    rows = np.array(
        [
            [_holder(run.blocks, plan.hosts[k, e], points[q, e]) for e in (0, 1)]
            for q, k in enumerate(first)
        ]  # fmt: skip
    )
    run.model.bolts.install(bolts, rows, points[:, 0], points[:, 1])
    log.info("installed %d bolt(s)", len(bolts))
    unit = run.model.scene.units.length
    said = _ends_outside(
        run.blocks, run.model.bolts.names, bolts, rows, points, run.shown_time, unit
    )
    if said is not None:
        log.warning(said)
        run.misplaced_bolts.append(said)


def _ends_outside(
    blocks: BlockSet, names, bolts, rows, points, time: float, unit: str
) -> str | None:
    """The sentence when a bolt a stage installs has an end outside the block it is
    anchored in by more than ``OUTSIDE`` of its length (a crack's gap, or ground that
    has moved it since it was drawn): the anchor then sits off the rock, as given."""
    found = []
    for q, bolt in enumerate(bolts):
        length = float(np.linalg.norm(points[q, 1] - points[q, 0]))
        for e, end in enumerate(("start", "end")):
            host = shapely.Polygon(blocks.polygon(int(rows[q, e])))
            gap = float(host.distance(shapely.Point(points[q, e])))
            if gap > OUTSIDE * length:
                name = blocks.names[int(rows[q, e])]
                found.append(f"'{names[bolt]}' {end} {gap:.3g} {unit} outside '{name}'")
    if not found:
        return None
    return (
        f"at t = {time:.6g} a stage installed bolt ends outside the blocks they are anchored "
        f"in ({'; '.join(found[:5])}{'; ...' if len(found) > 5 else ''}): the blocks have "
        "moved or broken since the scene was drawn, and the bolt pulls on the nearest one "
        "from off the rock; give the ends where the rock is at the stage's time"
    )


def _holder(blocks: BlockSet, origin: int, point: np.ndarray) -> int:
    """The row of the block of origin ``origin`` (or its fragment) nearest to ``point``."""
    rows = np.flatnonzero(blocks.origin == origin)
    if len(rows) == 1:
        return int(rows[0])
    polygons = [shapely.Polygon(blocks.polygon(r)) for r in rows]
    return int(rows[int(np.argmin(shapely.distance(polygons, shapely.Point(point))))])
