"""Draw the suite's pictures in forked child processes, beside the work that goes on.

The pictures are independent files, each a few tenths of a second to a second
of CPU (VTK renders, matplotlib's text layout, PNG encoding). A
:class:`Painter` hands each batch of drawing jobs to a forked child (it inherits
the results: nothing is pickled, and only writes files whose paths are known in
advance) and returns at once, so the pictures of the first cases are drawn while
the suite runs the others, and the rest while it runs its studies. Without fork
(or on one core) the jobs run at once, one after the other, in this process.
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


class Painter:
    """Runs batches of drawing jobs in forked children; :meth:`wait` joins them."""

    def __init__(self) -> None:
        self.forks = _cores() >= 2 and "fork" in multiprocessing.get_all_start_methods()
        self.children: list[multiprocessing.Process] = []

    def submit(self, jobs: list[Job]) -> None:
        """Draw ``jobs`` in a child process (or here and now without fork)."""
        if not jobs:
            return
        if not self.forks:
            _draw(jobs)
            return
        child = multiprocessing.get_context("fork").Process(target=_draw, args=(list(jobs),))
        child.start()
        self.children.append(child)

    def wait(self) -> None:
        """Wait for every child; RuntimeError when one failed (its error is in the log)."""
        failed = []
        for child in self.children:
            child.join()
            if child.exitcode != 0:
                failed.append(child.exitcode)
        self.children = []
        if failed:
            raise RuntimeError(f"drawing pictures failed in a child process (exit {failed[0]})")
