"""The contact terms of a step's incremental potential: convex, C¹, piecewise quadratic.

Within one Newton solve every contact c has frozen data: the normal
multiplier λn (augmented Lagrangian; 0 for the penalty method), the penalty
p, the tension a bonded contact holds, T (0 unless the joint is intact with a
tensile strength), the shear force carried from the step start λt, the shear
penalty ps and the friction bound b = tan φ N + c l (frozen from the last
outer iteration). With the penetration g = g0 + ∇g·D and the shear motion
since the step start s = s0 + ∇s·D (both linear in the step D, paper eqs.
9-13) the contact forces are

    N(g) = max(λn + p g, −T)                 normal (compression > 0)
    F(s) = clamp(λt + ps s, −b, b)           shear (elastic-perfectly plastic)

and the contact's potential is their integral (its value at g = s = 0 is
immaterial to the minimiser)::

    φn(g) = (N² − λn²) / (2p)                           while λn + p g ≥ −T
          = (T² − λn²) / (2p) − T (λn + p g + T) / p     beyond (N at its limit −T)
    φt(s) = (F² − λt²) / (2ps) + b ⟨|λt + ps s| − b⟩₊ / ps

Each is convex and continuously differentiable (dφn/dg = N, dφt/ds = F)
with two or three quadratic pieces; their second derivatives, p or 0 and ps
or 0, are the contact springs of K. With T = 0 and λn = 0, φn is Shi's
penalty energy p⟨g⟩₊²/2; with λn > 0 it is the augmented Lagrangian energy
λn g + p g²/2 of the paper's eq. 8 on the closed piece.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.contact import formulas
from dda.contact.formulas import NORMAL_ELASTIC, NORMAL_LIMIT, SLIP_BACK, SLIP_FORWARD, STICK

__all__ = ["NORMAL_ELASTIC", "NORMAL_LIMIT", "SLIP_BACK", "SLIP_FORWARD", "STICK", "ContactTerms"]


@dataclass(frozen=True)
class ContactTerms:
    """The frozen data of every contact's φn and φt in one Newton solve (m,) each.

    ``shear_base`` is kept within ±``bound`` and ``normal_base`` at or above
    −``tension`` by the caller (:func:`dda.contact.law.contact_terms`); a contact
    without a shear term (ps = 0) has b = 0.
    """

    normal_base: np.ndarray  # λn
    penalty: np.ndarray  # p
    tension: np.ndarray  # T ≥ 0
    shear_base: np.ndarray  # λt
    shear_penalty: np.ndarray  # ps (0: no shear term)
    bound: np.ndarray  # b ≥ 0

    def kernel_arrays(self) -> tuple[np.ndarray, ...]:
        """λn, p, T, λt, ps, b as contiguous float arrays, the kernels' arguments."""
        data = (self.normal_base, self.penalty, self.tension, self.shear_base,
                self.shear_penalty, self.bound)  # fmt: skip
        return tuple(np.ascontiguousarray(a, np.float64) for a in data)

    def normal_trial(self, g: np.ndarray) -> np.ndarray:
        return formulas.normal_trial(self.normal_base, self.penalty, g)

    def shear_trial(self, s: np.ndarray) -> np.ndarray:
        return formulas.shear_trial(self.shear_base, self.shear_penalty, s)

    def normal_force(self, g: np.ndarray) -> np.ndarray:
        """N = max(λn + p g, −T)."""
        return formulas.normal_force(self.normal_base, self.penalty, self.tension, g)

    def shear_force(self, s: np.ndarray) -> np.ndarray:
        """F = clamp(λt + ps s, −b, b)."""
        return formulas.shear_force(self.shear_base, self.shear_penalty, self.bound, s)

    def pieces(self, g: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(normal piece, shear piece) of every contact at (g, s).

        On a kink the normal term is taken elastic (a contact that just touches is
        most likely to stay closed) and the shear term slipping (a contact at the
        friction bound is most likely to go on sliding; with b = 0 it has no stuck piece).
        """
        normal = formulas.normal_piece(self.normal_base, self.penalty, self.tension, g)
        shear = formulas.shear_piece(self.shear_base, self.shear_penalty, self.bound, s)
        return normal.astype(np.int8), shear.astype(np.int8)

    def same_pieces(self, first, second) -> bool:
        """True when two (normal, shear) piece sets give the same quadratic: the shear
        pieces of a contact without a shear term (ps = 0 or b = 0) do not count."""
        if not np.array_equal(first[0], second[0]):
            return False
        live = (self.shear_penalty > 0.0) & (self.bound > 0.0)
        return bool(np.array_equal(first[1][live], second[1][live]))

    def springs(self, normal: np.ndarray, shear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Second derivatives (kn, ks) on the given pieces: the contact springs of K."""
        kn = formulas.normal_spring(self.penalty, normal)
        ks = formulas.shear_spring(self.shear_penalty, shear)
        return kn, ks

    def offsets(
        self, normal: np.ndarray, shear: np.ndarray, g0: np.ndarray, s0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Forces of the pieces' quadratics at D = 0: N = offset_n + kn ∇g·D, likewise F.

        Elastic normal: λn + p g0; at the limit: −T. Stuck: λt + ps s0; slipping: ±b.
        """
        normal_offset = formulas.normal_offset(
            self.normal_base, self.penalty, self.tension, g0, normal
        )
        shear_offset = formulas.shear_offset(
            self.shear_base, self.shear_penalty, self.bound, s0, shear
        )
        return normal_offset, shear_offset

    def energy(self, g: np.ndarray, s: np.ndarray) -> float:
        """Σ φn(g) + Σ φt(s) (the formulas of the module docstring)."""
        normal = formulas.normal_energy(self.normal_base, self.penalty, self.tension, g)
        with np.errstate(divide="ignore", invalid="ignore"):
            shear = formulas.shear_energy(self.shear_base, self.shear_penalty, self.bound, s)
        return float(np.sum(normal) + np.sum(np.where(self.shear_penalty > 0.0, shear, 0.0)))
