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

# pieces of a contact's terms (shear: which side of the friction bound, or stuck)
NORMAL_LIMIT, NORMAL_ELASTIC = 0, 1  # at the limit −T (open when T = 0) / elastic spring
SLIP_BACK, STICK, SLIP_FORWARD = -1, 0, 1


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
        return self.normal_base + self.penalty * g

    def shear_trial(self, s: np.ndarray) -> np.ndarray:
        return self.shear_base + self.shear_penalty * s

    def normal_force(self, g: np.ndarray) -> np.ndarray:
        """N = max(λn + p g, −T)."""
        return np.maximum(self.normal_trial(g), -self.tension)

    def shear_force(self, s: np.ndarray) -> np.ndarray:
        """F = clamp(λt + ps s, −b, b)."""
        return np.clip(self.shear_trial(s), -self.bound, self.bound)

    def pieces(self, g: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(normal piece, shear piece) of every contact at (g, s).

        On a kink the normal term is taken elastic (a contact that just touches is
        most likely to stay closed) and the shear term slipping (a contact at the
        friction bound is most likely to go on sliding; with b = 0 it has no stuck piece).
        """
        normal = np.where(self.normal_trial(g) >= -self.tension, NORMAL_ELASTIC, NORMAL_LIMIT)
        trial = self.shear_trial(s)
        shear = np.where(trial >= self.bound, SLIP_FORWARD, STICK)
        shear = np.where(trial <= -self.bound, SLIP_BACK, shear)
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
        kn = np.where(normal == NORMAL_ELASTIC, self.penalty, 0.0)
        ks = np.where(shear == STICK, self.shear_penalty, 0.0)
        return kn, ks

    def offsets(
        self, normal: np.ndarray, shear: np.ndarray, g0: np.ndarray, s0: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Forces of the pieces' quadratics at D = 0: N = offset_n + kn ∇g·D, likewise F.

        Elastic normal: λn + p g0; at the limit: −T. Stuck: λt + ps s0; slipping: ±b.
        """
        normal_offset = np.where(normal == NORMAL_ELASTIC, self.normal_trial(g0), -self.tension)
        shear_offset = np.where(shear == STICK, self.shear_trial(s0), shear * self.bound)
        return normal_offset, shear_offset

    def energy(self, g: np.ndarray, s: np.ndarray) -> float:
        """Σ φn(g) + Σ φt(s) (the formulas of the module docstring)."""
        p, ps = self.penalty, self.shear_penalty
        trial = self.normal_trial(g)
        limited = trial < -self.tension
        force = np.maximum(trial, -self.tension)
        normal = (force**2 - self.normal_base**2) / (2.0 * p)
        normal = normal - np.where(limited, self.tension * (trial + self.tension) / p, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            shear_trial = self.shear_trial(s)
            friction = self.shear_force(s)
            excess = np.maximum(np.abs(shear_trial) - self.bound, 0.0)
            shear = (friction**2 - self.shear_base**2) / (2.0 * ps) + self.bound * excess / ps
        return float(np.sum(normal) + np.sum(np.where(ps > 0.0, shear, 0.0)))
