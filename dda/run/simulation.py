"""The time loop: contacts, step solve, step control, update, frames, events."""

from __future__ import annotations

import logging
import time as wallclock
from array import array
from collections.abc import Callable

import numpy as np

from dda.blocks import BlockSet
from dda.contact import reach
from dda.contact.broad import KeptPairs
from dda.contact.contact_set import ContactSet
from dda.contact.formulas import normal_trial
from dda.contact.law import friction_bound
from dda.contact.pipeline import refresh_contacts
from dda.contact.preload import carry_stress, with_carried_forces
from dda.contact.push_out import pay_for_the_push
from dda.contact.rows import contact_rows
from dda.effects.base import StepContext
from dda.errors import SimulationError
from dda.fracture.fragments import parent_rows
from dda.fracture.inherited_contacts import after_breaking
from dda.geometry import block_sizes
from dda.jit import compile_seconds, run_work
from dda.model import SEARCH_FACTOR, Model, build
from dda.result import OPEN, FractureEvent, Frame, Result
from dda.run.checkpoint import Checkpoint, CheckpointPlan, check_scene, restore, scene_fingerprint
from dda.run.deep_overlap import Overlap, deeper, deepest_overlap, overlap_warning
from dda.run.energy import TERMS, EnergyAccount
from dda.run.environment import environment
from dda.run.equilibrium_start import StartInterrupted, Unsettled, settle
from dda.run.floating import note_unbalanced
from dda.run.frames import make_frame, shifted
from dda.run.measure import Probes
from dda.run.run_warnings import (
    IN_SITU_KEPT,
    cut_steps_warning,
    energy_warning,
    fracture_warning,
    in_situ_slip_warning,
    in_situ_warning,
    initial_stress_warning,
    penetration_warning,
    restitution_step_warning,
    restitution_warning,
    skipped_stages_warning,
    smallest_free_size,
    static_motion_warning,
    unsettled_start_warning,
)
from dda.run.stages import apply_due_stages, set_strengths
from dda.run.stop import StopOnSignal
from dda.scene import Scene
from dda.scene.edge_cover import opening_walls
from dda.scene.limits import check_run_size
from dda.scene.local_frame import local_origin, translated
from dda.solve.linsolve import single_threaded_blas
from dda.solve.policy import StepPolicy, current_policy
from dda.solve.step import LinearCache, StepSolution, solve_step
from dda.solve.timing import StageTimer
from dda.solve.update import apply_step, vertex_displacements

log = logging.getLogger(__name__)

MAX_CUTS = 40  # halvings of one step before the run gives up
GROWTH = 1.5  # time-step growth per accepted step, back up to the maximum after a cut
MIN_STEP_FRACTION = 1e-9  # smallest step, as a fraction of the maximum time step
BEYOND_REACH = "beyond the search reach"  # a step to redo after a full search, not to cut
# summary["start"] of a run whose equilibrium start did not settle
UNSETTLED_START = "unloaded (the equilibrium start did not settle)"
# ... and of one stopped by a signal while its equilibrium start ran (no step taken)
INTERRUPTED_START = "interrupted (the equilibrium start was stopped before it ended)"
# energy columns of Result.history (dda.run.energy): stored terms, their total, work of the
# loads, and the energy of the blocks the stages removed so far (E ≤ E₀ + W − that)
HISTORY_ENERGY = (
    *(f"{t}_energy" for t in TERMS), "total_energy", "external_work", "excavated_energy"
)  # fmt: skip


class _Run:
    """Mutable state of one run (kept out of the public API)."""

    def __init__(self, model: Model, policy: StepPolicy | None = None) -> None:
        self.model = model
        # the step's policy (the environment's by default), block pattern and solver
        self.linear = LinearCache(current_policy() if policy is None else policy)
        self.blocks: BlockSet = model.blocks.copy()
        self.contacts = ContactSet.empty()
        self.kept_pairs = KeptPairs()
        self.reach = model.allowed_displacement  # the next step's search reach (m)
        self.search_redos = 0  # steps redone after a search with the full distance
        self.time = 0.0
        self.step = 0
        self.dt = model.max_time_step
        self.timer = StageTimer()
        self.iterations = 0  # linear solves: Newton iterations and chord steps
        self.newton_iterations = 0  # assembled systems solved
        self.factorisations = 0
        self.cut_steps = 0
        self.smallest_cut_dt = np.inf  # the shortest step a cut made
        self.last_moves = None  # a static run's last step: (vertex moves, owners, names)
        self.move_before = 0.0  # a static run's largest vertex move in the step before
        self.moves_before = None  # a static run's vertex moves of the step before
        # the in-situ field's contacts whose shear is beyond their joint's strength at
        # t = 0: (count, largest ratio, joint, vertex)
        self.in_situ_slip = (0, 0.0, "", (0.0, 0.0))
        self.origin = (0.0, 0.0)  # the scene's point the run computes about (local_frame)
        # a static run's last step: the largest force its damping held, over the block's
        # weight, and that block's row
        self.static_held = (0.0, -1)
        self.max_iterations_step = 0
        self.friction_dissipation = 0.0
        self.max_penetration = 0.0
        self.events: list[FractureEvent] = []
        self.energy = EnergyAccount(model, self.blocks)
        self.stages_done = 0  # [[stages]] applied so far
        self.excavated_energy = 0.0  # energy of the blocks the stages removed
        self.probes = _probes(model, self.blocks)  # [[measure]], None without
        self.start = "unloaded"  # how the run started (dda.run.equilibrium_start)
        self.compiled_before = compile_seconds()  # the run's share goes in its summary
        self.start_newton_iterations = 0  # Newton iterations of the equilibrium start
        self.start_method = None  # how its limit solve settled (dda.run.equilibrium_start)
        self.start_seconds = 0.0  # its wall time, the search at t = 0 included
        self.start_compile_seconds = 0.0  # ... and its share of compile_seconds()
        self.in_situ_change = (0.0, "", "")  # what the start changed of the in-situ field
        self.initial_stress_relaxed: str | None = None  # ... or of the blocks' own stresses
        self.in_situ_given = None  # a static run's field at t = 0, while it is measured
        self.unbalanced: list[str] = []  # dda.run.floating's warnings, as they were said
        self.unbalanced_force = (0.0, 0.0, 0.0)  # ... and the net force and moment it said
        self.misplaced_bolts: list[str] = []  # stage bolts with an end off their block
        self.pushed_steps = 0  # steps whose push-out removed an overlap
        self.deepest_overlap: Overlap | None = None  # two blocks' at the saved frames
        self.history: dict[str, array] = {  # 8 bytes a number, not a list's 32
            k: array("q" if k == "iterations" else "d")
            for k in ("time", "dt", "iterations", "max_penetration", *HISTORY_ENERGY)
        }

    @property
    def shown_time(self) -> float:
        """The time the outputs show (history, frames, measurements, summary):
        :func:`shown_time` of the steps' sum."""
        return shown_time(self.time)

    def finished(self) -> bool:
        m = self.model
        if m.steps is not None:
            return self.step >= m.steps
        return self.time >= m.duration * (1 - 1e-12)

    def remaining(self) -> float:
        m = self.model
        return np.inf if m.steps is not None else m.duration - self.time

    def until_event(self) -> float:
        """Time to the end of the run or to the next stage, whichever comes first."""
        stages = self.model.stages
        if stages is None:
            return self.remaining()
        return min(self.remaining(), stages.next_time(self.stages_done) - self.time)


