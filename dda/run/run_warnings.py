"""What a finished run should tell its user although nothing failed: energy the
numerics created, contacts that sank deep into each other, a time step cut at most
steps, a static analysis whose blocks still move. Each is one sentence in
``summary["warnings"]``, said once at the end of the run (`dda run` prints them)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

# the blocks' energy above E0 + W, over the energy that moved in the run (the largest
# kinetic, |ΔV|, elastic, contact energy or |W|), beyond which the run created energy
# that matters (numerics may dissipate, never create)
ENERGY_WARNING = 0.01

# the largest penetration, over the size (4 area / perimeter: twice a sliver's thickness)
# of the smallest free block, beyond which the contacts no longer model touching blocks
# (the shipped cases: ≤ 2.9e-4; the paper's pure penalty case, Fig. 2a, 0.11: the
# penetration the augmented Lagrangian removes)
PENETRATION_WARNING = 0.01
# the largest change of a free block's in-situ stress by the equilibrium start, as a
# fraction of the field, that the run takes as the field kept (tunnel_deep: 6e-5; a
# field with free outer blocks and no boundary stress: ~1)
IN_SITU_KEPT = 0.1
# the share of the steps cut (Δt shortened after a failed attempt) beyond which the
# time step is too large for the model
CUT_STEPS_WARNING = 0.5
# a static analysis's last step moving a vertex by more than this fraction of the
# allowed displacement per step: the blocks have not come to rest (a settled model's
# last step moves them by 0; a block without support by its free fall in one step)
STATIC_MOTION_WARNING = 1e-3
# ... or with a force its last step's damping (2M/Δt² D) held above this share of a
# block's weight: the forces are not yet those of equilibrium
STATIC_UNBALANCED_WARNING = 1e-3


def smallest_free_size(sizes: np.ndarray, fixed: np.ndarray) -> float | None:
    """The smallest size (``sizes``: :func:`dda.geometry.block_sizes`) of a free block;
    None where every block is fixed."""
    free = ~np.asarray(fixed, bool)
    return float(np.asarray(sizes)[free].min()) if free.any() else None


def penetration_warning(
    max_penetration: float, size: float | None, length: str, augmented: bool
) -> str | None:
    """The sentence when the largest penetration exceeds :data:`PENETRATION_WARNING` of
    the smallest free block's ``size`` (:func:`smallest_free_size`; None: no free
    block), else None; its advice for the contact method (``augmented``: the augmented
    Lagrangian's tolerance, else the penalty)."""
    if size is None or max_penetration <= PENETRATION_WARNING * size:
        return None
    advice = (
        "lower [contact] tolerance (the penetration the augmented Lagrangian accepts)"
        if augmented
        else 'raise [contact] penalty, or use the "augmented-lagrangian" method'
    )
    return (
        f"contacts penetrated by up to {max_penetration:.3g} {length}, "
        f"{100.0 * max_penetration / size:.3g} % of the smallest free block's size "
        f"({size:.3g} {length}, 4 × area / perimeter): {advice}"
    )


# a block turning this much a step (rad) is named as the energy's likely source
TURN_A_STEP = 1e-3
# restitution: the contact penalty above this share of the blocks' Young's modulus
RESTITUTION_PENALTY = 0.1
# ... and the share of each rebound the velocity update may take beyond e unsaid
RESTITUTION_STEP_LOSS = 0.05


def restitution_warning(
    joints: list[str], penalty: float, young: float, force: str, length: str
) -> str | None:
    """The sentence when joints with ``restitution`` (named in ``joints``) meet a contact
    penalty p above :data:`RESTITUTION_PENALTY` of the blocks' smallest Young's modulus E:
    the dashpot beside each contact spring is tuned to a rigid block on the spring p,
    and where the block is as soft as the contact its own elasticity takes the impact and
    gives it back (a 1 m × 0.5 m block, E = 1e9 Pa, dropped at 1.05 m/s with e = 0.3:
    rebounds at 0.29, 0.41 and 0.70 of its impact speed with p = E/10, E and 10 E)."""
    if not joints or penalty <= RESTITUTION_PENALTY * young:
        return None
    names = ", ".join(f"joints.{name}" for name in joints)
    return (
        f"{names}: restitution needs contact springs softer than the blocks, [contact] "
        f"penalty ≤ {RESTITUTION_PENALTY:g} × Young's modulus ({RESTITUTION_PENALTY * young:.3g} "
        f"{force}/{length}); with {penalty:.3g} the blocks' own elasticity takes part of "
        "each impact and gives it back, and the rebound departs from e (docs/contact.md, "
        "restitution)"
    )


def restitution_step_warning(
    joints: list[str], omega: float, dt: float, gamma: float, time: str
) -> str | None:
    """The sentence when the velocity update's own damping takes more than
    :data:`RESTITUTION_STEP_LOSS` off each rebound beyond e: its damping ratio
    (γ − ½) ω Δt / 2 over an impact's half period π/ω leaves exp(−π (γ − ½) ω Δt / 2) of
    the rebound speed (ω: the stiffest impact's, √(2p/m) of the lightest free block on
    two contacts). A 1 m block, m = 2500 kg, p = 1e9 N/m, e = 1, γ = 1 rebounds at 0.704,
    0.933 and 0.966 at Δt = 5e-4, 1e-4 and 5e-5 s; the formula gives 0.704, 0.932, 0.965."""
    rate = np.pi * (gamma - 0.5) * omega / 2.0  # the loss's exponent per unit of Δt
    if not joints or rate * dt <= -np.log1p(-RESTITUTION_STEP_LOSS):
        return None
    names = ", ".join(f"joints.{name}" for name in joints)
    enough = -np.log1p(-RESTITUTION_STEP_LOSS) / rate
    return (
        f"{names}: at Δt = {dt:.3g} {time} the velocity update (newmark_gamma = {gamma:g}) "
        f"takes about {100.0 * -np.expm1(-rate * dt):.0f} % more off each rebound than "
        f"restitution's e (impacts of {np.pi / omega:.3g} {time}, ω = √(2p/m) = "
        f"{omega:.3g} rad/{time} of the lightest free block); Δt ≤ {enough:.2g} {time} keeps "
        f"it within {100.0 * RESTITUTION_STEP_LOSS:g} % (docs/contact.md, restitution)"
    )


def fracture_warning(min_area: float, areas: np.ndarray, length: str) -> str | None:
    """The sentence when ``[fracture]`` can break no block: no free block's material is
    breakable (``areas``, of the free breakable blocks, empty), or none is as large as
    two pieces of ``min_area`` (the smallest a block must be to split); else None."""
    areas = np.asarray(areas, float)
    if not len(areas):
        return (
            "[fracture] is set, but no free block's material has the strength keys "
            "(cohesion, friction_angle, tensile_strength): no block could break"
        )
    if areas.max() >= 2.0 * min_area:
        return None
    return (
        f"[fracture] min_area {min_area:.3g} {length}² is more than half of every "
        f"breakable block's area (the largest {areas.max():.3g} {length}²): no block "
        "could break (a block splits into pieces of at least min_area)"
    )


def cut_steps_warning(
    cut_steps: int, steps: int, smallest_dt: float, time_step: float
) -> str | None:
    """The sentence when more than :data:`CUT_STEPS_WARNING` of the steps were cut."""
    if steps <= 0 or cut_steps <= CUT_STEPS_WARNING * steps:
        return None
    return (
        f"the time step was cut at {cut_steps} of {steps} steps (to {smallest_dt:.3g} s at "
        f"the smallest, from analysis.time_step = {time_step:.3g} s): blocks move further "
        "in one step than the analysis allows; a smaller time_step takes fewer attempts"
    )


# a static run's moves fall (the blocks settle) when the last step's is at most this share
# of the one before: a stiff bolt at Δt = 1e-4 creeps with ρ = 1 − 2e-5, while a block
# sliding beyond its friction moves alike each step, ρ = 1 within 1e-8 (2e-11 at 20° on a
# 30° plane, Δt = 0.01), where the way "still to go", moved ρ / (1 − ρ), is round-off's
SETTLING = 1.0 - 1e-6


def static_motion_warning(
    moved: float,
    before: float,
    allowed: float,
    block: str,
    length: str,
    unbalanced: tuple[float, str, str] = (0.0, "", "weight"),
    back: bool = False,
) -> str | None:
    """The sentence when a static analysis has not come to rest: the blocks' way still to
    go, :func:`still_to_go` of the last step's largest vertex move ``moved`` (of ``block``)
    and the one before it ``before``, above :data:`STATIC_MOTION_WARNING` of the allowed
    displacement per step; or a block's force that the last step's damping held,
    ``unbalanced`` = (its share of the block's weight, or without gravity of the largest
    load on a block: ``of`` "weight" or "load"; the block; ``of``), above
    :data:`STATIC_UNBALANCED_WARNING` (a stiff bolt or contact that creeps by next to
    nothing a step still misses that share of its force). The way still to go is said
    only where the moves fall: where they do not (a block sliding beyond its friction,
    or without support) its estimate is round-off. ``back``: the last step moved that
    vertex back against the step before: the run alternates between two states (an
    audit: a bonded mass round an opening moved 4.5e-7 m to and fro at every step, said
    as "about 0.0143 m more at that rate"; at half its Δt it settled), which no rate of
    settling describes."""
    left = still_to_go(moved, before, allowed)
    share, heaviest, of = unbalanced
    if left <= STATIC_MOTION_WARNING * allowed and share <= STATIC_UNBALANCED_WARNING:
        return None
    if back:
        return (
            f"the static analysis ended moving to and fro: block {block!r} moved {moved:.3g} "
            f"{length} in the last step, back against the step before ({before:.3g} "
            f"{length}). It alternates between two states (a contact that opens and closes, "
            "or slips and sticks, at alternate steps): its blocks stand within about that "
            "of their rest; a smaller time_step can settle it (that scene at half the "
            "time_step did)"
        )
    falling = 0.0 < before and moved <= SETTLING * before
    more = f", about {left:.3g} {length} more at that rate" if falling else ""
    held = ""
    if share > STATIC_UNBALANCED_WARNING:
        whose = f"block {heaviest!r}'s weight" if of == "weight" else "the largest load on a block"
        held = f"; the last step's damping held {share:.2g} of {whose}"
    return (
        f"the static analysis ended with blocks still moving: block {block!r} moved "
        f"{moved:.3g} {length} in the last step{more}{held}. A block without support, or "
        "sliding beyond its joints' friction, has no equilibrium; else the analysis needs "
        "more steps (or a larger time_step: in a static analysis Δt sets how far a step goes)"
    )


def still_to_go(moved: float, before: float, allowed: float) -> float:
    """How far the blocks of a static analysis still move, from the last two steps'
    largest vertex moves: a static step of Shi's takes each slow mode a fraction ρ of the
    way left (its moves fall by ρ = 1 − k Δt² / 2m a step: a block held by a bolt of
    stiffness k at Δt = 1e-4 creeps by 1e-8 m a step with 5e-4 m to go), so the way left
    is moved ρ / (1 − ρ) with ρ = moved / before; infinite where the moves do not fall
    (a block without support), and the last move itself where there is no step before.
    Moves at round-off (1e-12 of the allowed step) count as none."""
    if moved <= 1e-12 * allowed:
        return 0.0
    if before <= 0.0:
        return moved
    ratio = moved / before
    return moved * ratio / (1.0 - ratio) if ratio < 1.0 else np.inf


# of |E₀| + max |W| + the energy that moved: the energies' round-off (a 400-block mass in
# its in-situ field, nothing moving beyond 1e-14 m, E₀ = 3.6e5 J, "created" 1.2e-6 J:
# 3.4e-12 of E₀, summed over the blocks' strain energies at every step)
ENERGY_ROUND_OFF = 1e-10


def energy_excess(
    history: Mapping[str, Sequence[float]],
    initial: float,
    contacts: bool = True,
    start: Mapping[str, float] | None = None,
) -> tuple[float, float, float]:
    """(the largest excess of the stored energy over E₀ + W − X at a step, the energy that
    moved: the largest kinetic, |ΔV|, elastic, contact energy or |W| of the run, and
    |E₀| + max |W|) of a run's ``history`` (its energy columns) and its E₀; X the energy of
    the blocks the stages removed so far (``excavated_energy``; it leaves the account, and
    the fall of V it makes at a stage is no motion). ``start``: the energies at the start
    (:meth:`dda.run.energy.EnergyTerms.as_dict`; None: no elastic or contact energy), from
    which the elastic and contact energies that moved are measured: a run that starts
    loaded (the equilibrium start, an in-situ field) holds them from t = 0, still.

    Without ``contacts`` a rise of the contact springs' energy C above its start C₀ is
    excused: E + X − E₀ − W − max(0, C − C₀) (the history's Σ N²/(2p) overstates what an
    augmented-Lagrangian contact holds, and it rises as a block settles). What the
    springs held at the start and gave back stays in the account: a run that starts
    loaded does not hide energy its blocks gain up to C₀ (an audit: two bonded blocks
    spun at 4 rad/s gained 352 J, said alone and unsaid beside a block pressed on a
    floor, C₀ = 1,348 J). With C₀ = 0 that is the blocks' energy E − C against
    E₀ + W − X."""
    total = np.asarray(history["total_energy"], float)
    if not len(total):
        return 0.0, 0.0, 0.0
    start = {} if start is None else start
    elastic = np.asarray(history["elastic_energy"], float) - start.get("elastic", 0.0)
    contact = np.asarray(history["contact_energy"], float) - start.get("contact", 0.0)
    if not contacts:
        total = total - np.maximum(contact, 0.0)
    work = np.asarray(history["external_work"], float)
    excavated = np.asarray(history.get("excavated_energy", np.zeros(len(total))), float)
    potential = np.asarray(history["potential_energy"], float)
    fall = np.diff(potential, prepend=potential[0])
    fall[np.diff(excavated, prepend=excavated[0]) != 0.0] = 0.0  # a stage removed blocks
    moved = max(
        float(np.max(history["kinetic_energy"])),
        float(np.abs(np.cumsum(fall)).max()),
        float(np.abs(elastic).max()),
        float(np.abs(contact).max()),
        float(np.abs(work).max()),
    )
    excess = float(np.max(total + excavated - initial - work))
    return excess, moved, abs(initial) + float(np.abs(work).max())


def energy_warning(
    history: Mapping[str, Sequence[float]],
    initial: float,
    pushed_steps: int = 0,
    fastest: tuple[str, float, float] | None = None,
    units: tuple[str, str] = ("m", "s"),
    turning: tuple[str, float, float] | None = None,
    start: Mapping[str, float] | None = None,
) -> str | None:
    """The sentence when the blocks' energy (kinetic, potential, elastic, bolts') rose
    above E₀ + W by more than :data:`ENERGY_WARNING` of the energy that moved
    (:func:`energy_excess` without the contacts' springs; ``start``: the energies at the
    start, C₀ the springs'). A rise of the contact springs' energy above C₀ is left out:
    the history counts Σ N²/(2p), which overstates what an augmented Lagrangian contact
    holds at its small penetration (the paper's two blocks: 1.12 ft·lb against 0.27 of
    work), so that it rises as a block settles on its base while nothing moves; energy
    that appears in the blocks beyond what the springs gave back came from nowhere. For
    dynamic analyses: a static one sets the velocities to 0 at every step, and its
    pseudo-steps are no energy balance (a block hung from a fixed point and turned
    0.6 rad stores 2.3e5 J in the point's spring in its first step, 29 times its
    potential energy's fall).

    It gives the evidence the run holds for a cause: the steps at which the push-out
    removed overlaps (``pushed_steps``: blocks drawn overlapping, or a block moved into
    another within a step), and the fastest block at the run's end (``fastest``: name,
    speed, slenderness (half its perimeter)² / area), as a time step too long for the
    contacts of a small or thin block leaves it (a 4.5 m long wedge of 2.8 m² on the
    boundary of a tunnel section in a 13 MPa field rattled at 7.5 m/s with Δt = 1 ms,
    the push-out acting at 10 of 30 steps, and the run gained 5.6e5 J; with Δt = 0.1 ms
    it stands and the excess is 1.1e3 J); and the fastest-turning block (``turning``:
    name, ω, its turn a step ω Δt), where a contact holds a turning block that is no
    sliver: the gaps are linearised within a step, and a contact that holds the block as
    it turns gains at second order in its turn (two bonded 1 m blocks spun at 4 rad/s
    at Δt = 1e-3 s gained 1.9 % of their kinetic energy in 2 s, ten times less at
    Δt = 1e-4)."""
    excess, moved, budget = energy_excess(history, initial, False, start)
    if excess <= ENERGY_WARNING * moved + ENERGY_ROUND_OFF * (moved + budget):
        return None
    ratio = excess / moved if moved > 0.0 else np.inf
    share = f"{100.0 * ratio:.2g} % of" if ratio < 1.0 else f"{ratio:.3g} times"
    said = (
        f"the run created energy: the blocks' energy rose {excess:.3g} above the initial "
        f"energy plus the work of the loads ({share} the energy that moved). "
    )
    if pushed_steps:
        said += (
            f"The push-out removed overlaps at {pushed_steps} step(s) by moving blocks, "
            "which lifts them against their loads or strains them where they cannot move "
            "as a whole: blocks drawn overlapping (draw them apart or touching: "
            "docs/contact.md, energy), or a block that moved into another within a step. "
        )
    if fastest is None:
        return said + "A smaller analysis.time_step gives less of it"
    name, speed, slenderness = fastest
    thin = f", a sliver {slenderness:.2g} times as long as thick" if slenderness > 20 else ""
    length, time = units
    fastest_is = f"The fastest block at the end is {name!r} ({speed:.3g} {length}/{time}{thin})"
    if not _any_contact_loaded(history):
        return said + (
            f"{fastest_is}. No contact carried a force in the run: the energy came from "
            "the time integration of the other effects (bolts, fixed points, water, the "
            "blocks' turning); a smaller analysis.time_step gives less of it"
        )
    if turning is not None and not thin and turning[2] >= TURN_A_STEP:
        block, omega, turn = turning
        return said + (
            f"The fastest-turning block is {block!r} ({omega:.3g} rad/{time}, {turn:.2g} rad "
            "a step): contact gaps are linearised within a step, and a contact that holds "
            "a turning block (bonded, or pressed) gains energy at second order in its "
            "turn; a smaller analysis.time_step gives less of it"
        )
    return said + (
        f"{fastest_is}: a "
        "time step too long for the contacts of a small or thin block lets it rattle; a "
        "smaller analysis.time_step gives less of it (or merge slivers: dda cut's "
        "min_block_area)"
    )


def _any_contact_loaded(history: Mapping[str, Sequence[float]]) -> bool:
    """Whether a contact held energy or penetrated at any step of ``history``."""
    return any(
        len(history.get(key, ())) and float(np.max(history[key])) > 0.0
        for key in ("contact_energy", "max_penetration")
    )


def in_situ_slip_warning(
    count: int, ratio: float, joint: str, where: tuple[float, float], length: str
) -> str | None:
    """The sentence when the in-situ field puts more shear on ``count`` contacts than
    their joint's strength holds (``ratio``, the largest |F| / b, on ``joint`` at
    ``where``): the mass slips along those joints from t = 0, as a scene whose joints
    cannot carry the field's tension would open (that one is refused at load)."""
    if count == 0:
        return None
    x, y = where
    much = f"up to {ratio:.3g} times it" if np.isfinite(ratio) else "where it holds none"
    return (
        f"the in-situ field's shear is beyond the strength of joint {joint!r} on {count} "
        f"contact(s), {much} (at ({x:.6g}, {y:.6g}) {length}): the rock mass slips along "
        "those joints from t = 0"
    )


def initial_stress_warning(change: float, block: str) -> str | None:
    """The sentence when the equilibrium start changed a free block's own initial stress
    (``[[blocks]] stress``, no ``[in_situ]``) by more than :data:`IN_SITU_KEPT` of the
    largest given (``change``, at ``block``): a stress that the contacts and the fixed
    blocks do not hold relaxes there, the block keeping its shape (an audit: a free
    block given −2 MPa started at 0, unsaid, where the same field as ``[in_situ]`` was
    said)."""
    if change <= IN_SITU_KEPT:
        return None
    return (
        f"the equilibrium start changed the initial stress of block {block!r} (its "
        f"blocks[].stress) by {100.0 * change:.0f} % of the largest given: a stress the "
        "contacts and the fixed blocks do not hold relaxes at the start, the block keeping "
        "its shape (hold it with neighbours, fixed blocks or [[boundary_stresses]], or "
        'release it as a motion with analysis.start = "unloaded")'
    )


def in_situ_warning(
    change: float, block: str, cause: str = "", by: str = "the equilibrium start"
) -> str | None:
    """The sentence when the equilibrium start changed a free block's in-situ stress by
    more than :data:`IN_SITU_KEPT` of the field (``change``, the largest, at ``block``),
    with its likely ``cause``: ``"slipped"`` (joints that carry less shear than the
    field puts on them, said apart), ``"opening"`` (openings drawn in the mass, whose
    walls hold no stress), ``"bounded"`` (the model has boundary stresses: joints
    weaker than the field, in tension too, or boundary stresses that do not hold it), else
    no boundary stresses."""
    if change <= IN_SITU_KEPT:
        return None
    said = (
        f"{by} changed the in-situ stress of block {block!r} by "
        f"{100.0 * change:.0f} % of the field (the largest): "
    )
    if cause == "slipped":
        return said + (
            "joints slip under the field's shear at t = 0 (the in-situ slip warning "
            "says where), and the blocks move until they hold"
        )
    if cause == "opening":
        return said + (
            "the field is not in equilibrium with the walls of the opening(s) drawn in the "
            "mass, which hold no stress: the start finds the stress around them, as "
            "excavating them at t = 0 would (excavate them by a stage to start from the "
            "field as given: docs/engineering.md)"
        )
    if cause == "bounded":
        return said + (
            "joints give way under it (in shear or tension: a strength below the field's), "
            "or the boundary stresses and the fixed blocks do not hold it as given (check "
            "their boxes and values against the in-situ stress)"
        )
    return said + (
        "the field is not in equilibrium with the model's boundary (give its free outer "
        "blocks [[boundary_stresses]], or fix their neighbours)"
    )


def unsettled_start_warning(newton_iterations: int, seconds: float) -> str:
    """The sentence of a run whose equilibrium start did not settle
    (:mod:`dda.run.equilibrium_start`): it started unloaded, as Shi's start does."""
    return (
        f"the equilibrium start did not settle ({newton_iterations} Newton iterations, "
        f"{seconds:.3g} s): the run started unloaded, its blocks dropping onto unloaded "
        "contact springs and ringing about their static state; blocks that should stand "
        "may creep or slip where friction is nearly used up (analysis.start = "
        '"unloaded" starts so at once)'
    )


def skipped_stages_warning(
    left: Sequence[float], steps: int, end: float, time: str = "s"
) -> str | None:
    """The sentence when a run given ``analysis.steps`` ended at ``end`` before the stages
    at the times ``left``: a step cut short to end at a stage's time grows back by 1.5×
    a step, so ``steps`` steps end before steps × time_step (an audit: a stage at 0.09 s of
    a run of 10 steps of 0.01 s never happened, unsaid; the run ended at 0.0821 s)."""
    if not len(left):
        return None
    first = float(left[0])
    return (
        f"{len(left)} stage(s) never applied: the run's {steps} steps ended at t = {end:.6g} "
        f"{time}, before the stage at t = {first:.6g} {time} (steps cut short to end at a "
        "stage's time take the run's time with them); give analysis.duration instead of "
        "analysis.steps to reach every stage"
    )
