"""What the step asks of its linear systems: :class:`StepSystems`, one protocol.

A step's systems are band systems (:class:`dda.solve.band_system.BandSystem`, whose
Newton passes, and the outer loop around them, run compiled), dense ones
(:class:`dda.solve.dense_system.DenseSystem`) or ones on a sparse block pattern
(:class:`dda.solve.step._PieceSystem`); the last two leave the passes to the numpy
Newton (:class:`NumpyPasses`). The step calls each through this protocol only and never
asks which one it holds.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class StepSystems(Protocol):
    """The linear systems of one step, K(springs) D = F(offsets)."""

    # the passes run compiled (the size rules of band systems,
    # dda.solve.policy.StepPolicy.size_rules)
    compiled_passes: bool
    # the contact forces are summed contact by contact, as the compiled loop sums them
    # (dda.contact.law.BoundIteration(by_rows=...))
    sums_by_rows: bool

    def __call__(self, kn, ks, offset_n, offset_t) -> np.ndarray:
        """D (n, 6) of the quadratic of these springs and offsets."""

    def chord(self, residual: np.ndarray) -> np.ndarray | None:
        """K_f⁻¹ r (n, 6) with the kept factorisation K_f, or None when there is none."""

    def contact_vector(self, normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
        """Σ N ∇g + Σ F ∇s over the contacts, (n, 6)."""

    def minimise(self, terms, start, max_solves, first_pieces=None, **rules):
        """A compiled Newton pass (a :class:`dda.solve.newton.NewtonResult`), or None:
        the caller runs :func:`dda.solve.newton.minimise` on this system."""

    def better_start(self, terms, candidates: list[np.ndarray]) -> np.ndarray | None:
        """The candidate of least Π by a compiled Π, or None
        (:func:`dda.solve.newton.better_start` chooses)."""

    def gaps(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(g, s) after the step ``d`` summed as the compiled passes sum them, or None
        (the caller's :class:`dda.solve.newton.ContactGeometry` gives them)."""

    def solve_loop(self, loop) -> tuple[np.ndarray, int, int, bool, float] | None:
        """The step's whole outer loop in one compiled call, or None: the caller runs
        :meth:`dda.solve.step._StepLoop.solve`."""

    @property
    def factorisations(self) -> int:
        """Factorisations these systems made themselves (not the run's solver's)."""


class NumpyPasses:
    """Systems whose Newton passes are :func:`dda.solve.newton.minimise`'s: nothing
    compiled (the band systems' are, :class:`dda.solve.band_system.BandSystem`)."""

    compiled_passes = False
    sums_by_rows = False
    factorisations = 0  # made by these systems themselves (counted per instance)

    def minimise(self, *args, **kwargs) -> None:
        """None: the caller runs :func:`dda.solve.newton.minimise` on this system."""
        return None

    def better_start(self, terms, candidates) -> None:
        """None: :func:`dda.solve.newton.better_start` chooses the start."""
        return None

    def gaps(self, d: np.ndarray) -> None:
        """None: the caller's contact geometry gives them."""
        return None

    def solve_loop(self, loop) -> None:
        """None: the outer loop runs in Python."""
        return None
