"""Draw the suite's pictures, in two processes where the platform can fork.

The pictures are independent files, each a few tenths of a second to a second
of CPU (VTK renders, matplotlib's text layout, PNG encoding): on a machine with
two cores or more, a forked child draws every other picture while this process
draws the rest, which halves the wall time of the pictures of ``dda verify
--quick``. The child inherits the results (nothing is pickled) and only writes
files; its paths are known in advance. Without fork, or on one core, they are
drawn here one after the other.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable
from pathlib import Path

log = logging.getLogger(__name__)

Job = Callable[[], Path]


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _draw(jobs: list[Job]) -> None:
    for job in jobs:
        job()


def draw(jobs: list[Job]) -> None:
    """Run every job (each writes one picture); two processes when it pays.

    Raises RuntimeError when the child fails (its error is in the log).
    """
    if len(jobs) < 2 or _cores() < 2 or "fork" not in multiprocessing.get_all_start_methods():
        _draw(jobs)
        return
    child = multiprocessing.get_context("fork").Process(target=_draw, args=(jobs[1::2],))
    child.start()
    try:
        _draw(jobs[0::2])
    finally:
        child.join()
    if child.exitcode != 0:
        raise RuntimeError(f"drawing pictures failed in a child process (exit {child.exitcode})")
