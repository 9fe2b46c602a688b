"""Scene -> Model: packed block arrays, tables, and only the effects the scene needs."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from dda.blocks import BlockSet
from dda.contact.joints import JointTable
from dda.contact.law import ContactLaw
from dda.effects.base import Effect
from dda.effects.bolts import RockBolts
from dda.effects.boundary_stresses import boundary_stress_loads
from dda.effects.damping import MaterialDamping
from dda.effects.elastic import Elastic, elasticity_matrices
from dda.effects.fixed_points import FixedPoints
from dda.effects.gravity import Gravity
from dda.effects.inertia import Inertia
from dda.effects.loads import PointLoads
from dda.effects.points import MaterialPoints
from dda.effects.seismic import GroundMotion
from dda.effects.water import WaterPressure
from dda.geometry import pack_polygons
from dda.scene import Scene
from dda.scene.in_situ import in_situ_stress
from dda.scene.presets import apply_preset
from dda.scene.stage_plan import StagePlan, stage_plan

log = logging.getLogger(__name__)

SEARCH_FACTOR = 2.5  # search distance / largest displacement allowed per step (Shi)
TOUCH = 1e-9  # a new contact closer than this fraction of the model size starts closed


@dataclass
class ContactModel:
    """Everything the contact pipeline needs, fixed for the run."""

    law: ContactLaw
    joints: JointTable
    initial_penalty: float
    search_distance: float
    vertex_radius: float
    touch_tolerance: float


@dataclass
class Model:
    """A scene made ready to run."""

    scene: Scene
    blocks: BlockSet
    effects: list[Effect]
    elastic: Elastic
    inertia: Inertia
    contact: ContactModel | None
    material_density: np.ndarray
    static: bool
    exact_rotation: bool
    max_time_step: float
    duration: float | None
    steps: int | None
    allowed_displacement: float
    model_size: float
    save_every: int
    fracture: Effect | None = None
    active_effects: list[str] = field(default_factory=list)
    bolts: RockBolts | None = None  # also in ``effects``
    ground: GroundMotion | None = None  # also in ``effects``
    water: WaterPressure | None = None  # also in ``effects``
    stages: StagePlan | None = None


def initial_blocks(scene: Scene, material_rows: dict[str, int], joint_rows: dict[str, int]):
    """BlockSet at t = 0 from the scene's blocks."""
    polygons = [np.asarray(b.vertices, dtype=float) for b in scene.blocks]
    vertices, offsets = pack_polygons(polygons)
    edge_joint = (
        np.concatenate(
            [
                np.array(
                    [joint_rows.get(j, -1) if j else -1 for j in b.edge_joints]
                    if b.edge_joints
                    else [-1] * len(b.vertices),
                    dtype=np.int64,
                )
                for b in scene.blocks
            ]
        )
        if scene.blocks
        else np.zeros(0, np.int64)
    )
    n = len(scene.blocks)
    velocity = np.zeros((n, 6))
    velocity[:, [0, 1, 2]] = np.array([b.velocity for b in scene.blocks]).reshape(n, 3)
    return BlockSet(
        names=[b.name for b in scene.blocks],
        ids=np.arange(n, dtype=np.int64),
        material=np.array([material_rows[b.material] for b in scene.blocks], dtype=np.int64),
        vertices=vertices,
        offsets=offsets,
        edge_joint=edge_joint,
        velocity=velocity,
        stress=np.array([b.stress for b in scene.blocks], dtype=float).reshape(n, 3),
        rotation=np.zeros(n),
        displacement=np.zeros((n, 2)),
        fixed=np.array([b.fixed for b in scene.blocks], dtype=bool),
    )


