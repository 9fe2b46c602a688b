"""Seconds spent per named stage of the step."""

from __future__ import annotations

import time
from collections import defaultdict


class StageTimer:
    """Accumulates wall seconds per stage: ``with timer("assembly"): ...``."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)

    def __call__(self, stage: str) -> _Stage:
        return _Stage(self.seconds, stage)

    def as_dict(self) -> dict[str, float]:
        return {k: round(v, 6) for k, v in sorted(self.seconds.items())}


class _Stage:
    """One ``with timer(stage)``: a plain context manager, not a generator's (a step
    enters about 14 of them: 1.1 µs each against 2.6 µs)."""

    __slots__ = ("seconds", "stage", "start")

    def __init__(self, seconds: dict[str, float], stage: str) -> None:
        self.seconds, self.stage = seconds, stage

    def __enter__(self) -> None:
        self.start = time.perf_counter()

    def __exit__(self, *exc) -> None:
        self.seconds[self.stage] += time.perf_counter() - self.start
