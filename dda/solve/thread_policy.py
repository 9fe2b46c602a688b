"""How many threads the sparse solver gets: the cores the machine can give now.

On a shared machine the cores are not all free. Two PARDISO threads on a 2-core
machine that another process keeps busy made the 30x30 wall's step 1.3–2× slower
than one thread (docs/benchmarks.md), because a factorisation's threads wait for
each other and one of them waits for the other process. So, unless ``DDA_THREADS``
fixes the count, the solver takes the cores that the other processes left idle over
the last window:

    others = (Δ busy time of all CPUs − Δ CPU time of this process) / Δ wall time
    threads = clamp(round(usable − others · usable / cpus), 1, usable)

``usable``: the cores this process may run on, ``cpus``: the machine's (the
``cpu`` line of ``/proc/stat`` counts them all). The window is the time since the
last decision, at least :data:`WINDOW` seconds (the first one starts when this module
is imported and may be as short as :data:`FIRST_WINDOW`); a decision is kept until
the next window closes. Where ``/proc/stat``
cannot be read the solver takes every usable core.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

WINDOW = 1.0  # s: the shortest window a decision is made over ...
FIRST_WINDOW = 0.1  # s: ... but the first one, which starts at import, may be this short
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


@dataclass(frozen=True)
class CpuSample:
    """Cumulative counters at one moment."""

    wall: float  # s, monotonic
    busy: float  # s of all CPUs not idle since boot (None where unknown)
    own: float  # s of CPU this process used (all its threads)


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _machine_busy() -> tuple[float, int] | None:
    """(busy seconds of all CPUs since boot, number of CPUs) from ``/proc/stat``."""
    try:
        with open("/proc/stat", encoding="ascii") as stat:
            lines = stat.read().splitlines()
    except OSError:
        return None
    fields = [int(x) for x in lines[0].split()[1:]]
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)  # idle + iowait
    cpus = sum(1 for line in lines if line.startswith("cpu") and line[3:4].isdigit())
    return (sum(fields[:8]) - idle) / _TICKS, max(cpus, 1)


def sample() -> tuple[CpuSample, int] | None:
    """The counters now, and the machine's CPU count (None without ``/proc/stat``)."""
    machine = _machine_busy()
    if machine is None:
        return None
    busy, cpus = machine
    return CpuSample(time.monotonic(), busy, time.process_time()), cpus


def threads_for(usable: int, others_busy: float, cpus: int) -> int:
    """clamp(round(usable − others_busy · usable / cpus), 1, usable)."""
    others_here = max(others_busy, 0.0) * usable / max(cpus, usable)
    return min(usable, max(1, round(usable - others_here)))


def others_busy(before: CpuSample, after: CpuSample) -> float:
    """Cores the other processes kept busy between two samples (≥ 0)."""
    wall = after.wall - before.wall
    if wall <= 0.0:
        return 0.0
    return max(0.0, ((after.busy - before.busy) - (after.own - before.own)) / wall)


class ThreadPolicy:
    """The solver's threads, decided again once a window of :data:`WINDOW` s has passed."""

    def __init__(self) -> None:
        first = sample()
        self._last = None if first is None else first[0]
        self._threads = usable_cores()
        self._decided = False

    def threads(self) -> int:
        """The current decision (a fresh one when the window has closed)."""
        window = WINDOW if self._decided else FIRST_WINDOW
        if self._last is None or time.monotonic() - self._last.wall < window:
            return self._threads
        now = sample()
        if now is None:
            return self._threads
        current, cpus = now
        self._threads = threads_for(usable_cores(), others_busy(self._last, current), cpus)
        self._last, self._decided = current, True
        return self._threads


POLICY = ThreadPolicy()