# significant digits of the time the outputs show
SHOWN_TIME_DIGITS = 12


def shown_time(time: float) -> float:
    """``time`` rounded to :data:`SHOWN_TIME_DIGITS` significant digits. The run's
    clock is the floating-point sum of its steps, which carries their round-off
    (315 steps of 0.01 s sum to 3.149999999999977 s); the outputs show 3.15 s. The
    run itself goes on with the exact sum (its stages, loads and end)."""
    return float(f"{time:.{SHOWN_TIME_DIGITS}g}")


def _probes(model: Model, blocks: BlockSet, contacts: ContactSet | None = None) -> Probes | None:
    """The run's measurements with the row of step 0 (``contacts``: those at t = 0, none
    by default), or None without ``[[measure]]``."""
    if not model.scene.measure:
        return None
    names = [] if model.bolts is None else model.bolts.names
    probes = Probes(model.scene.measure, blocks, names, model.exact_rotation)
    start = ContactSet.empty() if contacts is None else contacts
    probes.record(0, 0.0, blocks, start, model.bolts)
    return probes


def _attempt(run: _Run, start: ContactSet, dt: float) -> tuple[StepSolution | None, float, str]:
    """Solve one step of length dt; return (solution or None, factor to cut dt, reason)."""
    m = run.model
    ctx = StepContext(dt=dt, time=run.time + dt, step=run.step + 1, static=m.static)
    if m.ground is not None:  # fixed blocks that follow the ground: their step is known
        ctx.prescribed = m.ground.prescribed(run.blocks, ctx)
        if m.water is not None:  # ... and its water table: where it is at the step's end
            m.water.follow(ctx.time)
    solution = solve_step(m, run.blocks, start.copy(), ctx, run.timer, run.linear)
    if ctx.prescribed is not None:
        solution.d = solution.d + ctx.prescribed
    run.iterations += solution.iterations
    run.newton_iterations += solution.newton_iterations
    run.factorisations += solution.factorisations
    if not np.all(np.isfinite(solution.d)):
        return None, 0.25, "non-finite solution"
    if not solution.converged:
        return None, 0.5, "contacts did not settle"
    solution.moves = vertex_displacements(run.blocks, solution.d, m.exact_rotation)
    moved = np.abs(solution.moves).max(initial=0.0)
    if moved > m.allowed_displacement * (1 + 1e-9):
        return None, max(0.1, 0.9 * m.allowed_displacement / moved), "displacement above g2"
    if m.contact is not None and reach.beyond(moved, run.reach, m.allowed_displacement):
        return None, 1.0, BEYOND_REACH
    solution.moved = float(moved)
    return solution, 1.0, ""


