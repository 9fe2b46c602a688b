"""Named faults put into the engine one at a time, to prove that `dda verify` can fail.

Each fault is applied with pytest's ``monkeypatch`` (or any object with its
``setattr``) to the engine's internals, never to the scene and never to
``verify``: the FEM side keeps solving the scene as written, the engine
computes something else. The faults:

``young_x1.05``, ``young_x0.97``
    every material's elasticity matrix scaled (E x 1.05, E x 0.97);
``poisson_zero``
    every elasticity matrix rebuilt with ν = 0;
``penalty_x0.5``
    the contact penalty the engine starts from halved (the scene's
    ``[contact] penalty`` or its default);
``gravity_dropped``
    no gravity on the scene's last block;
``gravity_one_density``
    gravity computed with the first material's density for every block;
``stress_x1.05``
    the stresses the engine reports in its frames scaled by 1.05;
``friction_plus2``
    2° added to every joint friction angle above zero;
``cohesion_dropped``
    every joint's cohesion left out of its friction bound;
``cohesion_kept``
    a bond that breaks keeps its cohesion (residual cohesion = peak: a brittle joint
    made ductile);
``tension_dropped``
    every joint's tensile strength left out (a bonded joint holds no tension);
``inertia_x0.95``
    the inertia term 2M/Δt² of the step's matrix taken as 1.9M/Δt²;
``velocity_x0.95``
    the velocity update with 1.9 D/Δt instead of Shi's 2 D/Δt;
``stress_replaced``, ``stress_twice``
    a block's stress replaced by the step's increment instead of accumulated,
    or the increment added twice;
``plane_swapped``
    plane stress and plane strain swapped in the elasticity matrices;
``friction_sin``
    the friction bound built with sin φ instead of tan φ;
``shear_penalty_x0.1``
    the shear contact penalty p·shear_ratio divided by 10;
``shear_reset``
    the shear force a contact carries reset to zero at the end of every step;
``gap_offset``
    every contact's penetration measured 10⁻⁶ of the model's half-size deeper;
``load_at_centroid``, ``spring_at_centroid``
    point loads, fixed-point springs acting at their block's centroid instead of
    at their point;
``al_halved``, ``al_wrong_sign``
    the augmented-Lagrangian multiplier update λ ← λ + p g with p/2, or with −p;
``rotation_linearised``
    the blocks' vertices moved by Shi's first-order map x + T D instead of the
    exact rotation;
``stress_rotated_backwards``
    the stress turned with the block by −r₀ instead of r₀;
``pushout_in_velocity``
    the displacement that removes an overlap found at a new contact
    (dda.contact.push_out, a rarely run correction) counted in the velocity;
``children_unstressed``
    the pieces of a broken block start unstressed instead of with its stress;
``fracture_slope_root``
    the fracture criterion's slope N = tan²(45° + φ/2) taken as tan(45° + φ/2);
``tension_cutoff_doubled``
    the fracture criterion's tensile strength T0 taken as 2 T0;
``crack_planes_complement``
    the shear cracks cut at ±(45° + φ/2) to σ1 instead of ±(45° − φ/2).

``UNCAUGHT`` lists the faults no verification case catches yet (none now), with
the reason in docs/verification.md; they are not in ``FAULTS`` (which the tests
hold every case to).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

import dda.contact.law as contact_law
import dda.fracture.criterion as criterion
import dda.fracture.effect as fracture_effect
import dda.fracture.fragments as fragments
import dda.run.simulation as simulation
import dda.solve.step as step
import dda.solve.update as update
from dda.effects.elastic import elasticity_matrices
from dda.effects.fixed_points import FixedPoints
from dda.effects.gravity import Gravity
from dda.effects.loads import PointLoads
from dda.kinematics import displacement_matrices
from dda.model import Model


def _scale_young(factor: float) -> Callable[[Model], None]:
    def fault(model: Model) -> None:
        model.elastic.material_elasticity = model.elastic.material_elasticity * factor

    return fault


def _poisson_zero(model: Model) -> None:
    materials = list(model.scene.materials.values())
    young = np.array([m.young for m in materials])
    model.elastic.material_elasticity = elasticity_matrices(
        young, np.zeros(len(materials)), model.scene.analysis.plane
    )


def _half_penalty(model: Model) -> None:
    if model.contact is not None:
        model.contact.initial_penalty *= 0.5


def _friction_plus2(model: Model) -> None:
    if model.contact is None:
        return
    joints = model.contact.joints
    for name in ("tan_friction", "tan_residual"):  # the peak and the residual angle
        angle = np.arctan(getattr(joints, name))
        setattr(joints, name, np.where(angle > 0, np.tan(angle + np.radians(2.0)), 0.0))


def _drop_cohesion(model: Model) -> None:
    if model.contact is not None:
        model.contact.joints.cohesion = np.zeros_like(model.contact.joints.cohesion)


def _keep_cohesion(model: Model) -> None:
    if model.contact is not None:
        joints = model.contact.joints
        joints.residual_cohesion = joints.cohesion.copy()


def _drop_tension(model: Model) -> None:
    if model.contact is not None:
        model.contact.joints.tensile = np.zeros_like(model.contact.joints.tensile)


def _drop_gravity_on_last_block(model: Model) -> None:
    name = model.scene.blocks[-1].name
    for effect in model.effects:
        if isinstance(effect, Gravity):
            original = effect.forces

            def forces(blocks, ctx, original=original):
                f = original(blocks, ctx)
                f[[k for k, n in enumerate(blocks.names) if n == name]] = 0.0
                return f

            effect.forces = forces


def _gravity_with_one_density(model: Model) -> None:
    for effect in model.effects:
        if isinstance(effect, Gravity):
            density = effect.material_density
            effect.material_density = np.full_like(density, density[0])


def _scale_inertia(model: Model) -> None:
    original = model.inertia.stiffness
    model.inertia.stiffness = lambda blocks, ctx: 0.95 * original(blocks, ctx)


def _stress_replaced(model: Model) -> None:
    original = model.elastic.stress_increment
    model.elastic.stress_increment = lambda blocks, d: original(blocks, d) - blocks.stress


def _stress_twice(model: Model) -> None:
    original = model.elastic.stress_increment
    model.elastic.stress_increment = lambda blocks, d: 2.0 * original(blocks, d)


def _plane_swapped(model: Model) -> None:
    materials = list(model.scene.materials.values())
    other = "stress" if model.scene.analysis.plane == "strain" else "strain"
    model.elastic.material_elasticity = elasticity_matrices(
        np.array([m.young for m in materials]), np.array([m.poisson for m in materials]), other
    )


def _friction_sin(model: Model) -> None:
    if model.contact is not None:
        joints = model.contact.joints
        joints.tan_friction = np.sin(np.arctan(joints.tan_friction))
        joints.tan_residual = np.sin(np.arctan(joints.tan_residual))


def _shear_penalty_tenth(model: Model) -> None:
    if model.contact is not None:
        law = model.contact.law
        model.contact.law = dataclasses.replace(law, shear_ratio=law.shear_ratio / 10.0)


def _at_centroid(effect, blocks) -> np.ndarray:
    """T at the centroid of each point's block: the point's force or spring acts there."""
    rows = effect.points.rows
    return displacement_matrices(blocks.centroid[rows], blocks.centroid[rows])


def _load_at_centroid(model: Model) -> None:
    for effect in model.effects:
        if isinstance(effect, PointLoads):

            def forces(blocks, ctx, effect=effect):
                per_load = np.einsum(
                    "mkr,mk->mr", _at_centroid(effect, blocks), effect.current_forces(ctx.time)
                )
                f = np.zeros((blocks.count, 6))
                np.add.at(f, effect.points.rows, per_load)
                return f

            effect.forces = forces


def _spring_at_centroid(model: Model) -> None:
    for effect in model.effects:
        if isinstance(effect, FixedPoints):
            effect._matrices = lambda blocks, effect=effect: _at_centroid(effect, blocks)


MODEL_FAULTS: dict[str, Callable[[Model], None]] = {
    "young_x1.05": _scale_young(1.05),
    "young_x0.97": _scale_young(0.97),
    "poisson_zero": _poisson_zero,
    "penalty_x0.5": _half_penalty,
    "gravity_dropped": _drop_gravity_on_last_block,
    "gravity_one_density": _gravity_with_one_density,
    "friction_plus2": _friction_plus2,
    "cohesion_dropped": _drop_cohesion,
    "cohesion_kept": _keep_cohesion,
    "tension_dropped": _drop_tension,
    "inertia_x0.95": _scale_inertia,
    "stress_replaced": _stress_replaced,
    "stress_twice": _stress_twice,
    "plane_swapped": _plane_swapped,
    "friction_sin": _friction_sin,
    "shear_penalty_x0.1": _shear_penalty_tenth,
    "load_at_centroid": _load_at_centroid,
    "spring_at_centroid": _spring_at_centroid,
}


def _scaled_frame(monkeypatch) -> None:
    make_frame = simulation.make_frame

    def scaled_frame(*args, **kwargs):
        frame = make_frame(*args, **kwargs)
        return dataclasses.replace(frame, stresses=frame.stresses * 1.05)

    monkeypatch.setattr(simulation, "make_frame", scaled_frame)


def _velocity_scaled(monkeypatch) -> None:
    new_velocity = update.new_velocity

    def scaled(d, velocity, acceleration, dt, gamma):
        return new_velocity(0.95 * d, velocity, acceleration, dt, gamma)

    monkeypatch.setattr(update, "new_velocity", scaled)
    monkeypatch.setattr(update, "apply_kernel", None)  # its compiled twin has the fault too


def _shear_reset(monkeypatch) -> None:
    record = contact_law.record

    def forgetting(contacts, *args, **kwargs):
        record(contacts, *args, **kwargs)
        contacts.shear_multiplier = np.zeros_like(contacts.shear_multiplier)

    monkeypatch.setattr(contact_law, "record", forgetting)


def _gap_offset(monkeypatch) -> None:
    contact_rows = step.contact_rows

    def deeper(blocks, contacts):
        rows = contact_rows(blocks, contacts)
        size = float(np.ptp(blocks.vertices, axis=0).max()) / 2.0
        rows.penetration = rows.penetration + 1e-6 * size
        return rows

    monkeypatch.setattr(step, "contact_rows", deeper)


def _augment_with(factor: float):
    """dda.contact.law._augment with λ ← λ + factor · p g (and λt ← λt + factor · ps s)."""

    def augment(contacts, terms, g, s, previous_g, law):
        tolerance = law.tolerance
        trial_n = terms.normal_trial(g)
        elastic = trial_n >= -terms.tension
        found_deep = contacts.fresh & (contacts.penetration > tolerance)
        far = elastic & (np.abs(g) > tolerance) & ~found_deep
        stuck = (np.abs(terms.shear_trial(s)) < terms.bound) & (terms.shear_penalty > 0.0)
        slid = stuck & (np.abs(s) > tolerance)
        faulty_n = terms.normal_base + factor * terms.penalty * g
        faulty_t = terms.shear_base + factor * terms.shear_penalty * s
        contacts.normal_multiplier = np.where(
            elastic, np.where(far, np.maximum(faulty_n, -terms.tension), terms.normal_base), 0.0
        )
        contacts.shear_multiplier = np.where(slid, faulty_t, contacts.shear_multiplier)
        if previous_g is not None:
            slow = far & (np.abs(g) > law.shrink_target * np.abs(previous_g))
            slow &= contacts.penalty < law.max_penalty
            contacts.penalty = np.where(
                slow,
                np.minimum(contacts.penalty * law.penalty_growth, law.max_penalty),
                contacts.penalty,
            )
        violation = max(
            float(np.max(np.abs(g[elastic]), initial=0.0)),
            float(np.max(np.abs(s[stuck]), initial=0.0)),
        )
        return int(np.count_nonzero(far | slid)), violation

    def patch(monkeypatch) -> None:
        monkeypatch.setattr(contact_law, "_augment", augment)

    return patch


def _rotation_linearised(monkeypatch) -> None:
    move_points = update.move_points

    def linear(points, centroids, d, exact_rotation=True):
        return move_points(points, centroids, d, False)

    monkeypatch.setattr(update, "move_points", linear)
    monkeypatch.setattr(update, "moves_kernel", None)  # its compiled twin has the fault too


def _stress_rotated_backwards(monkeypatch) -> None:
    rotate_stress = update.rotate_stress

    def backwards(stress, angle):
        return rotate_stress(stress, -angle)

    monkeypatch.setattr(update, "rotate_stress", backwards)
    monkeypatch.setattr(update, "apply_kernel", None)  # its compiled twin has the fault too


def _pushout_in_velocity(monkeypatch) -> None:
    apply_step = simulation.apply_step

    def counted(blocks, d, dt, elastic, static, exact_rotation, pushed=None, gamma=1.0, **more):
        apply_step(blocks, d, dt, elastic, static, exact_rotation, None, gamma, **more)

    monkeypatch.setattr(simulation, "apply_step", counted)


def _children_unstressed(monkeypatch) -> None:
    inherited = fragments.children_state

    def unstressed(velocity, parent_centroid, parent_stress, centroids):
        motion, stress = inherited(velocity, parent_centroid, parent_stress, centroids)
        return motion, np.zeros_like(stress)

    monkeypatch.setattr(fragments, "children_state", unstressed)


def _fracture_slope_root(monkeypatch) -> None:
    strength_numbers = criterion.strength_numbers

    def root_slope(cohesion, friction_angle, tensile_strength):
        n_phi, c0, _ = strength_numbers(cohesion, friction_angle, tensile_strength)
        n_root = np.sqrt(n_phi)
        return n_root, c0, -c0 + np.asarray(tensile_strength, dtype=float) * n_root

    monkeypatch.setattr(criterion, "strength_numbers", root_slope)


def _tension_cutoff_doubled(monkeypatch) -> None:
    evaluate = fracture_effect.evaluate

    def doubled(stress, cohesion, friction_angle, tensile_strength):
        return evaluate(stress, cohesion, friction_angle, 2.0 * np.asarray(tensile_strength))

    monkeypatch.setattr(fracture_effect, "evaluate", doubled)


def _crack_planes_complement(monkeypatch) -> None:
    plane_directions = criterion.plane_directions

    def complement(mode, angle1, friction_angle):  # π/4 − (−φ)/2 = π/4 + φ/2
        return plane_directions(mode, angle1, -np.asarray(friction_angle, dtype=float))

    monkeypatch.setattr(criterion, "plane_directions", complement)


# faults patched into the engine's modules (not into a built model)
ENGINE_FAULTS: dict[str, Callable[[object], None]] = {
    "stress_x1.05": _scaled_frame,
    "velocity_x0.95": _velocity_scaled,
    "shear_reset": _shear_reset,
    "gap_offset": _gap_offset,
    "al_halved": _augment_with(0.5),
    "al_wrong_sign": _augment_with(-1.0),
    "rotation_linearised": _rotation_linearised,
    "stress_rotated_backwards": _stress_rotated_backwards,
    "pushout_in_velocity": _pushout_in_velocity,
    "children_unstressed": _children_unstressed,
    "fracture_slope_root": _fracture_slope_root,
    "tension_cutoff_doubled": _tension_cutoff_doubled,
    "crack_planes_complement": _crack_planes_complement,
}
# faults no verification case catches yet (docs/verification.md would say why): none
UNCAUGHT: tuple[str, ...] = ()
FAULTS = tuple(f for f in (*MODEL_FAULTS, *ENGINE_FAULTS) if f not in UNCAUGHT)


def apply_fault(monkeypatch, name: str) -> None:
    """Put fault ``name`` into the engine (undone by ``monkeypatch.undo()``)."""
    if name in ENGINE_FAULTS:
        ENGINE_FAULTS[name](monkeypatch)
        return
    fault = MODEL_FAULTS[name]
    build = simulation.build

    def faulty_build(scene):
        model = build(scene)
        fault(model)
        return model

    monkeypatch.setattr(simulation, "build", faulty_build)
