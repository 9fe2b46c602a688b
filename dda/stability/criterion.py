"""When a strength-reduction trial fails: its watched blocks do not come to rest.

A trial runs the reduced scene for ``duration``; over the last ``window`` of it the
largest speed of any watched block is recorded,

    s = max over blocks and steps of ( |v| + |ω| r ),

v the centroid velocity, ω the spin and r the largest distance of a vertex from the
centroid (s bounds the speed of every point of the block). The trial fails when
s > ``velocity``. The default limit is ``acceleration`` × |g| × ``duration``: the speed
an out-of-balance force of that fraction of the weight gives a block from rest over
the trial. A block that stands stays at rest (the equilibrium start, docs/contact.md);
one that slides at an out-of-balance acceleration a reaches a t, so at the default
(1e-4) a slide is caught once a > 1e-4 g.
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

    @property
    def judged_from(self) -> float:
        """The time from which speeds count."""
        return self.duration * (1.0 - self.window)


def run_length(scene: Scene) -> float:
    """The simulated time of the scene's run (``duration``, or ``steps`` × ``time_step``)."""
    a = scene.analysis
    return a.duration if a.duration is not None else a.steps * a.time_step


def criterion_of(scene: Scene) -> Criterion:
    """The criterion of ``scene``'s ``[fos]`` table (defaults resolved).

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
    duration = fos.duration if fos.duration is not None else run_length(scene)
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
    return Criterion(duration, fos.window, velocity, fos.blocks)


def block_speeds(frame: Frame) -> np.ndarray:
    """|v| + |ω| r of every block of ``frame`` (r: its farthest vertex from the centroid)."""
    counts = np.array([len(v) for v in frame.vertices])
    if not len(counts):
        return np.zeros(0)
    xy = np.concatenate(frame.vertices) - np.repeat(frame.centroids, counts, axis=0)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    radius = np.sqrt(np.maximum.reduceat((xy * xy).sum(axis=1), starts))
    v = frame.velocities
    return np.hypot(v[:, 0], v[:, 1]) + np.abs(v[:, 2]) * radius


class SpeedWatch:
    """An ``on_frame`` callback that keeps the largest watched speed in the window."""

    def __init__(self, criterion: Criterion) -> None:
        self.criterion = criterion
        self.largest = 0.0

    def __call__(self, frame: Frame) -> None:
        if frame.time < self.criterion.judged_from * (1.0 - 1e-12):
            return
        watched = ~np.asarray(frame.fixed, bool)
        if self.criterion.blocks:
            parents = np.array([n.split("/")[0] for n in frame.names])
            watched &= np.isin(parents, self.criterion.blocks)
        if watched.any():
            self.largest = max(self.largest, float(block_speeds(frame)[watched].max()))

    @property
    def failed(self) -> bool:
        """True when the largest speed exceeds the limit."""
        return self.largest > self.criterion.velocity
