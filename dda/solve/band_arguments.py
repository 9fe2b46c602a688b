"""The band kernels' arguments and results, named (:mod:`dda.solve.band_newton`,
:mod:`dda.solve.band_step`).

Each is a ``NamedTuple``: numba passes them to a compiled function as they are and
builds the results inside one, so a kernel takes a few named records instead of dozens
of positional arrays, and its caller reads a result by name.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dda.contact.strength import Strength


class BandGeometry(NamedTuple):
    """What does not change within a step, in band order: K₀, F₀ and the contacts'
    gradient rows."""

    blocks: np.ndarray  # (n, 6, 6) K₀'s diagonal blocks
    bolt_columns: np.ndarray  # (q, 12) unknowns of each bolt's two blocks (−1: fixed)
    bolt_rows: np.ndarray  # (q, 12) its rows [r_i r_j]
    bolt_k: np.ndarray  # (q,) its stiffnesses
    forces: np.ndarray  # (6 n,) F₀
    columns: np.ndarray  # (m, 12) unknowns of each contact's two blocks (−1: fixed)
    normal_rows: np.ndarray  # (m, 12) ∇g of each contact
    shear_rows: np.ndarray  # (m, 12) ∇s
    g0: np.ndarray  # (m,) gaps at D = 0
    s0: np.ndarray  # (m,) slips at D = 0


class BandTerms(NamedTuple):
    """The contact terms frozen within a Newton pass
    (:class:`dda.contact.potential.ContactTerms`)."""

    normal_base: np.ndarray  # λn
    penalty: np.ndarray  # p
    tension: np.ndarray  # T
    shear_base: np.ndarray  # λt
    shear_penalty: np.ndarray  # ps
    bound: np.ndarray  # b


class Factor(NamedTuple):
    """The kept factorisation: changed in place by the kernels."""

    band: np.ndarray  # (6 n, kd + 1) L in LAPACK's lower band storage
    springs: np.ndarray  # (2, m) the contact springs of the factorised K
    state: np.ndarray  # int64 flags: HAS_FACTOR, FACTORISATIONS, FAILED (band_newton)


class PassStart(NamedTuple):
    """Where a Newton pass starts."""

    d: np.ndarray  # (6 n,) D
    g: np.ndarray  # (m,) its gaps, when have_gaps
    s: np.ndarray  # (m,) its slips, when have_gaps
    have_gaps: bool
    normal: np.ndarray  # (m,) int8 the first iteration's normal pieces, when have_pieces
    shear: np.ndarray  # (m,) int8 its shear pieces
    have_pieces: bool


class PassRules(NamedTuple):
    """How a Newton pass spends its solves (:func:`dda.solve.newton.minimise`)."""

    max_solves: int  # Newton iterations
    max_steps: int  # Newton iterations and chord steps (< 0: no limit)
    rate: float  # chord steps go on while each leaves at most this of ‖∇Π‖
    chord_first: bool  # the first direction is the chord direction
    conjugate: bool  # successive chord steps conjugated
    tolerance: float  # converged at ‖∇Π‖ ≤ this · (‖K₀D‖ + ‖F₀‖ + ‖contact forces‖)


class PassOutcome(NamedTuple):
    """What a Newton pass returns."""

    d: np.ndarray
    g: np.ndarray
    s: np.ndarray
    solves: int  # Newton iterations
    chords: int  # chord steps
    converged: bool
    chord_next: bool  # the next direction would have been a chord direction
    finite: bool


class BandContacts(NamedTuple):
    """The contacts' law data at the step's start (:class:`dda.contact.contact_set.ContactSet`)."""

    intact: np.ndarray  # bool: bonded
    strength: Strength  # the joints' strength (:mod:`dda.contact.strength`)
    breakable: np.ndarray  # bool
    normal_multiplier: np.ndarray  # λn
    shear_multiplier: np.ndarray  # λt
    penalty: np.ndarray  # p
    fresh: np.ndarray  # bool: found this step
    state: np.ndarray  # int8: OPEN, SLIDING, LOCKED
    direction: np.ndarray  # slide direction
    last_normal: np.ndarray  # N at the last step's end
    penetration: np.ndarray  # g at the last step's end


class LawSettings(NamedTuple):
    """The contact law's settings (:class:`dda.contact.law.ContactLaw`)."""

    friction: bool
    augmented: bool
    shear_ratio: float
    tolerance: float
    shrink_target: float
    max_penalty: float
    growth: float
    friction_tolerance: float
    persistent: bool  # ContactLaw.persistent: a dynamic step's AL


class LoopRules(NamedTuple):
    """How the step's outer loop spends its solves (:class:`dda.solve.step._StepLoop`)."""

    dynamic: bool
    budget: int  # Newton iterations of the step
    between_bounds: int  # solves on one set of friction bounds
    guessed_solves: int  # ... while some bounds are a guess
    rate: float
    chord_first: bool
    conjugate: bool
    tolerance: float  # Newton's


class StepOutcome(NamedTuple):
    """What the compiled outer loop returns: the contacts' new data and its counts."""

    d: np.ndarray
    g: np.ndarray
    s: np.ndarray
    intact: np.ndarray
    normal_multiplier: np.ndarray
    penalty: np.ndarray
    state: np.ndarray
    direction: np.ndarray
    normal_force: np.ndarray
    shear_force: np.ndarray
    dissipated: float
    solves: int
    chords: int
    converged: bool
    finite: bool
    failed: bool