def _equilibrium_start(run: _Run, report=None, stop=None) -> None:
    """Load the contacts that touch at t = 0, the blocks and the effects' springs
    (dda.run.equilibrium_start); a start that does not settle leaves the run unloaded.
    ``report``: the run's progress reporter, shown the start's Newton iterations;
    ``stop``: asked after each of the start's solves and interior-point iterations, True
    raises :class:`StartInterrupted`."""
    m = run.model
    started, compiled = wallclock.perf_counter(), compile_seconds()
    _touching_at_start(run)

    def spent(newton: int) -> None:
        if report is not None:
            info = {"step": 0, "time": 0.0, "equilibrium_start": f"{newton} Newton iterations"}
            report(0.0, info)
        if stop is not None and stop():
            run.start_seconds = wallclock.perf_counter() - started
            run.start_newton_iterations, run.start = newton, INTERRUPTED_START
            raise StartInterrupted

    with run.timer("start"):  # its own stages apart: the steps' stay the steps'
        settled = settle(m, run.blocks, run.contacts, StageTimer(), spent)
    if report is not None:
        report(0.0, {"step": 0, "time": 0.0, "equilibrium_start": None})
    run.start_seconds = wallclock.perf_counter() - started
    run.start_compile_seconds = compile_seconds() - compiled
    run.start_newton_iterations, run.start_method = settled.newton_iterations, settled.method
    if isinstance(settled, Unsettled):  # the run starts as an unloaded start would
        if m.scene.in_situ is None:
            run.contacts = ContactSet.empty()  # step 1 finds them afresh
        # else the contacts found at t = 0 carry the in-situ field (_touching_at_start)
        run.start = UNSETTLED_START
        return
    run.contacts = settled.contacts
    if m.scene.in_situ is not None:
        run.in_situ_change = _in_situ_change(run, settled.stress)
    elif np.any(run.blocks.stress[~run.blocks.fixed] != 0.0):  # the blocks' own stresses
        largest, name, _ = _in_situ_change(run, settled.stress, say=False)
        run.initial_stress_relaxed = initial_stress_warning(largest, name)
        if run.initial_stress_relaxed is not None:  # at once too: a long run may be stopped
            log.warning(run.initial_stress_relaxed)
    run.blocks.stress = settled.stress
    run.energy.initial = run.energy.measure(run.blocks, run.contacts)
    run.probes = _probes(m, run.blocks, run.contacts)  # step 0's row, loaded
    run.start = "equilibrium"
    log.info(
        "equilibrium start (%s): %d contact(s) loaded, %d Newton iteration(s), %.2f s",
        settled.method,
        int(np.count_nonzero(settled.contacts.state != OPEN)),
        settled.newton_iterations,
        run.start_seconds,
    )


def _beyond_strength(model: Model, blocks: BlockSet, contacts: ContactSet, origin):
    """(how many contacts carry an in-situ shear force beyond their friction bound, the
    largest |F| / b (inf where a joint holds no shear: no normal force, no cohesion), its
    joint's name, its vertex in the scene's coordinates, the run's less ``origin``) of the
    contacts that carry the field at t = 0 (N = λn + p g₀, F = λt,
    :mod:`dda.contact.preload`)."""
    cm = model.contact
    carrying = np.flatnonzero(contacts.state != OPEN)
    none = (0, 0.0, "", (0.0, 0.0))
    if not len(carrying) or not cm.law.friction:
        return none
    touching = contacts.subset(carrying)
    rows = contact_rows(blocks, touching)
    joint_rows = cm.joints.rows_for(blocks, touching)
    joints = cm.joints.properties(joint_rows, rows.length)
    normal = normal_trial(touching.normal_multiplier, touching.penalty, rows.penetration)
    bound = friction_bound(touching, joints, normal)
    shear = np.abs(touching.shear_multiplier)
    scale = float(np.abs(normal).max(initial=0.0))
    beyond = shear > bound + 1e-9 * scale
    if not np.any(beyond):
        return none
    with np.errstate(divide="ignore"):
        ratio = np.where(beyond, shear / bound, 0.0)
    k = int(np.argmax(ratio))
    x, y = blocks.vertices[touching.vertex[k]] + np.asarray(origin)
    name = cm.joints.names[joint_rows[k]]
    return int(np.count_nonzero(beyond)), float(ratio[k]), name, (float(x), float(y))


def _in_situ_change(
    run: _Run, settled: np.ndarray, given: np.ndarray | None = None, say: bool = True
) -> tuple[float, str, str]:
    """(largest change of a free block's stress by the equilibrium start over the
    largest in-situ stress, that block's name, its likely cause: :func:`in_situ_warning`).
    Above :data:`IN_SITU_KEPT` the start relaxed the field: joints slipped under its
    shear, or it is not in equilibrium with the model's boundary (a free outer block
    without boundary stresses or a fixed neighbour to carry it); said (``say``: at once
    too), not silent. ``given``: the field (default the blocks' stresses)."""
    blocks = run.blocks
    given = blocks.stress if given is None else given
    scale = float(np.abs(given).max())
    free = np.flatnonzero(~blocks.fixed)
    if scale == 0.0 or len(free) == 0:
        return 0.0, "", ""
    change = np.abs(settled[free] - given[free]).max(axis=1) / scale
    k = int(np.argmax(change))
    largest, name = float(change[k]), blocks.names[free[k]]
    cause = ""
    if largest > IN_SITU_KEPT:  # why (the openings asked only then: a union of the blocks)
        bounded = bool(run.model.scene.boundary_stresses)
        cause = "slipped" if run.in_situ_slip[0] else "opening" if _has_openings(blocks) else ""
        cause = cause or ("bounded" if bounded else "")
    said = in_situ_warning(largest, name, cause) if say else None
    if said is not None:  # at once, as well as in the summary: a long run may be stopped
        log.warning(said)
    return largest, name, cause


def _has_openings(blocks: BlockSet) -> bool:
    """True where the blocks' union has holes: openings drawn in the mass
    (:func:`dda.scene.edge_cover.opening_walls`)."""
    polygons = [blocks.polygon(i) for i in range(blocks.count)]
    return opening_walls(polygons) is not None


def _static_in_situ_change(run: _Run) -> None:
    """A static run's :func:`_in_situ_change`: its steps from the unloaded start relax a
    field its boundary does not hold (82 % of a field in a mass without boundary stresses,
    unsaid: the check was the equilibrium start's, which a static run has not), measured
    after each step until the first stage or fracture changes the model."""
    given = run.in_situ_given
    if given is None:
        return
    if run.stages_done or len(given) != run.blocks.count:
        run.in_situ_given = None
        return
    change = _in_situ_change(run, run.blocks.stress, given, say=False)
    run.in_situ_change = (*change, "the static steps")


