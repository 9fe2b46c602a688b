"""How each kind of case is run: static, dynamic (histories) and fracture (onset load).

``static``
    The engine runs the scene to its end; the FEM solves the scene once,
    statically; :func:`verify.comparison.compare.compare` gives the rows.
``dynamic``
    The engine runs the scene; the FEM integrates it with the engine's time
    integrator (:mod:`verify.fem.dynamics`). Rows ``history``: every block's
    centroid displacement (``ux``, ``uy``) and rotation (``r``) in every saved
    frame, against the FEM block means at the same time; rows
    ``stress_history``: its stress against the FEM block average.
``fracture``
    The engine runs the scene until a block breaks; the FEM finds the load
    factor at which that block's average stress meets the criterion
    (:mod:`verify.fem.fracture`). Row ``onset``: the load factor at the step the
    block broke, against the FEM's. The frame before the break is compared
    as a static state with the FEM solved at that frame's load factor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

import dda
from dda import Result, Scene
from verify.comparison.breaks import (
    broken_factors,
    children_rows,
    common_factor,
    crack_rows,
    frame_before_break,
    onset_rows,
    planned_largest_factor,
)
from verify.comparison.compare import STRESS, VECTOR, Row, compare, tensor_in_frame, vector_in_frame
from verify.comparison.dda_side import DdaSide
from verify.comparison.expect import Expectation
from verify.fem.dynamics import FemHistory, integrate
from verify.fem.fracture import Onset, onset_factors
from verify.fem.in_situ import excavated
from verify.fem.statics import FemOptions, FemSolution, solve_fem
from verify.fem.turn import turned_scene
from verify.references.al_rate import al_update_rows
from verify.references.block import free_block
from verify.references.bolt import REFERENCES as BOLT_REFERENCES
from verify.references.collisions import momentum_rows
from verify.references.impact import REFERENCES as IMPACT_REFERENCES
from verify.references.impact import ROWS as IMPACT_ROWS
from verify.references.motion import (
    REFERENCES,
    Track,
    dissipation_rows,
    motion_rows,
    with_time_step,
)
from verify.references.shaking import REFERENCES as SHAKING_REFERENCES
from verify.references.shaking import RUN_ROWS as SHAKING_RUN_ROWS
from verify.references.water import REFERENCES as WATER_REFERENCES


@dataclass
class KindResult:
    """What a runner returns (see :class:`verify.harness.cases.CaseResult`)."""

    dda: DdaSide
    fem: FemSolution
    rows: list[Row]
    seconds: dict[str, float]
    reference: object
    series: dict = field(default_factory=dict)


class Stopwatch:
    """Seconds per named stage."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def run(self, name: str, function, *args, **kwargs):
        """Call ``function`` and add its wall time to ``name``."""
        start = time.perf_counter()
        value = function(*args, **kwargs)
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
        return value


def run_static(
    scene: Scene, expectation: Expectation, options: FemOptions, reference=None
) -> KindResult:
    """Final frame against the static FEM solution."""
    watch = Stopwatch()
    result = watch.run("dda", dda.simulate, scene)
    at_rest = turned_scene(scene, expectation.fem_turn, expectation.fem_about)
    fem = reference or watch.run("fem", solve_fem, at_rest, options)
    start = None if at_rest is scene else excavated(at_rest)
    side = DdaSide.from_result(result, excavated(scene), start=start)  # after the stages
    rows = compare(side, fem, expectation)
    if "al_updates" in expectation.checks:
        rows += watch.run("dda", al_update_rows, scene)
    return KindResult(side, fem, rows, watch.seconds, fem)


def run_dynamic(
    scene: Scene, expectation: Expectation, options: FemOptions, reference=None
) -> KindResult:
    """Centroid displacement and rotation histories against the FEM's."""
    watch = Stopwatch()
    result = watch.run("dda", dda.simulate, scene)
    history: FemHistory = reference or watch.run("fem", integrate, scene, options)
    rows, series = history_rows(result, scene, history, expectation)
    side = DdaSide.from_result(result, scene)
    return KindResult(side, history.final, rows, watch.seconds, history, series)


