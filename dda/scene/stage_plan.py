"""The plan of a scene's ``[[stages]]``: when each stage comes, which blocks it removes and
which bolts it installs, resolved to scene rows (applied to a run by dda.run.stages)."""

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

    def next_time(self, done: int) -> float:
        """Time of the next stage after ``done`` stages (inf: none left)."""
        return float(self.times[done]) if done < len(self.times) else np.inf


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
    )