def _touching_at_start(run: _Run) -> None:
    """The contacts at t = 0, carrying the scene's in-situ stress (dda.contact.preload)."""
    _search(run, ContactSet.empty())
    field = run.model.scene.in_situ
    if field is not None and run.model.contact is not None:
        run.contacts = carry_stress(run.blocks, run.contacts, field)
        run.energy.initial = run.energy.measure(run.blocks, with_carried_forces(run.contacts))
        run.in_situ_slip = _beyond_strength(run.model, run.blocks, run.contacts, run.origin)


def _search(run: _Run, previous: ContactSet) -> None:
    """The step's contacts, from ``previous`` (the last step's), searched as far as
    the run's reach (:mod:`dda.contact.reach`)."""
    m = run.model
    if m.contact is None:
        return
    with run.timer("contact_search"):
        gap = SEARCH_FACTOR * run.reach
        motion = reach.coming_motion(run.blocks, run.dt, m.scene.analysis.gravity)
        run.contacts = refresh_contacts(
            run.blocks, previous, m.contact, run.kept_pairs, gap, motion
        )


def _step_length(dt: float, remaining: float) -> float:
    """Length of the next step: ``dt``, shortened to end the run exactly at its duration.

    When less than two steps remain, the rest is split in two equal steps
    instead of leaving a sliver: in a step 1e-3 of the normal one, any
    penetration left to remove becomes a velocity of 2 d/Δt (Shi's update).
    """
    if remaining <= dt * (1.0 + 1e-9):  # the last step (round-off in the time sum)
        return remaining
    if remaining < 2.0 * dt:
        return 0.5 * remaining
    return dt


def _advance(run: _Run) -> None:
    """Compute and apply one step, cutting Δt until it is acceptable."""
    m = run.model
    previous = run.contacts
    _search(run, previous)
    dt = _step_length(run.dt, run.until_event())
    cut = 0
    while True:
        solution, factor, reason = _attempt(run, run.contacts, dt)
        if solution is not None:
            break
        if reason == BEYOND_REACH:  # a vertex moved further than the search looked
            log.debug("step %d: beyond the search reach, searching in full", run.step + 1)
            run.reach = m.allowed_displacement
            run.search_redos += 1
            _search(run, previous)
            continue
        if cut == MAX_CUTS or dt * factor < MIN_STEP_FRACTION * m.max_time_step:
            raise SimulationError(
                f"step {run.step + 1} at t = {run.time:.6g}: {reason} after {cut + 1} "
                f"attempts (last Δt = {dt:.3g}); the run cannot go on"
            )
        log.debug("step %d: %s, Δt %.3g -> %.3g", run.step + 1, reason, dt, dt * factor)
        dt *= factor
        cut += 1
    if cut:  # a step cut (once or more): the warning counts steps, not attempts
        run.cut_steps += 1
        run.smallest_cut_dt = min(run.smallest_cut_dt, dt)
    if m.static:
        run.move_before = _largest_move(run.last_moves)
        run.moves_before = None if run.last_moves is None else run.last_moves[0]
        run.last_moves = (solution.moves, run.blocks.vertex_owner, run.blocks.names)
        run.static_held = _held_by_damping(m, run.blocks, solution, dt, run.energy.gravity)
    pushing = solution.pushed is not None and bool(np.any(solution.pushed))
    if pushing:
        run.pushed_steps += 1
    with run.timer("update"):
        ctx = StepContext(dt=dt, time=run.time + dt, step=run.step + 1, static=m.static)
        ground = None if m.ground is None else m.ground.prescribed(run.blocks, ctx)
        run.energy.add_step_work(
            run.blocks, solution.d, ctx.time, solution.contacts, ground, run.time
        )
        for effect in m.effects:
            effect.after_step(run.blocks, solution.d, ctx)
        if run.probes is not None:
            run.probes.move(run.blocks, solution.d)
        pushed = solution.pushed if pushing and not m.static else None
        before = None if pushed is None else run.blocks.copy()
        apply_step(
            run.blocks,
            solution.d,
            dt,
            m.elastic,
            m.static,
            m.exact_rotation,
            solution.pushed,
            m.scene.analysis.newmark_gamma,
            moves=solution.moves,
        )
        if before is not None:
            _pay_for_the_push(run, before, solution.d, pushed, dt, ctx.time)
        if m.ground is not None:  # the blocks that follow the ground move at its velocity
            m.ground.set_velocity(run.blocks, ctx.time)
        if not np.all(np.isfinite(run.blocks.vertices)):
            raise SimulationError(f"step {run.step + 1}: non-finite block positions")
    run.contacts = solution.contacts
    run.reach = reach.next_reach(solution.moved, m.allowed_displacement)
    run.time += dt
    run.step += 1
    run.dt = min(m.max_time_step, dt * GROWTH)
    run.max_iterations_step = max(run.max_iterations_step, solution.iterations)
    run.friction_dissipation += solution.friction_dissipation
    run.max_penetration = max(run.max_penetration, solution.max_penetration)
    _record(run, dt, solution)
    _static_in_situ_change(run)
    if m.stages is not None:  # first: a strength reduced at t is the one judged at t
        apply_due_stages(run)
    if m.fracture is not None:
        with run.timer("fracture"):
            _fracture(run, ctx)
    if run.probes is not None:
        run.probes.record(run.step, run.shown_time, run.blocks, run.contacts, m.bolts)


