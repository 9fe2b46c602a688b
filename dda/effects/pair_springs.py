"""Linear springs that couple the unknowns of two blocks (rock bolts).

A spring b between block i and block j has a stretch linear in the step D,

    e_b(D) = e0_b + r_i·D_i + r_j·D_j        (r_i, r_j: 1x6 rows, like a contact's ∇g)

and the energy f_b e_b + ½ k_b e_b², with a constant force f_b (pretension)
and a stiffness k_b ≥ 0: a convex quadratic in D. Its constant part (the force
f_b + k_b e0_b at D = 0) is a load vector, -(f_b + k_b e0_b)(r_i, r_j)ᵀ, that
the owning effect adds to F; what is left, ½ k_b (r_i·D_i + r_j·D_j)², is
the part held here: it adds

    K_ii += k r_iᵀ r_i,  K_ij += k r_iᵀ r_j,  K_ji += k r_jᵀ r_i,  K_jj += k r_jᵀ r_j

to K, through the same scatter as a contact spring (:mod:`dda.solve.assembly`), and
k (r·D) r to the product K₀D of the step's quadratic (:mod:`dda.solve.newton`), so
the Newton solve, its line search and its residual all see the same energy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np


@dataclass(frozen=True)
class PairSprings:
    """m springs between blocks ``block_i`` and ``block_j`` (rows of the BlockSet)."""

    block_i: np.ndarray  # (m,) int
    block_j: np.ndarray  # (m,) int
    row_i: np.ndarray  # (m, 6) ∂e/∂D_i
    row_j: np.ndarray  # (m, 6) ∂e/∂D_j
    stiffness: np.ndarray  # (m,) k ≥ 0

    def __len__(self) -> int:
        return len(self.block_i)

    def stretch(self, d: np.ndarray) -> np.ndarray:
        """r_i·D_i + r_j·D_j of every spring, (m,)."""
        return np.einsum("mr,mr->m", self.row_i, d[self.block_i]) + np.einsum(
            "mr,mr->m", self.row_j, d[self.block_j]
        )

    def product(self, d: np.ndarray) -> np.ndarray:
        """The springs' part of K D, (n, 6): Σ k (r·D) (r_i on block i, r_j on block j)."""
        force = self.stiffness * self.stretch(d)
        out = np.zeros_like(d)
        np.add.at(out, self.block_i, force[:, None] * self.row_i)
        np.add.at(out, self.block_j, force[:, None] * self.row_j)
        return out

    @classmethod
    def join(cls, parts: Sequence[PairSprings]) -> PairSprings | None:
        """All springs of ``parts`` in one set; None when there are none."""
        parts = [p for p in parts if p is not None and len(p)]
        if not parts:
            return None
        if len(parts) == 1:
            return parts[0]
        return cls(*(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)))
