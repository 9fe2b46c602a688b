"""The plan of a scene's ``[[stages]]``: when each stage comes, which blocks it removes,
which bolts it installs and by what it divides the strengths, resolved to scene rows
(applied to a run by dda.run.stages)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.scene.format import Scene


@dataclass(frozen=True)
class StagePlan:
    """The stages of a scene, resolved to scene rows (= origin ids) and bolt indices."""

    times: np.ndarray  # (s,)
    removed: tuple[np.ndarray, ...]  # origin ids removed by each stage
    bolts: tuple[np.ndarray, ...]  # indices (dda.effects.bolts.RockBolts) installed by each
    hosts: np.ndarray  # (b, 2) origin ids of the start and end block of every stage bolt
    points: np.ndarray  # (b, 2, 2) their start and end points
    strength_factors: np.ndarray  # (s,) F of each stage, NaN: the stage sets none
    intact: np.ndarray  # (s,) bool: the stage's F divides the breakable materials' too

    def next_time(self, done: int) -> float:
        """Time of the next stage after ``done`` stages (inf: none left)."""
        return float(self.times[done]) if done < len(self.times) else np.inf

    def strength_after(self, done: int) -> tuple[float, bool]:
        """(F, intact) in force after ``done`` stages: those of the last of them that sets
        a ``strength_factor`` (each divides the scene's own strengths), else (1, False)."""
        set_by = np.flatnonzero(~np.isnan(self.strength_factors[:done]))
        if not len(set_by):
            return 1.0, False
        return float(self.strength_factors[set_by[-1]]), bool(self.intact[set_by[-1]])

    @property
    def changes_strengths(self) -> bool:
        return bool(np.any(~np.isnan(self.strength_factors)))


def stage_plan(scene: Scene) -> StagePlan | None:
    """The plan of ``scene.stages``; stage bolts follow the scene's bolts in the bolt list."""
    if not scene.stages:
        return None
    row = {b.name: k for k, b in enumerate(scene.blocks)}
    first = len(scene.bolts)
    bolts, hosts, points = [], [], []
    for stage in scene.stages:
        bolts.append(np.arange(first, first + len(stage.bolts)))
        first += len(stage.bolts)
        hosts += [[row[b.blocks[0]], row[b.blocks[1]]] for b in stage.bolts]
        points += [[b.start, b.end] for b in stage.bolts]
    return StagePlan(
        times=np.array([s.time for s in scene.stages]),
        removed=tuple(np.array([row[n] for n in s.remove], np.int64) for s in scene.stages),
        bolts=tuple(bolts),
        hosts=np.array(hosts, np.int64).reshape(-1, 2),
        points=np.array(points, float).reshape(-1, 2, 2),
        strength_factors=np.array(
            [np.nan if s.strength_factor is None else s.strength_factor for s in scene.stages]
        ),
        intact=np.array([s.intact for s in scene.stages], bool),
    )
