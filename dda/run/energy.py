"""Energy accounting of a run: what the blocks hold and what the loads put in.

Per step the engine records (``Result.history``)::

    kinetic   T = ½ Σ vᵢᵀ Mᵢ vᵢ                 (Shi's six velocity components,
                                               Mᵢ = ρ ∫ Tᵢᵀ Tᵢ dA, docs/theory.md §3)
    potential V = Σ mᵢ g·(x_low − x_cᵢ)         (gravity; datum: the lowest vertex
                                               of the model at t = 0, so V ≥ 0 there)
              + Σ ∫_blockᵢ p dA                 (water pressure p below the table: the
                                               potential of its loads, a fixed field)
    elastic   U = ½ Σ Sᵢ σᵢᵀ Eᵢ⁻¹ σᵢ
    contact   C = Σ N²/2p + Σ F²/2p_s          (closed contacts: the contact springs
                                               at their forces after the step)
    springs   ½ Σ p_f |x − x₀|²                (fixed points)
              + Σ f0 e + ½ k e²                (rock bolts: pretension f0, stretch e)
    work      W = Σ_steps Σ_loads F(t)·T(x) D  (point loads, boundary stresses)
              + Σ_steps Σ (N ∇g_j + F ∇s_j)·D_j (the ground moving fixed blocks by D_j:
                                                contacts, and T r_j·D_j of bolts with
                                                (T/L) Δ⊥ r⊥_j·D_j across them)
              + Σ_steps V_w(x₀, t₁) − V_w(x₀, t₀) (the ground carrying the water table:
                                                the potential the water's field gains
                                                at the blocks' place over a step)

Fixed blocks never move and are left out. Shi's time integration (Newmark
β = ½, γ = 1) dissipates, friction dissipates, so for a sound run
T + V + U + C + springs ≤ E₀ + W at every step (up to round-off and the
linearisation of the contact distance within a step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.rows import contact_rows, gaps_after
from dda.effects.bolts import RockBolts
from dda.effects.fixed_points import FixedPoints
from dda.effects.gravity import Gravity
from dda.effects.inertia import mass_matrices
from dda.effects.loads import PointLoads
from dda.effects.water import WaterPressure
from dda.jit import compiled_in_run, kernel
from dda.kinematics import displacement_matrices
from dda.result import OPEN

TERMS = ("kinetic", "potential", "elastic", "contact", "springs")


@dataclass(frozen=True)
class EnergyTerms:
    """The stored energies of the block system at one instant (per unit thickness)."""

    kinetic: float
    potential: float
    elastic: float
    contact: float
    springs: float

    @property
    def total(self) -> float:
        """T + V + U + C + springs."""
        return self.kinetic + self.potential + self.elastic + self.contact + self.springs

    def as_dict(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in TERMS} | {"total": self.total}


def kinetic_energy(density: np.ndarray, blocks: BlockSet) -> float:
    """T = ½ Σ vᵀ M v over the free blocks.

    Parameters
    ----------
    density : (n,) density of each block
    blocks : the blocks (velocity (n, 6) = d/dt of (u0, v0, r0, ex, ey, gxy))
    """
    free = ~blocks.fixed
    m = mass_matrices(density, blocks)[free]
    v = blocks.velocity[free]
    return float(0.5 * np.einsum("ni,nij,nj->", v, m, v))


def gravity_potential(
    density: np.ndarray, blocks: BlockSet, gravity: np.ndarray, datum: np.ndarray
) -> float:
    """V = Σ ρᵢ S₀ᵢ g·(x_datum − x_cᵢ) over the free blocks (S₀ᵢ ρᵢ the block's mass).

    With g = (0, −g) this is Σ m g (y_c − y_datum).
    """
    free = ~blocks.fixed
    mass = density[free] * blocks.mass_area[free]
    height = (datum[None, :] - blocks.centroid[free]) @ np.asarray(gravity, float)
    return float(np.sum(mass * height))


def elastic_energy(elasticity: np.ndarray, blocks: BlockSet) -> float:
    """U = ½ Σ S σᵀ E⁻¹ σ over the free blocks (σ = (sxx, syy, sxy), E per block).

    Parameters
    ----------
    elasticity : (n, 3, 3) constitutive matrix of each block (stress from
        (ex, ey, gxy))
    """
    free = ~blocks.fixed
    if not free.any():
        return 0.0
    sigma = blocks.stress[free]
    strain = np.linalg.solve(elasticity[free], sigma[:, :, None])[:, :, 0]
    return float(0.5 * np.sum(blocks.area[free] * np.einsum("ni,ni->n", sigma, strain)))


def block_energies(
    density: np.ndarray,
    elasticity: np.ndarray,
    blocks: BlockSet,
    gravity: np.ndarray | None,
    datum: np.ndarray,
) -> tuple[float, float, float]:
    """(T, V, U) of :func:`kinetic_energy`, :func:`gravity_potential` and
    :func:`elastic_energy` in one compiled pass over the blocks (V = 0 without
    ``gravity``)."""
    g = np.zeros(2) if gravity is None else np.asarray(gravity, float)
    return block_energies_kernel(
        np.ascontiguousarray(density, np.float64),
        np.ascontiguousarray(elasticity, np.float64),
        blocks.fixed,
        blocks.area,
        blocks.ixx,
        blocks.iyy,
        blocks.ixy,
        blocks.density_ratio,
        blocks.mass_area,
        np.ascontiguousarray(blocks.centroid, np.float64),
        np.ascontiguousarray(blocks.velocity, np.float64),
        np.ascontiguousarray(blocks.stress, np.float64),
        g,
        np.asarray(datum, np.float64),
    )


def _block_energies(
    density, elasticity, fixed, area, ixx, iyy, ixy, ratio, mass_area, centroid, velocity,
    stress, gravity, datum,
):  # fmt: skip
    """Compiled (T, V, U): vᵀMv from the moments (the entries of
    :func:`dda.effects.inertia.mass_matrices`), σᵀE⁻¹σ by Cramer's rule on the 3 × 3 E."""
    kinetic = potential = elastic = 0.0
    for i in range(fixed.shape[0]):
        if fixed[i]:
            continue
        v = velocity[i]
        a, b, c = ixx[i], iyy[i], ixy[i]
        quadratic = (
            area[i] * (v[0] * v[0] + v[1] * v[1])
            + (a + b) * v[2] * v[2] + a * v[3] * v[3] + b * v[4] * v[4]
            + 0.25 * (a + b) * v[5] * v[5]
            + 2.0 * v[2] * (-c * v[3] + c * v[4] + 0.5 * (a - b) * v[5])
            + c * v[5] * (v[3] + v[4])
        )  # fmt: skip
        kinetic += 0.5 * density[i] * ratio[i] * quadratic
        height = (datum[0] - centroid[i, 0]) * gravity[0] + (datum[1] - centroid[i, 1]) * gravity[1]
        potential += density[i] * mass_area[i] * height
        e, s = elasticity[i], stress[i]
        det = (
            e[0, 0] * (e[1, 1] * e[2, 2] - e[1, 2] * e[2, 1])
            - e[0, 1] * (e[1, 0] * e[2, 2] - e[1, 2] * e[2, 0])
            + e[0, 2] * (e[1, 0] * e[2, 1] - e[1, 1] * e[2, 0])
        )
        x0 = (
            s[0] * (e[1, 1] * e[2, 2] - e[1, 2] * e[2, 1])
            - e[0, 1] * (s[1] * e[2, 2] - e[1, 2] * s[2])
            + e[0, 2] * (s[1] * e[2, 1] - e[1, 1] * s[2])
        ) / det
        x1 = (
            e[0, 0] * (s[1] * e[2, 2] - e[1, 2] * s[2])
            - s[0] * (e[1, 0] * e[2, 2] - e[1, 2] * e[2, 0])
            + e[0, 2] * (e[1, 0] * s[2] - s[1] * e[2, 0])
        ) / det
        x2 = (
            e[0, 0] * (e[1, 1] * s[2] - s[1] * e[2, 1])
            - e[0, 1] * (e[1, 0] * s[2] - s[1] * e[2, 0])
            + s[0] * (e[1, 0] * e[2, 1] - e[1, 1] * e[2, 0])
        ) / det
        elastic += 0.5 * area[i] * (s[0] * x0 + s[1] * x1 + s[2] * x2)
    return kinetic, potential, elastic


block_energies_kernel = kernel(_block_energies)


def contact_energy(contacts: ContactSet, shear_ratio: float, friction: bool) -> float:
    """C = Σ N² / (2p) + Σ F² / (2 p_s) over the closed contacts (p_s = shear_ratio · p).

    The energy the contact springs hold at the forces of the last solve: N and
    F are the normal and shear forces. For the penalty method N = p d, and the
    normal part is Shi's ½ p d²; with the augmented Lagrangian it is what the
    spring of the step's potential holds at that force (dda.contact.potential).
    A sliding contact's spring is stretched to its friction bound. Without
    friction no shear spring is built and none is counted.
    """
    if not len(contacts):
        return 0.0
    closed = contacts.state != OPEN
    p = contacts.penalty[closed]
    normal = np.sum(contacts.normal_force[closed] ** 2 / (2.0 * p))
    if not friction or shear_ratio <= 0.0:
        return float(normal)
    shear = np.sum(contacts.shear_force[closed] ** 2 / (2.0 * shear_ratio * p))
    return float(normal + shear)


def spring_energy(springs: FixedPoints | None) -> float:
    """½ Σ p_f |x − x₀|² of the fixed-point springs."""
    if springs is None:
        return 0.0
    gap = springs.points.positions - springs.anchors
    return float(0.5 * springs.stiffness_value * np.sum(gap * gap))


def load_work(
    loads: PointLoads | None, blocks: BlockSet, d: np.ndarray, time: float, start: float
) -> float:
    """Work of the point loads over the step from ``start`` to ``time``: Σ F·T(x) D.

    The engine applies each load with its step's force (:meth:`PointLoads.step_forces`)
    at the point's position at the start (F_i += Tᵀ F), so this is exactly the work
    that enters the step's equations.
    """
    if loads is None or not len(loads.points):
        return 0.0
    rows = loads.points.rows
    t = displacement_matrices(loads.points.positions, blocks.centroid[rows])
    moved = np.einsum("mkr,mr->mk", t, d[rows])
    return float(np.sum(loads.step_forces(start, time) * moved))


def ground_work(
    blocks: BlockSet,
    contacts: ContactSet,
    bolts: RockBolts | None,
    d: np.ndarray,
    prescribed: np.ndarray,
) -> float:
    """Work of the ground on the blocks over one step, its fixed blocks moved by ``prescribed``.

    Each contact's force at the end of the step, N (normal) and F (shear), acts
    on the moving block through the gradients of the gap and of the shear motion,
    so the ground does N ∇g_j·D_j + F ∇s_j·D_j; a bolt of tension T (at the end
    of the step, its stretch linear in ``d``) does T r_j·D_j. ``blocks``: at the
    step start; ``d``: the step, with ``prescribed`` on the moving blocks.
    """
    work = 0.0
    if len(contacts):
        rows = contact_rows(blocks, contacts)
        g, s = gaps_after(rows, contacts.block_a, contacts.block_b, prescribed)
        work += float(np.dot(contacts.normal_force, g - rows.penetration))
        work += float(np.dot(contacts.shear_force, s - rows.slip))
    if bolts is not None and bolts.active.any():
        axial, across, e0 = bolts.step_springs(blocks, prescribed)
        free = d - prescribed  # the step of the free blocks (prescribed's are in e0)
        tension = bolts.pretension[bolts.active] + axial.stiffness * (e0 + axial.stretch(free))
        work += float(np.dot(tension, axial.stretch(prescribed)))
        sideways = across.stiffness * across.stretch(d)  # the springs across, at the end
        work += float(np.dot(sideways, across.stretch(prescribed)))
    return work


def _effect(effects, kind):
    return next((e for e in effects if isinstance(e, kind)), None)


class EnergyAccount:
    """Measures the stored energies and accumulates the work of the loads.

    Built once per run from the model; the gravity datum is fixed at the
    lowest vertex (along g) of the initial blocks.
    """

    def __init__(self, model, blocks: BlockSet) -> None:
        self.density_table = model.material_density
        self.static = model.static  # its loads at each step's end (PointLoads.forces)
        self.elastic = model.elastic
        gravity = _effect(model.effects, Gravity)
        self.gravity = None if gravity is None else np.asarray(gravity.gravity, float)
        # point loads and boundary stresses (dda.effects.boundary_stresses)
        self.loads = [e for e in model.effects if isinstance(e, PointLoads)]
        self.springs = _effect(model.effects, FixedPoints)
        self.bolts = _effect(model.effects, RockBolts)
        self.water = _effect(model.effects, WaterPressure)
        law = None if model.contact is None else model.contact.law
        self.shear_ratio = 0.0 if law is None else law.shear_ratio
        self.friction = False if law is None else law.friction
        self.datum = self._datum(blocks)
        self.work = 0.0
        self.initial = self.measure(blocks, ContactSet.empty())

    def _datum(self, blocks: BlockSet) -> np.ndarray:
        if self.gravity is None or not len(blocks.vertices):
            return np.zeros(2)
        return blocks.vertices[np.argmax(blocks.vertices @ self.gravity)].copy()

    def measure(self, blocks: BlockSet, contacts: ContactSet) -> EnergyTerms:
        """The stored energies of ``blocks`` with ``contacts`` (after a step)."""
        density = self.density_table[blocks.material]
        elasticity = self.elastic.block_elasticity(blocks)
        if compiled_in_run(block_energies_kernel):
            kinetic, potential, elastic = block_energies(
                density, elasticity, blocks, self.gravity, self.datum
            )
        else:
            kinetic = kinetic_energy(density, blocks)
            potential = 0.0
            if self.gravity is not None:
                potential = gravity_potential(density, blocks, self.gravity, self.datum)
            elastic = elastic_energy(elasticity, blocks)
        if self.water is not None:
            potential += self.water.energy(blocks)
        return EnergyTerms(
            kinetic=kinetic,
            potential=potential,
            elastic=elastic,
            contact=contact_energy(contacts, self.shear_ratio, self.friction),
            springs=spring_energy(self.springs) + (self.bolts.energy() if self.bolts else 0.0),
        )

    def stored(self, blocks: BlockSet) -> float:
        """The blocks' potential (gravity, water) and elastic energy."""
        terms = self.measure(blocks, ContactSet.empty())
        return terms.potential + terms.elastic

    def load_work(self, blocks: BlockSet, d: np.ndarray, time: float, start: float) -> float:
        """The work of the loads (point loads, boundary stresses) over ``d`` from
        ``blocks``, in the step from ``start`` to ``time``."""
        return sum(load_work(loads, blocks, d, time, start) for loads in self.loads)

    def add_step_work(
        self,
        blocks: BlockSet,
        d: np.ndarray,
        time: float,
        contacts: ContactSet | None,
        prescribed: np.ndarray | None,
        start: float,
    ) -> float:
        """Add the external work over the accepted step ``d`` from ``start`` to ``time``
        (before the blocks move): the loads' and, when fixed blocks moved by
        ``prescribed`` (part of ``d``), the ground's through ``contacts`` (their forces at
        the step's end). The water's pressure is a potential (``potential``), not work,
        but where the ground carries its table (``[seismic]``) the potential it gains at
        the blocks' place over the step, V(x₀, t₁) − V(x₀, t₀), is."""
        w = self.load_work(blocks, d, time, time if self.static else start)
        if prescribed is not None:
            w += ground_work(blocks, contacts, self.bolts, d, prescribed)
        if self.water is not None and self.water.ground is not None:
            after = self.water.energy_at(blocks, time)  # the step's wet edges, kept
            w += after - self.water.energy_at(blocks, start)
            self.water.follow(time)  # back where the step's end has it
        self.work += w
        return w
