"""A model that nothing fixed holds: the net load that moves it as a whole.

A model without a fixed block or fixed point, whose outer edges carry
``[[boundary_stresses]]`` (UDEC's ``bound stress``), is held by the balance of its loads
alone. Boundary stresses are prescribed loads: nothing reacts to the part of the loads
they do not balance. A stage that removes blocks removes their weight, not the boundary's
share that carried it: a tunnel's core, whose weight the far field held up, leaves a
net upward force F = W_core, and the whole section accelerates at a = |F| / M, a
drift that grows as ½ a t² and adds to every displacement. :func:`unbalanced_warning`
says so, at the start and after each stage, with the remedy: a fixed base block (a
support takes the difference, as the rock below does). It says so too of a model given
an in-situ field with nothing fixed and no boundary stresses, whose weight then moves it.
"""

from __future__ import annotations

import logging

import numpy as np

from dda.blocks import BlockSet
from dda.effects.base import StepContext
from dda.model import Model

log = logging.getLogger(__name__)

# the net external force over the sum of the blocks' external forces' magnitudes beyond
# which a model that nothing fixed holds moves as a whole (round-off: ~1e-15; the
# tunnel at depth with free outer blocks all round, once its core is excavated: 8e-4)
UNBALANCED = 1e-6
# the effects whose forces load the model from outside (the rest act between blocks,
# on a block's own strain, or hold it: inertia, elasticity, bolts, fixed points)
EXTERNAL = frozenset({"gravity", "loads", "boundary_stresses", "water"})


def net_load(model: Model, blocks: BlockSet, ctx: StepContext) -> tuple[np.ndarray, float]:
    """(Σ F, Σ |F_i|): the net force and moment (3,: Fx, Fy and M about the free blocks'
    centre of mass, M = Σ M_i + (c_i − C) × F_i, M_i a block's moment about its centroid)
    of the external effects on the free blocks in the step ``ctx``, and the sum of the
    blocks' force magnitudes and moments over the model's size (the scale)."""
    free = ~blocks.fixed
    net, scale, size = np.zeros(3), 0.0, max(model_size(blocks), 1e-300)
    _, arm = _masses_and_arms(model, blocks)
    for effect in model.effects:
        if effect.name not in EXTERNAL:
            continue
        forces = effect.forces(blocks, ctx)
        if forces is None:
            continue
        translation = forces[free, 0:2]
        net[:2] += translation.sum(axis=0)
        turning = arm[:, 0] * translation[:, 1] - arm[:, 1] * translation[:, 0]
        net[2] += float(np.sum(forces[free, 2] + turning))
        scale += float(np.hypot(translation[:, 0], translation[:, 1]).sum())
        scale += float(np.abs(forces[free, 2]).sum()) / size
    return net, scale


def turning_inertia(model: Model, blocks: BlockSet) -> float:
    """Σ ρ_i (I_xx,i + I_yy,i) + m_i |c_i − C|²: the free blocks' moment of inertia about
    their centre of mass (I about each centroid, of the block's mass area)."""
    free = ~blocks.fixed
    density = model.material_density[blocks.material[free]] * blocks.density_ratio[free]
    masses, arm = _masses_and_arms(model, blocks)
    own = density * (blocks.ixx[free] + blocks.iyy[free])
    return float(np.sum(own + masses * np.sum(arm * arm, axis=1)))


def _masses_and_arms(model: Model, blocks: BlockSet) -> tuple[np.ndarray, np.ndarray]:
    """(m_i, c_i − C) of the free blocks, C their centre of mass."""
    free = ~blocks.fixed
    masses = blocks.masses(model.material_density)[free]
    centre = masses @ blocks.centroid[free] / max(masses.sum(), 1e-300)
    return masses, blocks.centroid[free] - centre


def model_size(blocks: BlockSet) -> float:
    """The diagonal of the free blocks' bounding box (the arm of a moment's scale)."""
    points = blocks.vertices[np.isin(blocks.vertex_owner, np.flatnonzero(~blocks.fixed))]
    return float(np.hypot(*(points.max(axis=0) - points.min(axis=0)))) if len(points) else 0.0


def boundary_loaded(model: Model, ctx: StepContext) -> bool:
    """True when boundary stresses load the model in the step ``ctx``."""
    effect = next((e for e in model.effects if e.name == "boundary_stresses"), None)
    return effect is not None and bool(effect.factors(ctx.time).any())


def meant_to_stand(model: Model, blocks: BlockSet, ctx: StepContext) -> bool:
    """True when nothing fixed holds the model (no fixed block, no fixed point) although
    it is meant to stand: boundary stresses load it in the step ``ctx``, or it is given
    an in-situ field (the stress it stands in, in the ground)."""
    if blocks.fixed.any() or any(e.name == "fixed_points" for e in model.effects):
        return False
    return boundary_loaded(model, ctx) or model.scene.in_situ is not None


