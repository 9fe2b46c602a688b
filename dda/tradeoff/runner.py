"""Run the grid: one task per setting, in dask.distributed workers or serially.

A :class:`Task` carries everything a run needs: the scene as a dict (the
setting already applied by the client), the module-level function that
measures the result, the solver threads and the number of repeats. Workers
read no file, so a sweep runs on any dask cluster whose workers have dda
installed, whatever their working directory. The converged reference run of
a case without a closed form is a task too, submitted first (it is the
longest). Each task times its run ``repeats`` times in the same process and
reports the median (the first run of a process also loads compiled kernels;
identical runs on a shared machine vary by a factor of several), and the
host it ran on.

The pool of workers is :mod:`dda.parallel`'s (dask, a dependency, is imported only
when a sweep uses it).
"""

from __future__ import annotations

import logging
import os
import socket
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import dda
from dda.parallel import Cluster, Workers
from dda.solve.policy import THREADS_VARIABLE
from dda.tradeoff.cases import Case, model_size, relative_error
from dda.tradeoff.grid import Setting

log = logging.getLogger(__name__)

Progress = Callable[[int, int, dict], None]
MIN_REPEATS = 3  # a setting's time is the median of at least this many runs


@dataclass(frozen=True)
class Task:
    """One setting of one case, ready to run anywhere."""

    case: str
    scene: dict  # the raw scene with the setting applied
    measure: Callable[[dda.Result], np.ndarray]
    setting: Setting
    threads: int = 1  # PARDISO threads of this run (DDA_THREADS)
    repeats: int = MIN_REPEATS


def make_tasks(case: Case, settings: list[Setting], threads: int, repeats: int) -> list[Task]:
    """One task per setting (the scene dicts are built here, in the client)."""
    return [Task(case.name, case.scene(s), case.measure, s, threads, repeats) for s in settings]


_WARM = False


def _warm_up() -> None:
    """Run a tiny contact scene once per process, so first-call costs (imports,
    caches) are not charged to the first measured run."""
    global _WARM
    if not _WARM:
        dda.simulate(
            {
                "analysis": {"steps": 2},
                "materials": {"r": {"density": 1.0, "young": 1.0, "poisson": 0.2}},
                "blocks": [
                    {
                        "name": "a",
                        "material": "r",
                        "fixed": True,
                        "vertices": [[0, -1], [2, -1], [2, 0], [0, 0]],
                    },
                    {"name": "b", "material": "r", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]},
                ],
            }
        )
        _WARM = True


def run_task(task: Task) -> dict:
    """Run ``task`` ``task.repeats`` times; return its measured value and median wall time.

    The process's solver threads are set to ``task.threads`` first. A run that
    stops (``dda.SimulationError``) is reported once, with status ``failed``
    and no value.
    """
    os.environ[THREADS_VARIABLE] = str(task.threads)
    scene = dda.load_scene(task.scene)
    _warm_up()
    seconds: list[float] = []
    value, status, steps, penetration = None, "finished", 0, float("nan")
    for k in range(task.repeats):
        start = time.perf_counter()
        try:
            result = dda.simulate(scene)
        except dda.SimulationError as exc:
            seconds.append(time.perf_counter() - start)
            status = "failed"
            log.info("%s %s: %s", task.case, task.setting.label, exc)
            break
        seconds.append(time.perf_counter() - start)
        if k == 0:
            value = np.asarray(task.measure(result), float).tolist()
            steps, penetration = result.summary["steps"], result.summary["max_penetration"]
    return {
        **task.setting.as_dict(),
        "case": task.case,
        "status": status,
        "seconds": statistics.median(seconds),
        "seconds_all": seconds,
        "repeats": len(seconds),
        "threads": task.threads,
        "host": socket.gethostname(),
        "steps": steps,
        "max_penetration": penetration,
        "value": value if status == "finished" else None,
    }


def add_errors(rows: list[dict], case: Case, reference: np.ndarray | None) -> None:
    """Fill ``error`` (relative) and ``reference`` in place."""
    scale = model_size(case.raw) if case.per_model_size else None
    for row in rows:
        row["reference"] = None if reference is None else np.asarray(reference).tolist()
        if row["value"] is None or reference is None:
            row["error"] = float("nan")
        else:
            row["error"] = relative_error(np.asarray(row["value"]), reference, scale)


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep: ``rows`` holds the settings finished until then."""

    def __init__(self, rows: list[dict], total: int) -> None:
        super().__init__(f"interrupted after {len(rows)} of {total} settings")
        self.rows = rows
        self.total = total


def sweep(
    tasks: list[Task],
    reference: Task | None = None,
    cluster: Cluster | None = None,
    serial: bool = False,
    progress: Progress | None = None,
) -> tuple[list[dict], dict | None]:
    """Run the reference task (if any) and every task.

    Returns
    -------
    (rows in completion order, the reference's row or None); ``progress(done,
    total, row)`` is called for each row of ``tasks``.

    Raises
    ------
    SweepInterrupted
        On Ctrl-C, with the rows finished until then.
    """
    rows: list[dict] = []
    try:
        with Workers(None if serial else (cluster or Cluster())) as workers:
            # first in the queue: the longest run
            fine = None if reference is None else workers.submit(run_task, reference, priority=1)
            for row in workers.map_unordered(run_task, tasks):
                rows.append(row)
                if progress:
                    progress(len(rows), len(tasks), row)
            return rows, None if fine is None else fine.result()
    except KeyboardInterrupt:
        raise SweepInterrupted(rows, len(tasks)) from None