def _record(run: _Run, dt: float, solution: StepSolution) -> None:
    h = run.history
    h["time"].append(run.shown_time)
    h["dt"].append(dt)
    h["iterations"].append(solution.iterations)
    h["max_penetration"].append(solution.max_penetration)
    with run.timer("energy"):
        terms = run.energy.measure(run.blocks, run.contacts).as_dict()
    for name, value in terms.items():
        h[f"{name}_energy"].append(value)
    h["external_work"].append(run.energy.work)
    h["excavated_energy"].append(run.excavated_energy)


def _fracture(run: _Run, ctx: StepContext) -> None:
    """Let the fracture effect split blocks; re-home contacts and tracked points.

    The contacts go on as they were (their state, bonds and forces: a joint that failed
    stays failed, an in-situ field stays carried), those of the broken blocks on their
    pieces (:mod:`dda.fracture.inherited_contacts`); the next step's search finds the
    cracks' own."""
    old = run.blocks
    new, events = run.model.fracture.after_step(old, ctx)
    if not events:
        return
    parent_of = parent_rows(old, new)
    for effect in run.model.effects:
        effect.on_blocks_replaced(old, new, parent_of)
    if run.probes is not None:
        run.probes.on_blocks_replaced(old, new, parent_of)
    run.contacts = after_breaking(run.contacts, old, new, parent_of)
    run.blocks = new
    run.events.extend(events)


def run(
    scene: Scene,
    progress: bool | Callable[[float, dict], None] = False,
    on_frame: Callable[[Frame], None] | None = None,
    *,
    keep_frames: bool = True,
    stop: Callable[[], bool] | None = None,
    checkpoints: CheckpointPlan | None = None,
    resume: Checkpoint | None = None,
) -> Result:
    """Run a scene to its end.

    Parameters
    ----------
    scene : a validated Scene
    progress : True for a progress bar on stderr, or a callable(fraction, info)
    on_frame : called with every kept frame as the run proceeds (for writers)
    keep_frames : False: the Result keeps only the first and the latest frame
        (``on_frame`` still sees every one), so memory does not grow with the run
    stop : asked before every step; True ends the run there with status
        "interrupted" (after a last checkpoint when ``checkpoints`` is given). A
        :class:`dda.run.stop.StopOnSignal` (``dda run``'s) is asked after each of the
        equilibrium start's solves and interior-point iterations too: a signal there
        ends the run before step 1, without a checkpoint
    checkpoints : where and when to write checkpoints (:mod:`dda.run.checkpoint`)
    resume : a checkpoint of this scene to continue from; the Result's first
        frame is then the checkpoint's state, which ``on_frame`` does not see

    Raises
    ------
    TypeError : an option of the wrong type (before any work)
    SceneError : the run would exceed ``analysis.max_steps`` (:mod:`dda.scene.limits`)
    CheckpointError : ``resume`` was written for another scene or version
    SimulationError : a step that cannot be solved, or ``analysis.max_steps`` reached
    """
    _check_options(scene, progress, on_frame, keep_frames, stop, checkpoints, resume)
    start = wallclock.perf_counter()
    policy = StepPolicy.from_environment()  # a bad DDA_THREADS, DDA_SOLVER or DDA_SYSTEMS:
    # ValueError at once
    check_run_size(scene)
    origin = local_origin(scene)  # far from (0, 0): compute about the model's centre
    local = translated(scene, origin)
    model = build(local)
    state = _Run(model, policy)
    state.origin = tuple(float(c) for c in origin)
    report = _progress_reporter(progress, model, state, resume is not None)
    if resume is not None:
        check_scene(resume, scene)  # it compares the scene as the run holds it
        restore(state, resume)
        if model.stages is not None and model.stages.changes_strengths:
            set_strengths(state)
        start -= resume.wall_seconds
    elif not model.static and scene.analysis.start == "equilibrium":
        with single_threaded_blas(), run_work(len(scene.blocks), _expected_steps(model)):
            try:  # a signal stops the start too; a callable of the caller's is asked per step
                _equilibrium_start(state, report, stop if isinstance(stop, StopOnSignal) else None)
            except StartInterrupted:  # no step taken: no checkpoint, nothing to resume
                log.info("stopped during the equilibrium start")
    elif scene.in_situ is not None:  # an unloaded or static start: the contacts carry it
        _touching_at_start(state)
        if model.static:
            state.in_situ_given = state.blocks.stress.copy()
    if resume is None:
        note_unbalanced(state, "at the start")
    first = state.probes.take() if state.probes is not None and resume is None else None
    with run_work(len(scene.blocks), _expected_steps(model)):  # its contacts' rows: numpy
        frames = [_frame(state, first, origin)]  # in a small run, as the steps compute them
    if on_frame and resume is None:
        on_frame(frames[0])
    stopped = state.start == INTERRUPTED_START
    if checkpoints is not None and checkpoints.at_start and resume is None and not stopped:
        with state.timer("checkpoint"):
            checkpoints.write(state, wallclock.perf_counter() - start)
    status = "interrupted" if stopped else "finished"
    try:
        # PARDISO's threads get the cores; numba's kernels only where they pay (dda.jit)
        with single_threaded_blas(), run_work(len(scene.blocks), _expected_steps(model)):
            while not stopped and not state.finished():
                if stop is not None and stop():
                    status = "interrupted"
                    break
                _check_step_limit(state)
                _advance(state)
                last = state.finished()
                if state.step % model.save_every == 0 or last:
                    with state.timer("output"):
                        measured = None if state.probes is None else state.probes.take()
                        frame = _frame(state, measured, origin)
                        _keep(frames, frame, keep_frames)
                        if on_frame:
                            on_frame(frame)
                if checkpoints is not None and not last and checkpoints.due(state.step):
                    with state.timer("checkpoint"):
                        checkpoints.write(state, wallclock.perf_counter() - start)
                if report:
                    report(_fraction(state), {"step": state.step, "time": state.shown_time})
            if status == "interrupted" and checkpoints is not None and not stopped:
                checkpoints.write(state, wallclock.perf_counter() - start)
    except SimulationError as exc:
        status = "failed"
        exc.result = _result(state, frames, start, status)  # what was computed, for writers
        raise
    finally:
        if report and hasattr(report, "close"):
            report.close()
    result = _result(state, frames, start, status)
    for text in result.summary["warnings"]:  # `dda run` shows them as warnings
        log.info("warning: %s", text)
    return result