def build(scene: Scene) -> Model:
    """Instantiate the model; effects absent from the scene are not created.

    An ``[analysis] accuracy`` preset first fills in the settings the scene
    leaves at their defaults (:func:`dda.scene.presets.apply_preset`).
    """
    scene = apply_preset(scene)
    materials = list(scene.materials.values())
    material_rows = {m.name: k for k, m in enumerate(materials)}
    joints = list(scene.joints.values())
    joint_rows = {j.name: k for k, j in enumerate(joints)}
    blocks = initial_blocks(scene, material_rows, joint_rows)
    if scene.in_situ is not None:  # the stress the rock stands in, at each centroid
        blocks.stress = blocks.stress + in_situ_stress(scene.in_situ, blocks.centroid)
    a = scene.analysis
    density = np.array([m.density for m in materials])
    young = np.array([m.young for m in materials])
    exact = a.rotation == "exact"
    static = a.mode == "static"

    lo, hi = blocks.vertices.min(axis=0), blocks.vertices.max(axis=0)
    model_size = float(max(hi - lo)) / 2.0  # Shi's w0: half the model extent
    allowed = a.max_displacement_ratio * model_size

    elastic = Elastic(elasticity_matrices(young, [m.poisson for m in materials], a.plane))
    inertia = Inertia(density)
    inertia.name = "static_damping" if static else "inertia"
    effects: list[Effect] = [elastic, inertia]
    damping = np.array([m.damping for m in materials])
    if not static and np.any(damping > 0.0):
        effects.append(MaterialDamping(elastic.material_elasticity, density, damping))
    if np.any(np.asarray(a.gravity) != 0.0):
        effects.append(Gravity(density, a.gravity))
    if scene.loads:
        effects.append(_point_loads(scene, blocks, exact))
    if scene.boundary_stresses:
        effects.append(boundary_stress_loads(scene, blocks.fixed, exact))
    if any(b.fixed_points for b in scene.blocks):
        stiffness = a.fixed_point_penalty or 100.0 * float(young.max())
        effects.append(_fixed_points(scene, blocks, stiffness, exact))
    engineering = engineering_effects(scene, blocks, exact)
    effects += [e for e in engineering.values() if e is not None]

    breakable = any(m.breakable for m in materials)
    contact = _contact_model(
        scene, blocks, joints, joint_rows, float(young.max()), allowed, breakable
    )
    fracture = _fracture_effect(scene, blocks) if breakable else None
    active = [e.name for e in effects]
    if contact is not None:
        active.append("contact_augmented" if contact.law.augmented else "contact_penalty")
        if contact.law.friction:
            active.append("friction")
    if fracture is not None:
        active.append("fracture")
    if scene.stages:
        active.append("stages")
    if scene.measure:
        active.append("measure")
    log.info("active effects: %s", ", ".join(active))
    return Model(
        scene=scene,
        blocks=blocks,
        effects=effects,
        elastic=elastic,
        inertia=inertia,
        contact=contact,
        material_density=density,
        static=static,
        exact_rotation=exact,
        max_time_step=a.time_step,
        duration=a.duration if a.steps is None else None,
        steps=a.steps,
        allowed_displacement=allowed,
        model_size=model_size,
        save_every=a.save_every,
        fracture=fracture,
        active_effects=active,
        bolts=engineering["bolts"],
        ground=engineering["seismic"],
        water=engineering["water"],
        stages=stage_plan(scene),
    )


def engineering_effects(scene: Scene, blocks: BlockSet, exact: bool) -> dict[str, Effect | None]:
    """The effects of ``[water]``, ``[[bolts]]`` (with the bolts of ``[[stages]]``) and
    ``[seismic]``, in that order; None for a section the scene does not have."""
    row = {name: k for k, name in enumerate(blocks.names)}
    water = scene.water
    bolts = list(scene.bolts) + [b for stage in scene.stages for b in stage.bolts]
    seismic = scene.seismic
    out: dict[str, Effect | None] = {"water": None, "bolts": None, "seismic": None}
    if water is not None:
        out["water"] = WaterPressure(np.array(water.table), water.unit_weight)
    if bolts:
        hosts = np.array([[row[b.blocks[0]] for b in bolts], [row[b.blocks[1]] for b in bolts]])
        ends = MaterialPoints(
            hosts.ravel(), np.array([b.start for b in bolts] + [b.end for b in bolts])
        )
        out["bolts"] = RockBolts(
            [b.name for b in bolts],
            ends,
            np.array([b.stiffness for b in bolts]),
            np.array([b.pretension for b in bolts]),
            np.array([np.inf if b.capacity is None else b.capacity for b in bolts]),
            np.arange(len(bolts)) < len(scene.bolts),
            exact,
        )
    if seismic is not None:
        record = np.array(seismic.record)
        ids = np.array([row[name] for name in seismic.blocks], np.int64)
        out["seismic"] = GroundMotion(record[:, 0], seismic.scale * record[:, 1:], ids)
        if out["water"] is not None:  # the groundwater moves with the ground
            out["water"].ground = out["seismic"]
    return out


