"""Probability of failure over the realisations of a scene with random values.

Each realisation (:mod:`dda.stability.sampling`) is cut, run at F = 1 and judged by
the ``[fos]`` criterion (:mod:`dda.stability.criterion`), or given its own factor of
safety. Of n judged realisations k fail; P(failure) = k / n with Wilson's 95 %
score interval,

    (p̂ + z²/2n ± z √(p̂(1 − p̂)/n + z²/4n²)) / (1 + z²/n),   z = 1.959964,

whose width shrinks as 1/√n. A realisation whose scene is refused (a drawn joint
set that cuts an impossible block) is reported and left out of n.
"""

from __future__ import annotations

import math
import socket
import time
from dataclasses import dataclass

import dda
from dda.stability.fos import factor_of_safety
from dda.stability.sampling import realise
from dda.stability.trial import Trial, run_trial

Z95 = 1.959963984540054  # the 97.5 % point of the standard normal


@dataclass(frozen=True)
class Realisation:
    """Realisation ``index`` of the ensemble of a scene (raw dict, with ``[ensemble]``)."""

    scene: dict
    index: int
    source: str = "<dict>"
    fos: bool = False  # also search its factor of safety
    keep_frame: bool = True


def wilson(failures: int, n: int, z: float = Z95) -> tuple[float, float, float]:
    """(p̂, low, high): the fraction failing and its Wilson score interval."""
    if n == 0:
        return math.nan, 0.0, 1.0
    p = failures / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # no failure (or no survivor) puts that end at 0 (or 1) exactly, not at its round-off
    low = 0.0 if failures == 0 else max(0.0, centre - half)
    high = 1.0 if failures == n else min(1.0, centre + half)
    return p, low, high


def run_realisation(task: Realisation) -> dict:
    """Draw, cut, run and judge one realisation; its row (with ``values``, the drawn
    values, and ``frame`` for a failure when ``keep_frame``)."""
    base = dda.load_scene(task.scene, task.source)
    raw, values = realise(task.scene, base.ensemble, task.index)
    row = {"realisation": task.index, "seed": base.ensemble.seed, "values": values,
           "fos": math.nan, "frame": None}  # fmt: skip
    start = time.perf_counter()
    try:
        dda.load_scene(raw, task.source)
    except dda.SceneError as exc:
        return {**row, "failed": None, "speed": math.nan, "limit": math.nan, "steps": 0,
                "seconds": time.perf_counter() - start, "host": socket.gethostname(),
                "status": f"refused: {exc.key}: {exc.reason}"}  # fmt: skip
    trial = run_trial(Trial(raw, 1.0, task.source, task.keep_frame))
    row.update(trial)
    row["factor"] = None
    if task.fos:
        outcome, _ = factor_of_safety(raw)
        row["fos"] = outcome.fos if outcome.fos is not None else math.nan
    row["seconds"] = time.perf_counter() - start
    return row