def _pay_for_the_push(run: _Run, before: BlockSet, d, pushed, dt: float, time: float) -> None:
    """The pushed blocks pay for the push with their motion
    (:func:`dda.contact.push_out.pay_for_the_push`): the energy it stored, the blocks'
    potential and elastic energy after the step less what they would hold after it
    without the push (``before``, the blocks at the step's start, is stepped so, in
    place), less the loads' work over it."""
    m, energy = run.model, run.energy
    work = energy.load_work(before, pushed, time, time - dt)
    apply_step(before, d - pushed, dt, m.elastic, m.static, m.exact_rotation,
               gamma=m.scene.analysis.newmark_gamma)  # fmt: skip
    cost = energy.stored(run.blocks) - energy.stored(before) - work
    pay_for_the_push(run.blocks.velocity, pushed, m.inertia.masses(run.blocks), cost)


def _frame(state: _Run, measured: dict | None, origin: tuple[float, float]) -> Frame:
    """The frame of the run's state (with the measurement rows ``measured``), in the
    scene's coordinates (the run's own are ``origin`` less: dda.scene.local_frame)."""
    found = deepest_overlap(state.blocks, state.shown_time, state.max_penetration)
    state.deepest_overlap = deeper(found, state.deepest_overlap)
    placed = state.model.bolts
    bolts = None if placed is None else placed.segments()
    tensions = None if placed is None else placed.tension()[placed.active]
    ids = None if placed is None else np.flatnonzero(placed.active)
    frame = make_frame(
        state.blocks, _shown_contacts(state), state.shown_time, state.step, measured, bolts,
        _plane_strain_poisson(state.model.scene, state.blocks), tensions, ids,
    )  # fmt: skip
    return shifted(frame, origin)


def _shown_contacts(state: _Run) -> ContactSet:
    """The contacts a frame shows: at step 0 of a run that did not take the equilibrium
    start (static, unloaded, or a start that did not settle) in an in-situ field, with the
    forces their multipliers carry (:func:`with_carried_forces`): a static run's first
    frame showed every contact at 0 while each block held the field."""
    if state.step == 0 and state.start != "equilibrium" and state.model.scene.in_situ:
        return with_carried_forces(state.contacts)
    return state.contacts


def _plane_strain_poisson(scene, blocks) -> np.ndarray | None:
    """Each block's Poisson's ratio in a plane-strain scene (its frames carry szz), else
    None."""
    if scene.analysis.plane != "strain":
        return None
    poisson = np.array([m.poisson for m in scene.materials.values()])  # the model's rows
    return poisson[blocks.material]


def _keep(frames: list[Frame], frame: Frame, keep_all: bool) -> None:
    """Add ``frame``; unless ``keep_all``, only the first and the latest frame stay."""
    if keep_all or len(frames) < 2:
        frames.append(frame)
    else:
        frames[-1] = frame


def _check_step_limit(state: _Run) -> None:
    limit = state.model.scene.analysis.max_steps
    if state.step >= limit:
        raise SimulationError(
            f"step {state.step} at t = {state.time:.6g}: reached analysis.max_steps = {limit} "
            "(cut steps made the run longer than estimated); raise it to go on"
        )


def _result(state: _Run, frames: list[Frame], start: float, status: str) -> Result:
    bolts = state.model.bolts
    return Result(
        frames=frames,
        fracture_events=state.events,
        summary=_summary(state, wallclock.perf_counter() - start, status),
        history={k: np.array(v) for k, v in state.history.items()},
        bolt_events=[] if bolts is None else list(bolts.events),
        measurements={} if state.probes is None else state.probes.as_arrays(),
    )


def _expected_steps(model: Model) -> float:
    """Steps the run will take: its ``steps``, else duration / largest time step."""
    if model.steps is not None:
        return float(model.steps)
    return model.duration / model.max_time_step


def _fraction(state: _Run) -> float:
    m = state.model
    if m.steps is not None:
        return state.step / max(m.steps, 1)
    return min(state.time / m.duration, 1.0)