def unbalanced_warning(
    model: Model,
    blocks: BlockSet,
    ctx: StepContext,
    when: str,
    remaining: float,
    said: tuple[float, ...] = (0.0, 0.0, 0.0),
) -> tuple[str, tuple[float, ...]] | None:
    """(the sentence, the net force and moment) when nothing fixed holds a model meant to
    stand (:func:`meant_to_stand`) and its loads do not balance (a net force beyond
    :data:`UNBALANCED` of the scale, or a net moment beyond it times the model's size),
    unless the net force and moment are the ones ``said`` already; else None. ``when``:
    "at the start", "after stages[k]"; ``remaining``: the run's time left (s), for the
    drift: ½ a t² in a dynamic run, ½ a Δt t in a static one (½ a Δt² a step, each from
    rest)."""
    if not meant_to_stand(model, blocks, ctx):
        return None
    net, scale = net_load(model, blocks, ctx)
    arm = max(model_size(blocks), 1e-300)
    force, moment = float(np.hypot(*net[:2])), float(net[2])
    if scale == 0.0 or (force <= UNBALANCED * scale and abs(moment) <= UNBALANCED * scale * arm):
        return None
    change = net - np.asarray(said)
    if np.hypot(*change[:2]) <= UNBALANCED * scale and abs(change[2]) <= UNBALANCED * scale * arm:
        return None  # said already, at the start or after an earlier stage
    units = model.scene.units
    if boundary_loaded(model, ctx):
        why = (
            "Boundary stresses are prescribed loads: they do not follow what a stage removes "
            "(the excavated blocks' weight was theirs to carry). Fix a block along the "
            "model's base (its support takes the difference), or balance the loads"
        )
    else:
        why = (
            "No block is fixed and no [[boundary_stresses]] load its outer edges. Give them "
            "the in-situ field's traction as [[boundary_stresses]] and rest the model on a "
            'fixed block along its base (docs/engineering.md, "A tunnel at depth")'
        )
    motion = []
    if force > UNBALANCED * scale:
        motion.append(_drift(model, blocks, ctx, net, force, remaining))
    if abs(moment) > UNBALANCED * scale * arm:
        turning = moment / max(turning_inertia(model, blocks), 1e-300)
        motion.append(
            f"a net moment {moment:.4g} {units.force}·{units.length} about its centre of mass "
            f"turns it at {turning:.3g} rad/{units.time}²"
        )
    sentence = (
        f"nothing fixed holds the model and its loads do not balance {when}: "
        f"{'; '.join(motion)}, a motion that adds to every displacement. {why}"
    )
    return sentence, tuple(float(v) for v in net)


def _drift(model: Model, blocks: BlockSet, ctx: StepContext, net, force: float,
           remaining: float) -> str:  # fmt: skip
    """ "a net force (Fx, Fy) N moves it as a whole at a m/s² (drift by the run's end)"."""
    mass = float(blocks.masses(model.material_density).sum())
    acceleration = force / mass
    units = model.scene.units
    drift = ""
    if model.water is not None:  # the uplift changes as the model moves: no drift to extrapolate
        drift = " (the water's uplift changes as it moves)"
    elif np.isfinite(remaining) and remaining > 0.0:  # a static run starts each step at rest
        moved = 0.5 * acceleration * (ctx.dt if ctx.static else remaining) * remaining
        drift = f" ({moved:.3g} {units.length} by the run's end)"
    return (
        f"a net force ({net[0]:.4g}, {net[1]:.4g}) {units.force} moves it as a whole at "
        f"{acceleration:.3g} {units.length}/{units.time}²{drift}"
    )


def note_unbalanced(run, when: str) -> None:
    """Say :func:`unbalanced_warning` of ``run`` (dda.run.simulation's run) for its next
    step, at once and among the summary's warnings (``run.unbalanced``); a net force said
    already (``run.unbalanced_force``) is not said again."""
    ctx = StepContext(dt=run.dt, time=run.time + run.dt, step=run.step + 1, static=run.model.static)
    left = run.remaining()
    if not np.isfinite(left):  # a run of ``steps``: as long as its steps are not cut
        left = (run.model.steps - run.step) * run.model.max_time_step
    found = unbalanced_warning(run.model, run.blocks, ctx, when, left, run.unbalanced_force)
    if found is not None:
        sentence, run.unbalanced_force = found
        log.warning(sentence)
        run.unbalanced.append(sentence)
