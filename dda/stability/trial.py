"""One strength-reduction trial, runnable on any worker: load, reduce, run, judge.

A :class:`Trial` carries the scene as a dict (and the file it came from, for messages
and the files it names): workers read no file. The scene runs as given first, then its
strengths are divided by F:

- without ``[[stages]]`` the reduced scene runs from its equilibrium start
  (``[analysis] start``: the scene's geometry carrying its loads at t = 0, so a model
  that stands at F starts at rest) for the criterion's duration: the scene as given
  would stay at rest, so reducing from t = 0 is the same;
- with stages the scene runs with its own strengths through its stages to the end of
  its run, T_r, where one more stage divides them by F (``strength_factor``, times the
  factor of the scene's own last one), and goes on for the criterion's duration.

It is judged by :mod:`dda.stability.criterion` (the window lies after T_r). A run that
stops (``dda.SimulationError``) counts as failed.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import socket
import time
from dataclasses import dataclass

import dda
from dda.scene.engineering import Stage
from dda.stability.criterion import SpeedWatch, criterion_of
from dda.stability.strength_reduction import reduce_strengths

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Trial:
    """A scene (raw dict) and the factor its strengths are divided by."""

    scene: dict
    factor: float
    source: str = "<dict>"
    keep_frame: bool = True  # return the last frame of a failed trial (for its picture)


def trial_scene(scene: dda.Scene, factor: float) -> dda.Scene:
    """The scene a trial runs: strengths reduced (from t = 0, or for a scene with stages
    by a stage at the end of its run), run to the criterion's end and every step seen
    by the criterion."""
    criterion = criterion_of(scene)
    intact = scene.fos.intact
    if scene.stages:
        own = [s for s in scene.stages if s.strength_factor is not None]
        given = own[-1].strength_factor if own else 1.0  # a stage's F replaces the last
        intact = intact or (own[-1].intact if own else False)
        stage = Stage(criterion.start, strength_factor=factor * given, intact=intact)
        reduced = dataclasses.replace(scene, stages=(*scene.stages, stage))
    else:
        reduced = reduce_strengths(scene, factor, intact)
    analysis = dataclasses.replace(
        reduced.analysis, duration=criterion.end, steps=None, save_every=1
    )
    return dataclasses.replace(reduced, analysis=analysis)


def run_trial(trial: Trial) -> dict:
    """Run one trial; its row: factor, failed, speed (the criterion's value), limit,
    steps, seconds, host, status (``ran`` or the reason the run stopped), ``moving`` (the
    watched blocks faster than the limit, :meth:`SpeedWatch.moving`) and, for a failed
    trial with ``keep_frame``, ``frame`` (the last frame)."""
    scene = dda.load_scene(trial.scene, trial.source)
    criterion = criterion_of(scene)
    watch = SpeedWatch(criterion)
    start = time.perf_counter()
    status, steps, frame = "ran", 0, None
    try:
        result = dda.simulate(trial_scene(scene, trial.factor), on_frame=watch, keep_frames=False)
        steps, frame = result.summary["steps"], result.final
    except dda.SimulationError as exc:
        status = f"stopped: {' '.join(str(exc).split())}"
        log.info("trial F=%g %s", trial.factor, status)
        partial = getattr(exc, "result", None)
        if partial is not None and partial.frames:
            frame = partial.frames[-1]
    failed = watch.failed or status != "ran"
    return {
        "factor": trial.factor,
        "failed": failed,
        "speed": watch.largest if status == "ran" else math.inf,
        "limit": criterion.velocity,
        "steps": steps,
        "seconds": time.perf_counter() - start,
        "host": socket.gethostname(),
        "status": status,
        "frame": frame if failed and trial.keep_frame else None,
        "moving": watch.moving(),
    }
