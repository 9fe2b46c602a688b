"""Energy accounting of a run: what the blocks hold and what the loads put in.

Per step the engine records (``Result.history``)::

    kinetic   T = ½ Σ vᵢᵀ Mᵢ vᵢ                 (Shi's six velocity components,
                                               Mᵢ = ρ ∫ Tᵢᵀ Tᵢ dA, docs/theory.md §3)
    potential V = Σ mᵢ g·(x_low − x_cᵢ)         (gravity; datum: the lowest vertex
                                               of the model at t = 0, so V ≥ 0 there)
    elastic   U = ½ Σ Sᵢ σᵢᵀ Eᵢ⁻¹ σᵢ
    contact   C = Σ N²/2p + Σ F²/2p_s          (closed contacts: the contact springs
                                               at their forces after the step)
    springs   ½ Σ p_f |x − x₀|²                (fixed points)
    work      W = Σ_steps Σ_loads F(t)·T(x) D  (point loads)

Fixed blocks never move and are left out. Shi's time integration (Newmark
β = ½, γ = 1) dissipates, friction dissipates, so for a sound run
T + V + U + C + springs ≤ E₀ + W at every step (up to round-off and the
linearisation of the contact distance within a step).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.effects.fixed_points import FixedPoints
from dda.effects.gravity import Gravity
from dda.effects.inertia import mass_matrices
from dda.effects.loads import PointLoads
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
        return {**asdict(self), "total": self.total}


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
    """V = Σ ρᵢ Sᵢ g·(x_datum − x_cᵢ) over the free blocks.

    With g = (0, −g) this is Σ m g (y_c − y_datum).
    """
    free = ~blocks.fixed
    mass = density[free] * blocks.area[free]
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


def load_work(loads: PointLoads | None, blocks: BlockSet, d: np.ndarray, time: float) -> float:
    """Work of the point loads over one step: Σ F(t)·T(x) D.

    The engine applies each load with its factor at the end of the step and
    at the point's position at the start (F_i += Tᵀ F), so this is exactly
    the work that enters the step's equations.
    """
    if loads is None or not len(loads.points):
        return 0.0
    rows = loads.points.rows
    t = displacement_matrices(loads.points.positions, blocks.centroid[rows])
    moved = np.einsum("mkr,mr->mk", t, d[rows])
    return float(np.sum(loads.current_forces(time) * moved))


def _effect(effects, kind):
    return next((e for e in effects if isinstance(e, kind)), None)


class EnergyAccount:
    """Measures the stored energies and accumulates the work of the loads.

    Built once per run from the model; the gravity datum is fixed at the
    lowest vertex (along g) of the initial blocks.
    """

    def __init__(self, model, blocks: BlockSet) -> None:
        self.density_table = model.material_density
        self.elastic = model.elastic
        gravity = _effect(model.effects, Gravity)
        self.gravity = None if gravity is None else np.asarray(gravity.gravity, float)
        self.loads = _effect(model.effects, PointLoads)
        self.springs = _effect(model.effects, FixedPoints)
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
        potential = 0.0
        if self.gravity is not None:
            potential = gravity_potential(density, blocks, self.gravity, self.datum)
        return EnergyTerms(
            kinetic=kinetic_energy(density, blocks),
            potential=potential,
            elastic=elastic_energy(self.elastic.block_elasticity(blocks), blocks),
            contact=contact_energy(contacts, self.shear_ratio, self.friction),
            springs=spring_energy(self.springs),
        )

    def add_step_work(self, blocks: BlockSet, d: np.ndarray, time: float) -> float:
        """Add the loads' work over the accepted step ``d`` (before the blocks move)."""
        w = load_work(self.loads, blocks, d, time)
        self.work += w
        return w
