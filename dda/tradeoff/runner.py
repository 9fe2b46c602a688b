"""Run the grid: one run per setting, in dask.distributed workers or serially.

``run_one`` is a top-level function of an importable module and returns a
plain dict, so that spawned worker processes can run it and send the result
back. dask is imported only when a sweep uses it (optional extra
``dda-rock[tradeoff]``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import numpy as np

import dda
from dda.linsolve import THREADS_VARIABLE
from dda.tradeoff.cases import get_case, model_size, relative_error
from dda.tradeoff.grid import Setting

log = logging.getLogger(__name__)

Progress = Callable[[int, int, dict], None]


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


def run_one(case_name: str, setting: Setting) -> dict:
    """Run ``case_name`` with ``setting``; return the measured values and the wall time.

    A run that stops (``dda.SimulationError``) is reported with status
    ``failed`` and no value.
    """
    case = get_case(case_name)
    scene = dda.load_scene(case.scene(setting))
    _warm_up()
    start = time.perf_counter()
    try:
        result = dda.simulate(scene)
        value, status, steps = case.measure(result), "finished", result.summary["steps"]
        penetration = result.summary["max_penetration"]
    except dda.SimulationError as exc:
        value, status, steps, penetration = None, "failed", 0, float("nan")
        log.info("%s %s: %s", case_name, setting.label, exc)
    seconds = time.perf_counter() - start
    return {
        **setting.as_dict(),
        "case": case_name,
        "status": status,
        "seconds": seconds,
        "steps": steps,
        "max_penetration": penetration,
        "value": None if value is None else np.asarray(value, float).tolist(),
    }


def add_errors(rows: list[dict], case_name: str, reference: np.ndarray | None) -> None:
    """Fill ``error`` (relative) and ``reference`` in place."""
    case = get_case(case_name)
    scale = model_size(case.raw) if case.per_model_size else None
    for row in rows:
        row["reference"] = None if reference is None else np.asarray(reference).tolist()
        if row["value"] is None or reference is None:
            row["error"] = float("nan")
        else:
            row["error"] = relative_error(np.asarray(row["value"]), reference, scale)


def sweep(
    case_name: str,
    settings: list[Setting],
    scheduler: str | None = None,
    serial: bool = False,
    progress: Progress | None = None,
) -> list[dict]:
    """Run every setting; rows in completion order (with ``progress(done, total, row)``)."""
    if serial:
        rows = []
        for k, s in enumerate(settings):
            rows.append(run_one(case_name, s))
            if progress:
                progress(k + 1, len(settings), rows[-1])
        return rows
    return _distributed(case_name, settings, scheduler, progress)


def _distributed(case_name, settings, scheduler, progress) -> list[dict]:
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={THREADS_VARIABLE: "1"},  # two workers share the cores: no MKL threads
        )
    client = Client(scheduler or cluster)
    try:
        futures = client.map(run_one, [case_name] * len(settings), settings, pure=False)
        rows = []
        for future in as_completed(futures):
            rows.append(future.result())
            if progress:
                progress(len(rows), len(settings), rows[-1])
        return rows
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
