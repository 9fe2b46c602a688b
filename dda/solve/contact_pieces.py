"""The contact pieces of the step's potential, for the compiled Newton passes.

Compiled twins of :class:`dda.contact.potential.ContactTerms`'s pieces, springs,
offsets and energy, contact by contact (:mod:`dda.solve.band_newton` calls them):

    normal piece: elastic (1) where λn + p g ≥ −T, else open (0);
    shear piece: stuck (0) where |λt + ps s| < b, else sliding (±1);
    springs: kn = p (elastic), ks = ps (stuck, with friction), else 0;
    offsets: N₀ = λn + p g₀ (elastic) or −T; T₀ = λt + ps s₀ (stuck) or ±b.
"""

from __future__ import annotations

import numpy as np

from dda.jit import kernel


def _pieces(lam_n, p, tension, lam_t, ps, bound, g, s, normal, shear):
    """:meth:`dda.contact.potential.ContactTerms.pieces`, written into ``normal``, ``shear``."""
    for c in range(g.shape[0]):
        normal[c] = 1 if lam_n[c] + p[c] * g[c] >= -tension[c] else 0
        trial = lam_t[c] + ps[c] * s[c]
        if trial <= -bound[c]:
            shear[c] = -1
        elif trial >= bound[c]:
            shear[c] = 1
        else:
            shear[c] = 0


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
        kn[c] = p[c] if normal[c] == 1 else 0.0
        ks[c] = ps[c] if shear[c] == 0 and friction else 0.0


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
        if normal[c] == 1:
            offset_n[c] = lam_n[c] + p[c] * g0[c]
        else:
            offset_n[c] = -tension[c]
        if shear[c] == 0:
            offset_t[c] = lam_t[c] + ps[c] * s0[c]
        else:
            offset_t[c] = shear[c] * bound[c]
    return offset_n, offset_t


def _add_contact_energy(value, lam_n, p, tension, lam_t, ps, bound, g, s):
    """``value`` + Σ φn(g) + Σ φt(s), added contact by contact."""
    for c in range(g.shape[0]):
        trial = lam_n[c] + p[c] * g[c]
        force = max(trial, -tension[c])
        value += (force * force - lam_n[c] * lam_n[c]) / (2.0 * p[c])
        if trial < -tension[c]:
            value -= tension[c] * (trial + tension[c]) / p[c]
        if ps[c] > 0.0:
            shear_trial = lam_t[c] + ps[c] * s[c]
            friction = min(max(shear_trial, -bound[c]), bound[c])
            excess = max(abs(shear_trial) - bound[c], 0.0)
            value += (friction * friction - lam_t[c] * lam_t[c]) / (2.0 * ps[c])
            value += bound[c] * excess / ps[c]
    return value


_pieces = kernel(_pieces) or _pieces
_same_pieces = kernel(_same_pieces) or _same_pieces
_springs = kernel(_springs) or _springs
_same_springs = kernel(_same_springs) or _same_springs
_offsets = kernel(_offsets) or _offsets
_add_contact_energy = kernel(_add_contact_energy) or _add_contact_energy