def at_times(times: np.ndarray, history_times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (steps, ...) interpolated linearly to ``times`` (exact on the steps)."""
    flat = values.reshape(len(history_times), -1)
    out = np.column_stack([np.interp(times, history_times, c) for c in flat.T])
    return out.reshape(len(times), *values.shape[1:])


def of_blocks(frames, rows_of: list[list[int]], attribute: str) -> np.ndarray:
    """(frames, blocks, ...) array of a frame attribute at the given rows of every frame."""
    return np.array([getattr(f, attribute)[r] for f, r in zip(frames, rows_of, strict=True)])


def history_rows(
    result: Result, scene: Scene, history: FemHistory, expectation: Expectation
) -> tuple[list[Row], dict]:
    """Rows ``history`` (ux, uy, r) and ``stress_history`` of every free block in every frame."""
    free = list(history.final.block_mesh.blocks)
    frames = result.frames
    times = np.array([f.time for f in frames])
    rows_of = [[f.block(scene.blocks[i].name) for i in free] for f in frames]
    frame = expectation.frame
    series = {
        "times": times,
        "blocks": [scene.blocks[i].name for i in free],
        "dda_u": vector_in_frame(of_blocks(frames, rows_of, "displacements"), frame),
        "fem_u": vector_in_frame(
            at_times(times, history.times, history.displacements[:, free]), frame
        ),
        "dda_r": of_blocks(frames, rows_of, "rotations"),
        "fem_r": at_times(times, history.times, history.rotations[:, free]),
        "dda_s": tensor_in_frame(of_blocks(frames, rows_of, "stresses"), frame),
        "fem_s": tensor_in_frame(at_times(times, history.times, history.stresses[:, free]), frame),
    }
    scales = {
        "u": float(np.linalg.norm(series["fem_u"], axis=-1).max()),
        "r": float(np.abs(series["fem_r"]).max()),
        "s": float(np.abs(series["fem_s"]).max()),
    }
    rows = []
    for k, t in enumerate(times):
        for j, name in enumerate(series["blocks"]):
            item = f"{name}@{t:.6g}"
            values = [
                ("history", c, series["dda_u"][k, j, m], series["fem_u"][k, j, m], scales["u"])
                for m, c in enumerate(VECTOR)
            ]
            values.append(
                ("history", "r", series["dda_r"][k, j], series["fem_r"][k, j], scales["r"])
            )
            values += [
                (
                    "stress_history",
                    c,
                    series["dda_s"][k, j, m],
                    series["fem_s"][k, j, m],
                    scales["s"],
                )
                for m, c in enumerate(STRESS)
            ]
            for quantity, component, d, f, scale in values:
                row = Row(quantity, item, component, float(d), float(f), scale)
                rows.append(row.with_offset(expectation.offsets))
    return rows, series


def run_fracture(
    scene: Scene, expectation: Expectation, options: FemOptions, reference=None
) -> KindResult:
    """Load factor at the first break against the FEM's onset factor."""
    watch = Stopwatch()
    result = watch.run("dda", dda.simulate, scene)
    largest = planned_largest_factor(scene)  # the scene's, not where the engine broke
    onset: Onset = reference or watch.run("fem", onset_factors, scene, options, largest)
    before = frame_before_break(result)
    side = DdaSide.from_result(result, scene, before)
    factor = common_factor(scene, result.frames[before].time)
    fem = watch.run("fem", solve_fem, scene, options, load_factor=factor)
    rows = compare(side, fem, expectation) + onset_rows(result, scene, onset, expectation)
    rows += children_rows(result) + crack_rows(result, scene, onset)
    series = {
        "onset": {scene.blocks[i].name: f for i, f in onset.factors.items()},
        "broke": broken_factors(result, scene),
        "factor_before": factor,
    }
    return KindResult(side, fem, rows, watch.seconds, onset, series)


def run_motion(
    scene: Scene, expectation: Expectation, options: FemOptions, reference=None
) -> KindResult:
    """The scene at each of the expectation's time-step factors against the closed form
    (:mod:`verify.references.motion`, :mod:`verify.references.impact`); no FEM side
    (``fem`` is None). Reference ``momentum``: the scene as written against the conservation laws of
    :mod:`verify.references.collisions`."""
    watch = Stopwatch()
    system = SYSTEM_REFERENCES.get(expectation.reference)
    if system is not None:  # many blocks: conservation laws, at the scene's Δt only
        result = watch.run("dda", dda.simulate, scene)
        rows, series = system(scene, result)
        rows = [row.with_offset(expectation.offsets) for row in rows]
        side = DdaSide.from_result(result, scene)
        return KindResult(side, None, rows, watch.seconds, None, series)
    name = scene.blocks[free_block(scene)].name
    tracks, finest = {}, None
    for factor in sorted(expectation.time_steps, reverse=True):
        result = watch.run("dda", dda.simulate, with_time_step(scene, factor))
        tracks[factor] = Track.of(result, name)
        finest = result
    rows, series = motion_rows(scene, expectation, tracks, MOTION_REFERENCES)
    more = IMPACT_ROWS.get(expectation.reference)
    if more is not None:
        rows += more(scene, expectation, tracks, series)
    whole = RUN_ROWS.get(expectation.reference)
    if whole is not None:  # rows of the finest run beside the free block's
        rows += [row.with_offset(expectation.offsets) for row in whole(scene, finest)]
    side = DdaSide.from_result(finest, scene)
    return KindResult(side, None, rows, watch.seconds, None, series)


# the closed forms of kind "motion": verify.references.motion's, verify.references.impact's,
# verify.references.shaking's and verify.references.bolt's
MOTION_REFERENCES = {
    **REFERENCES,
    **IMPACT_REFERENCES,
    **SHAKING_REFERENCES,
    **BOLT_REFERENCES,
    **WATER_REFERENCES,
}
# rows of a motion reference from the finest run as a whole (beside the free block's)
RUN_ROWS = {**SHAKING_RUN_ROWS, "slide": dissipation_rows}
# the motion references of many blocks (rows from the whole run, verify.references.collisions)
SYSTEM_REFERENCES = {"momentum": momentum_rows}

RUNNERS = {
    "static": run_static,
    "dynamic": run_dynamic,
    "fracture": run_fracture,
    "motion": run_motion,
}
