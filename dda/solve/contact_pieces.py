"""The contact pieces of the step's potential, for the compiled Newton passes.

:class:`dda.contact.potential.ContactTerms`'s pieces, springs, offsets and energy,
contact by contact (:mod:`dda.solve.band_newton` calls them), each the formula of
:mod:`dda.contact.formulas` compiled:

    normal piece: elastic where λn + p g ≥ −T, else at the limit;
    shear piece: stuck where |λt + ps s| < b, else sliding (±1);
    springs: kn = p (elastic), ks = ps (stuck, with friction), else 0;
    offsets: N₀ = λn + p g₀ (elastic) or −T; T₀ = λt + ps s₀ (stuck) or ±b.
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import (
    normal_energy,
    normal_offset,
    normal_piece,
    normal_spring,
    shear_energy,
    shear_offset,
    shear_piece,
    shear_spring,
)
from dda.jit import kernel


def _pieces(lam_n, p, tension, lam_t, ps, bound, g, s, normal, shear):
    """:meth:`dda.contact.potential.ContactTerms.pieces`, written into ``normal``, ``shear``."""
    for c in range(g.shape[0]):
        normal[c] = normal_piece(lam_n[c], p[c], tension[c], g[c])
        shear[c] = shear_piece(lam_t[c], ps[c], bound[c], s[c])


def _same_pieces(ps, bound, normal, shear, other_normal, other_shear):
    """:meth:`~dda.contact.potential.ContactTerms.same_pieces`."""
    for c in range(normal.shape[0]):
        if normal[c] != other_normal[c]:
            return False
        if ps[c] > 0.0 and bound[c] > 0.0 and shear[c] != other_shear[c]:
            return False
    return True


def _springs(p, ps, friction, normal, shear, kn, ks):
    """The springs of the pieces into ``kn``, ``ks``: p on the elastic normal piece,
    ps on the stuck shear piece (with friction), else 0."""
    for c in range(normal.shape[0]):
        kn[c] = normal_spring(p[c], normal[c])
        ks[c] = shear_spring(ps[c], shear[c]) if friction else 0.0


def _same_springs(kn, ks, springs):
    """True when (kn, ks) are the springs of the kept factorisation (``springs`` (2, m))."""
    for c in range(kn.shape[0]):
        if kn[c] != springs[0, c] or ks[c] != springs[1, c]:
            return False
    return True


def _offsets(lam_n, p, tension, lam_t, ps, bound, g0, s0, normal, shear):
    """(N₀, T₀) of the pieces: λn + p g₀ on the elastic normal piece, −T off it;
    λt + ps s₀ stuck, ±b sliding."""
    m = normal.shape[0]
    offset_n, offset_t = np.empty(m), np.empty(m)
    for c in range(m):
        offset_n[c] = normal_offset(lam_n[c], p[c], tension[c], g0[c], normal[c])
        offset_t[c] = shear_offset(lam_t[c], ps[c], bound[c], s0[c], shear[c])
    return offset_n, offset_t


def _add_contact_energy(value, lam_n, p, tension, lam_t, ps, bound, g, s):
    """``value`` + Σ φn(g) + Σ φt(s), added contact by contact."""
    for c in range(g.shape[0]):
        value += normal_energy(lam_n[c], p[c], tension[c], g[c])
        if ps[c] > 0.0:
            value += shear_energy(lam_t[c], ps[c], bound[c], s[c])
    return value


_pieces = kernel(_pieces) or _pieces
_same_pieces = kernel(_same_pieces) or _same_pieces
_springs = kernel(_springs) or _springs
_same_springs = kernel(_same_springs) or _same_springs
_offsets = kernel(_offsets) or _offsets
_add_contact_energy = kernel(_add_contact_energy) or _add_contact_energy