def _point_loads(scene: Scene, blocks: BlockSet, exact: bool) -> PointLoads:
    rows = [blocks.names.index(ld.block) for ld in scene.loads]
    points = MaterialPoints(np.array(rows), np.array([ld.point for ld in scene.loads]))
    histories = [None if ld.history is None else np.array(ld.history) for ld in scene.loads]
    return PointLoads(points, np.array([ld.force for ld in scene.loads]), histories, exact)


def _fixed_points(scene: Scene, blocks: BlockSet, stiffness: float, exact: bool) -> FixedPoints:
    rows, pts = [], []
    for k, b in enumerate(scene.blocks):
        for p in b.fixed_points:
            rows.append(k)
            pts.append(p)
    return FixedPoints(MaterialPoints(np.array(rows), np.array(pts)), stiffness, exact)


def _contact_model(
    scene, blocks, joints, joint_rows, young_max, allowed, breakable
) -> ContactModel | None:
    """The contact model, or None where no two blocks can ever touch: a single block that
    cannot break (a breakable one's pieces touch each other), or only fixed blocks."""
    if (blocks.count < 2 and not breakable) or blocks.fixed.all():
        return None
    c = scene.contact
    table = JointTable(
        names=[j.name for j in joints],
        friction_angle=np.array([j.friction_angle for j in joints]),
        cohesion=np.array([j.cohesion for j in joints]),
        tensile=np.array([j.tensile_strength for j in joints]),
        interface_ids=np.array(
            [
                [blocks.names.index(i.blocks[0]), blocks.names.index(i.blocks[1])]
                for i in scene.interfaces
            ],
            dtype=np.int64,
        ).reshape(-1, 2),
        interface_joint=np.array([joint_rows[i.joint] for i in scene.interfaces], np.int64),
        residual={
            "friction_angle": np.array([j.residual_angle for j in joints]),
            "cohesion": np.array([j.residual_cohesion for j in joints]),
            "tensile": np.array([j.residual_tensile_strength for j in joints]),
            "barton": np.array([j.barton_bandis for j in joints], bool),
            "jrc": np.array([j.jrc for j in joints]),
            "jcs": np.array([j.jcs for j in joints]),
            "divisor": np.array([j.strength_divisor for j in joints]),
            "restitution": np.array(
                [np.nan if j.restitution is None else j.restitution for j in joints]
            ),
        },
    )
    extent = float(max(blocks.vertices.max(axis=0) - blocks.vertices.min(axis=0)))
    penalty = c.penalty if c.penalty is not None else 10.0 * young_max
    law = ContactLaw(
        augmented=c.method == "augmented-lagrangian",
        tolerance=c.tolerance if c.tolerance is not None else 1e-4 * extent,
        shear_ratio=c.shear_ratio,
        friction=table.has_friction,
        max_penalty=max(1e4 * young_max, penalty),
    )
    search = SEARCH_FACTOR * allowed
    return ContactModel(
        law=law,
        joints=table,
        initial_penalty=penalty,
        search_distance=search,
        vertex_radius=search,
        touch_tolerance=TOUCH * extent,
    )


def _fracture_effect(scene: Scene, blocks: BlockSet) -> Effect | None:
    try:
        from dda.fracture.effect import FractureEffect
    except ImportError:
        log.warning("breakable materials present but dda.fracture is not available")
        return None
    return FractureEffect.from_scene(scene, blocks)