def _check_options(scene, progress, on_frame, keep_frames, stop, checkpoints, resume) -> None:
    """Raise a TypeError naming the first of :func:`run`'s options of the wrong type,
    before any work (a string given for ``on_frame`` failed after the equilibrium start;
    one for ``checkpoints`` or ``resume`` as an AttributeError)."""
    expected = [
        ("scene", scene, isinstance(scene, Scene), "a dda.Scene"),
        ("progress", progress, isinstance(progress, bool) or callable(progress),
         "True, False or a callable(fraction, info)"),
        ("on_frame", on_frame, on_frame is None or callable(on_frame), "None or a callable(frame)"),
        ("keep_frames", keep_frames, isinstance(keep_frames, bool), "True or False"),
        ("stop", stop, stop is None or callable(stop), "None or a callable() -> bool"),
        ("checkpoints", checkpoints, checkpoints is None or isinstance(checkpoints, CheckpointPlan),
         "None or a dda.run.checkpoint.CheckpointPlan"),
        ("resume", resume, resume is None or isinstance(resume, Checkpoint),
         "None or a checkpoint (dda.run.checkpoint.read_checkpoint(path))"),
    ]  # fmt: skip
    for name, value, right, what in expected:
        if not right:
            raise TypeError(f"{name}: expected {what}, got {type(value).__name__} {value!r:.40}")


def _progress_reporter(progress, model: Model, state: _Run, resumed: bool):
    if callable(progress):
        return progress
    if not progress:
        return None
    from dda.run.progress import ProgressBar

    def aside() -> float:  # the kernels' compiling (once per installation) and the start
        started = state.start_seconds - state.start_compile_seconds  # 0 until it runs
        return compile_seconds() + (0.0 if resumed else started)  # (resumed: the first run's)

    # the ETA leaves out what will not come again: the compiling and the start
    bar = ProgressBar(1.0, label=model.scene.label, aside=aside)

    class _Bar:
        def __call__(self, fraction: float, info: dict) -> None:
            bar.update(fraction, **info)

        def close(self) -> None:
            bar.close()

    return _Bar()


def _summary(state: _Run, wall: float, status: str) -> dict:
    m = state.model
    steps = max(state.step, 1)
    return {
        "title": m.scene.title,
        "status": status,
        "steps": state.step,
        "time": state.shown_time,
        "wall_seconds": round(wall, 6),
        "compile_seconds": round(compile_seconds() - state.compiled_before, 3),
        "blocks": state.blocks.count,
        "iterations": state.iterations,
        "factorisations": state.factorisations,
        "iterations_per_step": state.iterations / steps,
        "newton_iterations": state.newton_iterations,
        "newton_iterations_per_step": state.newton_iterations / steps,
        "max_iterations_step": state.max_iterations_step,
        "start": state.start,
        "start_newton_iterations": state.start_newton_iterations,
        "start_method": state.start_method,
        "start_seconds": round(state.start_seconds, 6),
        "start_compile_seconds": round(state.start_compile_seconds, 3),  # of start_seconds
        "start_in_situ_change": state.in_situ_change[0],  # over the field (0 without one)
        "start_in_situ_change_block": state.in_situ_change[1],
        "start_in_situ_relaxed": state.in_situ_change[0] > IN_SITU_KEPT,
        "max_penetration": state.max_penetration,
        "deepest_overlap": 0.0 if state.deepest_overlap is None else state.deepest_overlap.depth,
        "cut_steps": state.cut_steps,
        "smallest_cut_time_step": None if state.cut_steps == 0 else state.smallest_cut_dt,
        "search_redos": state.search_redos,
        "friction_dissipation": state.friction_dissipation,
        "contact_method": None if m.contact is None else m.scene.contact.method,
        "active_effects": list(m.active_effects),
        "stage_seconds": state.timer.as_dict(),
        "fracture_events": len(state.events),
        "initial_energy": state.energy.initial.total,
        "external_work": state.energy.work,
        "environment": environment(),
        "scene_fingerprint": scene_fingerprint(m.scene),  # what --resume compares
        **_engineering_summary(state),
        "warnings": _warnings(state),
    }


def _warnings(state: _Run) -> list[str]:
    """The run's warnings (:mod:`dda.run.run_warnings`), in the scene's units."""
    m = state.model
    length = m.scene.units.length
    blocks = state.blocks
    size = smallest_free_size(
        block_sizes(blocks.vertices, blocks.offsets, blocks.area), blocks.fixed
    )
    augmented = m.contact is not None and m.contact.law.augmented
    found = [
        *m.scene.load_warnings,  # a drawing's left-out shapes, joint lines that cut nothing
        in_situ_warning(*state.in_situ_change),
        state.initial_stress_relaxed,
        in_situ_slip_warning(*state.in_situ_slip, length),
        *state.unbalanced,
        *state.misplaced_bolts,
        unsettled_start_warning(state.start_newton_iterations, state.start_seconds)
        if state.start == UNSETTLED_START
        else None,
        None if m.static else _energy_warning(state),
        penetration_warning(state.max_penetration, size, length, augmented),
        overlap_warning(
            state.deepest_overlap, state.max_penetration, size, (length, m.scene.units.time)
        ),
        cut_steps_warning(state.cut_steps, state.step, state.smallest_cut_dt, m.max_time_step),
        _last_motion_warning(state, length),
        _fracture_warning(state, length),
        *_restitution_warnings(m, state.blocks),
        _skipped_stages_warning(state),
    ]
    return [text for text in found if text is not None]


def _skipped_stages_warning(state: _Run) -> str | None:
    """:func:`skipped_stages_warning` of a finished run given ``analysis.steps``."""
    plan, steps = state.model.stages, state.model.steps
    if plan is None or steps is None or not state.finished():
        return None
    left = plan.times[state.stages_done :]
    return skipped_stages_warning(left, steps, state.shown_time, state.model.scene.units.time)


