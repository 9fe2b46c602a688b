"""When a strength-reduction trial fails: its watched blocks do not come to rest.

A trial runs the reduced scene for ``duration`` from ``start`` (0, or for a scene
with stages the end of its own run, where the reduction begins); the last ``window``
of that, from T₀ to T, is judged by the mean speed of each watched block over it,

    s = max over blocks of ( |c(T) − c(T₀)| + |θ(T) − θ(T₀)| r ) / (T − T₀),

c the centroid, θ the accumulated rotation and r the largest distance of a vertex from
the centroid (a block that appears inside the window, a fragment, is measured from the
first frame it is in). In a scene with ``[seismic]``, c is measured from the ground:
less the motion of the fixed blocks that follow it (a rigid translation), which keeps
the last velocity of its record and would otherwise count as every block's motion.
s is the mean speed over the window of the block's fastest
point, bounded by its largest: motion that accumulates (a slide, a topple) counts in
full, a vibration about a position that stands counts only by its amplitude over the
window's length (a block ringing at 1 µm and 300 Hz has speeds of 2 mm/s but s of at
most 2 µm / (T − T₀)). The trial fails when s > ``velocity``. The default limit is
``acceleration`` × |g| × ``duration``: the speed an out-of-balance force of that
fraction of the weight gives a block from rest over the trial. A block that stands
stays at rest (the equilibrium start, docs/contact.md); one that slides from t = 0 at
an out-of-balance acceleration a has s = a (T + T₀) / 2 = 0.9 a T with the default
window (0.2), so at the default (1e-4) a slide is caught once a > 1.1e-4 g.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dda.errors import SceneError
from dda.result import Frame
from dda.scene import Scene


@dataclass(frozen=True)
class Criterion:
    """The failure criterion of a trial, with every default resolved."""

    duration: float  # simulated time of a trial
    window: float  # fraction of the duration, at its end, that is judged
    velocity: float  # the speed limit
    blocks: tuple[str, ...] = ()  # watched blocks (empty: every free block)
    start: float = 0.0  # when the strengths are divided (the end of a staged scene's run)
    ground: tuple[str, ...] = ()  # the fixed blocks that follow [seismic]'s ground motion

    @property
    def end(self) -> float:
        """The end of the trial: ``start`` + ``duration``."""
        return self.start + self.duration

    @property
    def judged_from(self) -> float:
        """The time from which speeds count: the last ``window`` of the part after
        ``start``."""
        return self.start + self.duration * (1.0 - self.window)


def criterion_of(scene: Scene) -> Criterion:
    """The criterion of ``scene``'s ``[fos]`` table (defaults resolved); for a scene with
    ``[[stages]]`` it starts at the end of the scene's run (:mod:`dda.stability.trial`).

    Raises
    ------
    SceneError
        Key ``fos.velocity`` when the scene has no gravity and gives no speed limit;
        key ``analysis.mode`` for a static scene.
    """
    if scene.analysis.mode != "dynamic":
        raise SceneError(
            scene.source,
            "analysis.mode",
            "a strength-reduction trial needs a dynamic run (static runs reset the "
            "velocities every step, so no block could be seen moving)",
        )
    fos = scene.fos
    duration = fos.duration if fos.duration is not None else scene.analysis.run_length
    velocity = fos.velocity
    if velocity is None:
        g = math.hypot(*scene.analysis.gravity)
        if g == 0.0:
            raise SceneError(
                scene.source,
                "fos.velocity",
                "is required without gravity (the default limit is a fraction of |g|)",
            )
        velocity = fos.acceleration * g * duration
    start = scene.analysis.run_length if scene.stages else 0.0
    ground = () if scene.seismic is None else tuple(scene.seismic.blocks)
    criterion = Criterion(duration, fos.window, velocity, fos.blocks, start, ground)
    _check_judged(scene, criterion)
    return criterion


def _check_judged(scene: Scene, criterion: Criterion) -> None:
    """Refuse a criterion that cannot judge: a window shorter than a time step (one
    frame in it: every block's speed 0, every trial standing), a window that starts while the
    seismic record still shakes the ground (a block sliding to and fro is judged by its
    net motion over it: one period of a sine, nothing), or a record that plays before the
    strengths are reduced (a staged scene's: its trials would miss it)."""
    time, dt = scene.units.time, scene.analysis.time_step
    judged = criterion.window * criterion.duration
    if judged < dt * (1.0 - 1e-9):
        raise SceneError(
            scene.source,
            "fos.window",
            f"the judged window, {criterion.window:g} of the trial's {criterion.duration:g} "
            f"{time} = {judged:.6g} {time}, is shorter than a time step ({dt:g} {time}): "
            "no speed can be measured over it; give a longer fos.duration (--duration) or "
            "fos.window (--window)",
        )
    shaking = _shaking(scene)
    if shaking is None:
        return
    first, last = shaking
    if first < criterion.start:
        raise SceneError(
            scene.source,
            "seismic",
            f"the record shakes the ground from {first:g} {time}, before the strengths are "
            f"reduced at {criterion.start:g} {time} (the end of the staged run): the trials "
            f"would not see that part of it; start the record at {criterion.start:g} {time} "
            "or later",
        )
    if criterion.judged_from < last * (1.0 - 1e-12):
        if criterion.window >= 1.0:
            raise SceneError(
                scene.source,
                "fos.window",
                f"is 1: the judged window is the whole trial, and the seismic record shakes "
                f"the ground in it (to {last:g} {time}); give fos.window (--window) below 1 "
                "and a duration that judges after the record",
            )
        needed = (last - criterion.start) / (1.0 - criterion.window)
        raise SceneError(
            scene.source,
            "fos.duration",
            f"the judged window starts at {criterion.judged_from:g} {time}, before the "
            f"seismic record ends at {last:g} {time}: a block sliding to and fro while the "
            "ground shakes would be judged by its net motion; give fos.duration "
            f"(--duration) of at least {needed:.6g} {time}",
        )


def _shaking(scene: Scene) -> tuple[float, float] | None:
    """(first, last) time the ``[seismic]`` record's acceleration is not zero (None
    without one that is): linear between its rows, so a row of nonzero acceleration
    shakes the ground from the row before it to the row after it, and zero outside."""
    if scene.seismic is None:
        return None
    record = scene.seismic.record
    moving = [k for k, row in enumerate(record) if row[1] != 0.0 or row[2] != 0.0]
    if not moving:
        return None
    first, last = moving[0], moving[-1]
    return record[max(first - 1, 0)][0], record[min(last + 1, len(record) - 1)][0]


def watched_blocks(criterion: Criterion, scene: Scene) -> tuple[str, ...]:
    """The blocks a trial of ``scene`` watches: the criterion's ``blocks``, else every
    block of the scene, less the fixed ones and those a stage removes (fragments of a
    watched block are watched too, as :meth:`SpeedWatch.speeds` judges them)."""
    removed = {name for stage in scene.stages for name in stage.remove}
    named = set(criterion.blocks)
    return tuple(
        b.name
        for b in scene.blocks
        if not b.fixed and b.name not in removed and (not named or b.name in named)
    )


def criterion_record(criterion: Criterion, scene: Scene) -> dict:
    """The criterion as ``fos.json`` holds it: ``duration``, ``window``, ``velocity``,
    ``start`` (when the strengths are divided), ``watched`` (``"every free block"`` or
    ``"[fos] blocks"``: which rule chose them), ``blocks``, the watched blocks' names, and
    ``ground``, the blocks that follow [seismic]'s ground, whose motion is taken off (empty
    without)."""
    return {
        "duration": criterion.duration,
        "window": criterion.window,
        "velocity": criterion.velocity,
        "start": criterion.start,
        "watched": "[fos] blocks" if criterion.blocks else "every free block",
        "blocks": list(watched_blocks(criterion, scene)),
        "ground": list(criterion.ground),
    }


def block_radii(frame: Frame) -> np.ndarray:
    """r of every block of ``frame``: the distance of its farthest vertex from its centroid."""
    counts = np.array([len(v) for v in frame.vertices])
    if not len(counts):
        return np.zeros(0)
    xy = np.concatenate(frame.vertices) - np.repeat(frame.centroids, counts, axis=0)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    return np.sqrt(np.maximum.reduceat((xy * xy).sum(axis=1), starts))


class SpeedWatch:
    """An ``on_frame`` callback that measures the watched blocks' mean speed over the
    judged window (module docstring)."""

    def __init__(self, criterion: Criterion) -> None:
        self.criterion = criterion
        self._ids = np.zeros(0, np.int64)  # blocks seen in the window, sorted ...
        self._first = np.zeros((0, 6))  # ... their first (time, x, y, θ, ground x, y) in it
        self._last: Frame | None = None

    def __call__(self, frame: Frame) -> None:
        if frame.time < self.criterion.judged_from * (1.0 - 1e-12):
            return
        ids = np.asarray(frame.ids, np.int64)
        new = ~np.isin(ids, self._ids)
        if new.any():
            count = int(new.sum())
            state = np.column_stack([
                np.full(count, frame.time), frame.centroids[new], frame.rotations[new],
                np.repeat(self._ground(frame)[None, :], count, axis=0),
            ])  # fmt: skip
            order = np.argsort(np.concatenate([self._ids, ids[new]]), kind="stable")
            self._ids = np.concatenate([self._ids, ids[new]])[order]
            self._first = np.concatenate([self._first, state])[order]
        self._last = frame

    def _ground(self, frame: Frame) -> np.ndarray:
        """(2,) where the ground is in ``frame``: the mean centroid of the criterion's
        ``ground`` blocks, which move together (0 without them)."""
        if not self.criterion.ground:
            return np.zeros(2)
        rows = np.isin(np.asarray(frame.names), self.criterion.ground)
        return frame.centroids[rows].mean(axis=0) if rows.any() else np.zeros(2)

    def speeds(self) -> dict[str, float]:
        """Each watched block's mean speed over the window, by name (empty before the
        window has two frames)."""
        frame = self._last
        if frame is None:
            return {}
        watched = ~np.asarray(frame.fixed, bool)
        if self.criterion.blocks:
            parents = np.array([n.split("/")[0] for n in frame.names])
            watched &= np.isin(parents, self.criterion.blocks)
        first = self._first[np.searchsorted(self._ids, np.asarray(frame.ids, np.int64))]
        elapsed = frame.time - first[:, 0]
        watched &= elapsed > 0.0
        if not watched.any():
            return {}
        ground = self._ground(frame) - first[:, 4:6]  # the ground's motion since then
        moved = np.linalg.norm(frame.centroids - first[:, 1:3] - ground, axis=1)
        turned = np.abs(frame.rotations - first[:, 3]) * block_radii(frame)
        speed = (moved + turned)[watched] / elapsed[watched]
        names = [n for n, w in zip(frame.names, watched, strict=True) if w]
        return dict(zip(names, speed.tolist(), strict=True))

    @property
    def largest(self) -> float:
        """s: the largest mean speed of a watched block over the window (0 before the
        window has two frames)."""
        return max(self.speeds().values(), default=0.0)

    def moving(self) -> list[dict]:
        """The watched blocks faster than the limit, fastest first:
        ``[{"name": ..., "speed": ...}, ...]``."""
        fast = [(s, n) for n, s in self.speeds().items() if s > self.criterion.velocity]
        return [{"name": n, "speed": s} for s, n in sorted(fast, reverse=True)]

    @property
    def failed(self) -> bool:
        """True when the largest mean speed exceeds the limit."""
        return self.largest > self.criterion.velocity
