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
``tension_dropped``
    every joint's tensile strength left out (a bonded joint holds no tension).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

import dda.run.simulation as simulation
from dda.effects.elastic import elasticity_matrices
from dda.effects.gravity import Gravity
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
    angle = np.arctan(joints.tan_friction)
    joints.tan_friction = np.where(angle > 0, np.tan(angle + np.radians(2.0)), 0.0)


def _drop_cohesion(model: Model) -> None:
    if model.contact is not None:
        model.contact.joints.cohesion = np.zeros_like(model.contact.joints.cohesion)


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


MODEL_FAULTS: dict[str, Callable[[Model], None]] = {
    "young_x1.05": _scale_young(1.05),
    "young_x0.97": _scale_young(0.97),
    "poisson_zero": _poisson_zero,
    "penalty_x0.5": _half_penalty,
    "gravity_dropped": _drop_gravity_on_last_block,
    "gravity_one_density": _gravity_with_one_density,
    "friction_plus2": _friction_plus2,
    "cohesion_dropped": _drop_cohesion,
    "tension_dropped": _drop_tension,
}
FAULTS = (*MODEL_FAULTS, "stress_x1.05")


def apply_fault(monkeypatch, name: str) -> None:
    """Put fault ``name`` into the engine (undone by ``monkeypatch.undo()``)."""
    if name == "stress_x1.05":
        make_frame = simulation.make_frame

        def scaled_frame(*args, **kwargs):
            frame = make_frame(*args, **kwargs)
            return dataclasses.replace(frame, stresses=frame.stresses * 1.05)

        monkeypatch.setattr(simulation, "make_frame", scaled_frame)
        return
    fault = MODEL_FAULTS[name]
    build = simulation.build

    def faulty_build(scene):
        model = build(scene)
        fault(model)
        return model

    monkeypatch.setattr(simulation, "build", faulty_build)