def _restitution_warnings(model: Model, blocks: BlockSet) -> list[str | None]:
    """:func:`restitution_warning` and :func:`restitution_step_warning` of the model's
    joints with ``restitution``."""
    cm = model.contact
    if cm is None or not cm.joints.has_restitution or model.static:  # no dashpot in static
        return []
    rest = [cm.joints.names[k] for k in np.flatnonzero(np.isfinite(cm.joints.restitution))]
    young = min(material.young for material in model.scene.materials.values())
    units = model.scene.units
    free = ~blocks.fixed
    masses = model.inertia.masses(blocks)[free, 0, 0]
    omega = float(np.sqrt(2.0 * cm.initial_penalty / masses.min())) if len(masses) else 0.0
    gamma = model.scene.analysis.newmark_gamma
    return [
        restitution_warning(rest, cm.initial_penalty, young, units.force, units.length),
        restitution_step_warning(rest, omega, model.max_time_step, gamma, units.time),
    ]


def _fracture_warning(state: _Run, length: str) -> str | None:
    """:func:`fracture_warning` of a run with ``[fracture]`` in which no block broke (no
    breakable material: the model has no fracture effect, but the scene set its table)."""
    fracture, settings = state.model.fracture, state.model.scene.fracture
    if state.events or (fracture is None and settings == type(settings)()):
        return None
    if fracture is None:
        return fracture_warning(0.0, np.zeros(0), length)
    areas = state.blocks.area[fracture.candidates(state.blocks)]
    return fracture_warning(fracture.min_area, areas, length)


def _energy_warning(state: _Run) -> str | None:
    """:func:`energy_warning` of the run, with the evidence for its cause: the steps the
    push-out acted at, and the fastest free block at the end (name, speed, slenderness)."""
    blocks, units = state.blocks, state.model.scene.units
    free = np.flatnonzero(~blocks.fixed)
    fastest = None
    if len(free):
        speed = np.hypot(blocks.velocity[free, 0], blocks.velocity[free, 1])
        k = free[int(np.argmax(speed))]
        corners = blocks.vertices[blocks.offsets[k] : blocks.offsets[k + 1]]
        half = 0.5 * np.linalg.norm(np.diff(corners, axis=0, append=corners[:1]), axis=1).sum()
        fastest = (blocks.names[k], float(speed.max()), float(half**2 / blocks.area[k]))
        spin = np.abs(blocks.velocity[free, 2])
        k = free[int(np.argmax(spin))]
        turning = (blocks.names[k], float(spin.max()), float(spin.max()) * state.dt)
    history, initial = state.history, state.energy.initial
    return energy_warning(
        history, initial.total, state.pushed_steps, fastest, (units.length, units.time),
        turning if len(free) else None, initial.as_dict(),
    )  # fmt: skip


def _last_motion_warning(state: _Run, length: str) -> str | None:
    """:func:`static_motion_warning` of a static run's last step (None otherwise)."""
    if state.last_moves is None or not len(state.last_moves[0]):
        return None
    moves, owner, names = state.last_moves
    size = np.hypot(moves[:, 0], moves[:, 1])
    largest = int(np.argmax(size))
    allowed = state.model.allowed_displacement
    block = names[owner[largest]]
    share, row = state.static_held
    name = state.blocks.names[row] if 0 <= row < state.blocks.count else ""
    of = "weight" if state.energy.gravity is not None else "load"
    held = (share, name, of)
    before = state.moves_before
    back = before is not None and before.shape == moves.shape  # no break between them
    back = back and float(np.dot(moves[largest], before[largest])) < 0.0
    return static_motion_warning(
        float(size[largest]), state.move_before, allowed, block, length, held, back
    )


def _held_by_damping(
    model: Model, blocks: BlockSet, solution: StepSolution, dt: float, gravity
) -> tuple[float, int]:
    """(the largest force a static step's damping held, (2/Δt²) |(M D)ᵢ| over the
    translations, over that block's weight mᵢ|g|; the block's row). Without ``gravity``
    (g, or None) over the largest load on a free block instead (the step's F₀ on its
    translations: point loads, boundary stresses, water; a model loaded so, not by its
    weight, held its loads by damping unsaid); (0, −1) with neither. At rest it is 0; a
    block without support has its whole weight (or load) held."""
    free = np.flatnonzero(~blocks.fixed)
    if not len(free):
        return 0.0, -1
    masses = model.inertia.masses(blocks)[free]
    held = (2.0 / dt**2) * np.einsum("nij,nj->ni", masses[:, :2, :], solution.d[free])
    if gravity is not None:
        scale = masses[:, 0, 0] * float(np.hypot(*gravity))
    else:
        loads = solution.loads
        largest = float(np.hypot(loads[free, 0], loads[free, 1]).max())
        if largest == 0.0:
            return 0.0, -1
        scale = np.full(len(free), largest)
    share = np.hypot(held[:, 0], held[:, 1]) / scale
    k = int(np.argmax(share))
    return float(share[k]), int(free[k])


def _largest_move(last_moves) -> float:
    """The largest vertex move of a static step's ``last_moves`` (0 before the first)."""
    if last_moves is None or not len(last_moves[0]):
        return 0.0
    return float(np.hypot(last_moves[0][:, 0], last_moves[0][:, 1]).max())


def _engineering_summary(state: _Run) -> dict:
    """Summary entries of bolts and stages (none for a scene without them)."""
    m, out = state.model, {}
    if m.bolts is not None:
        out["bolts"] = len(m.bolts)
        out["bolt_names"] = list(m.bolts.names)  # the bolt ids of the frames and files
        out["bolt_events"] = list(m.bolts.events)
        out["bolt_break_energy"] = sum(event.energy for event in m.bolts.events)
    if m.stages is not None:
        out["stages_done"] = state.stages_done
        out["excavated_energy"] = state.excavated_energy
    return out
