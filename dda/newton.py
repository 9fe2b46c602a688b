"""Newton's method with an exact line search on a step's incremental potential.

The step D (n, 6) of Shi's scheme minimises

    Π(D) = ½ Dᵀ K₀ D − F₀ᵀ D + Σ_c φn(g_c(D)) + Σ_c φt(s_c(D))

K₀, F₀: inertia (2M/Δt², 2M v0/Δt), elasticity, initial stress, loads,
gravity and fixed-point springs, block-diagonal, and rock bolts, linear
springs that couple two blocks (:mod:`dda.pair_springs`); φn, φt: the contact terms of
:mod:`dda.contact.potential`, with the contact data frozen; g, s linear in D
(paper eqs. 9-13). Π is strictly convex (K₀ is positive definite through the
mass), C¹ and piecewise quadratic.

An iteration takes the pieces of every contact at the current D, solves the
quadratic of those pieces (K₀ plus the contact springs of those pieces: the
linear system of Shi's open–close iteration), and, unless every contact is on
its assumed piece at that minimiser (then it is Π's minimiser, exactly), moves
along the direction to the minimum of Π on that line
(:func:`dda.contact.line_search.line_minimum`). Π decreases in every
iteration, so no set of contact states can recur: the iteration cannot cycle.
It has also converged when the gradient of Π is within ``RELATIVE_TOLERANCE``
of the forces that make it up.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dda.contact.line_search import line_minimum
from dda.contact.potential import ContactTerms
from dda.contact.rows import ContactRows, gaps_after
from dda.pair_springs import PairSprings

log = logging.getLogger(__name__)

RELATIVE_TOLERANCE = 1e-4  # ‖∇Π‖ against ‖K₀D‖ + ‖F₀‖ + ‖contact forces‖


@dataclass(frozen=True)
class BlockQuadratic:
    """½ Dᵀ K₀ D − F₀ᵀ D with one 6x6 block of K₀ per block (fixed blocks: D = 0),
    plus the springs that couple two blocks (rock bolts, :mod:`dda.pair_springs`):
    K₀ = blockdiag + Σ k [r_i r_j]ᵀ[r_i r_j]."""

    stiffness: np.ndarray  # (n, 6, 6)
    forces: np.ndarray  # (n, 6)
    free: np.ndarray  # (n,) bool: the blocks that move
    couplings: PairSprings | None = None

    def product(self, d: np.ndarray) -> np.ndarray:
        """K₀ D, (n, 6)."""
        out = np.einsum("nij,nj->ni", self.stiffness, d)
        if self.couplings is not None:
            out += self.couplings.product(d)
        return out

    def value(self, d: np.ndarray) -> float:
        """½ Dᵀ K₀ D − F₀ᵀ D."""
        return float(np.sum(d * (0.5 * self.product(d) - self.forces)))

    def along(self, d: np.ndarray, direction: np.ndarray) -> tuple[float, float]:
        """(a, c) of the line D + α ΔD: a = ΔDᵀ(K₀ D − F₀), c = ΔDᵀ K₀ ΔD."""
        a = float(np.sum(direction * (self.product(d) - self.forces)))
        return a, float(np.sum(direction * self.product(direction)))


@dataclass(frozen=True)
class ContactGeometry:
    """The contacts' distances as linear functions of D (eqs. 9-13)."""

    rows: ContactRows
    block_a: np.ndarray
    block_b: np.ndarray

    def at(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(g, s): penetration and shear motion of every contact after the step D."""
        return gaps_after(self.rows, self.block_a, self.block_b, d)

    def rates(self, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∇g·ΔD, ∇s·ΔD)."""
        g, s = self.at(direction)
        return g - self.rows.penetration, s - self.rows.slip


@dataclass
class NewtonResult:
    d: np.ndarray
    solves: int
    converged: bool


# solve(normal springs, shear springs, normal offsets, shear offsets) -> D: the minimiser
# of the quadratic whose contact forces are offset + spring · (∇g·D)
PieceSolver = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
# contact_vector(normal forces, shear forces) -> Σ N ∇g + Σ F ∇s as (n, 6)
ForceVector = Callable[[np.ndarray, np.ndarray], np.ndarray]


def minimise(
    quadratic: BlockQuadratic,
    geometry: ContactGeometry,
    terms: ContactTerms,
    solve: PieceSolver,
    contact_vector: ForceVector,
    start: np.ndarray,
    max_solves: int,
    first_pieces: tuple[np.ndarray, np.ndarray] | None = None,
    iterates: list | None = None,
) -> NewtonResult:
    """Minimise Π from ``start`` with at most ``max_solves`` linear solves.

    ``first_pieces``: (normal, shear) pieces for the first iteration's quadratic
    instead of those at ``start`` (e.g. the contact states at the end of the
    last step). Any pieces give a descent direction; the quadratic's minimiser
    is Π's exactly when every contact is on the piece assumed for it there.
    ``iterates``: a list to which every iterate D is appended (diagnostics).
    """
    d = start
    g0, s0 = geometry.rows.penetration, geometry.rows.slip
    pieces = first_pieces
    for solves in range(1, max_solves + 1):
        g, s = geometry.at(d)
        if pieces is None:
            pieces = terms.pieces(g, s)
        kn, ks = terms.springs(*pieces)
        offset_n, offset_t = terms.offsets(*pieces, g0, s0)
        target = solve(kn, ks, offset_n, offset_t)
        if not np.all(np.isfinite(target)):
            return NewtonResult(target, solves, False)
        if terms.same_pieces(pieces, terms.pieces(*geometry.at(target))):
            if iterates is not None:
                iterates.append(target)
            return NewtonResult(target, solves, True)  # the quadratic was Π's there
        direction = target - d
        dg, ds = geometry.rates(direction)
        a, c = quadratic.along(d, direction)
        alpha, _ = line_minimum(terms, a, c, g, dg, s, ds)
        d = d + alpha * direction
        if iterates is not None:
            iterates.append(d)
        if _stationary(quadratic, geometry, terms, contact_vector, d):
            return NewtonResult(d, solves, True)
        log.debug("Newton %d: α = %.3g", solves, alpha)
        pieces = None
    return NewtonResult(d, max_solves, False)


def potential(
    quadratic: BlockQuadratic, geometry: ContactGeometry, terms: ContactTerms, d: np.ndarray
) -> float:
    """Π(D)."""
    return quadratic.value(d) + terms.energy(*geometry.at(d))


def better_start(
    quadratic: BlockQuadratic,
    geometry: ContactGeometry,
    terms: ContactTerms,
    candidates: list[np.ndarray],
) -> np.ndarray:
    """The candidate start with the lowest Π (e.g. D = 0 and D = v0 Δt)."""
    values = [potential(quadratic, geometry, terms, d) for d in candidates]
    return candidates[int(np.argmin(values))]


def _stationary(quadratic, geometry, terms, contact_vector, d) -> bool:
    """‖∇Π(D)‖ ≤ RELATIVE_TOLERANCE (‖K₀D‖ + ‖F₀‖ + ‖Σ N∇g + Σ F∇s‖)."""
    g, s = geometry.at(d)
    contact = contact_vector(terms.normal_force(g), terms.shear_force(s))
    blocks = quadratic.product(d)
    free = quadratic.free
    blocks, forces, contact = blocks[free], quadratic.forces[free], contact[free]
    residual = blocks - forces + contact
    scale = np.linalg.norm(blocks) + np.linalg.norm(forces) + np.linalg.norm(contact)
    return bool(np.linalg.norm(residual) <= RELATIVE_TOLERANCE * scale)
