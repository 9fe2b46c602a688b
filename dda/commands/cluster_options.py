"""The options that say where a command's tasks run (``dda tradeoff``, ``dda fos``,
``dda ensemble``): ``--workers N | --scheduler ADDRESS | --scheduler-file FILE |
--serial``."""

from __future__ import annotations

import argparse
import logging
from typing import Any

log = logging.getLogger(__name__)


def count(text: str) -> int:
    """A positive integer argument."""
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return int(text)


DEFAULT_WORKERS = 2  # of the local cluster, when --workers is not given


def add_cluster_options(parser: Any, workers: int = DEFAULT_WORKERS) -> None:
    """Add the mutually exclusive options of where the tasks run.

    ``--workers`` has no default of its own (None; :func:`local_workers` gives
    ``workers`` then): argparse takes an option whose value *is* its default for one not
    given, so ``--serial --workers 2`` would pass its exclusion check.
    """
    parser.set_defaults(default_workers=workers)
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=count,
        metavar="N",
        help=f"workers of the local cluster (default {workers}; one thread each)",
    )
    where.add_argument("--scheduler", metavar="ADDRESS", help="a running dask scheduler")
    where.add_argument(
        "--scheduler-file", metavar="FILE", help="the file a running dask scheduler wrote"
    )
    where.add_argument("--serial", action="store_true", help="run in this process")


def cluster_of(args: argparse.Namespace, command: str | None = None):
    """The :class:`dda.parallel.Cluster` the options name, or None for ``--serial``.

    The one-line refusal (a str) when ``--scheduler-file`` cannot be used
    (:func:`scheduler_refusal`). With ``command`` (a command that can run without dask):
    None also when dask is not installed and no scheduler is named (a warning says so),
    and the one-line refusal when a scheduler is named without dask.
    """
    from dda.parallel import Cluster, has_dask

    if args.serial:
        return None
    refused = scheduler_refusal(args)
    if refused:
        return f"dda {command}: {refused}" if command else refused
    cluster = Cluster(
        args.scheduler, args.scheduler_file, local_workers(args), getattr(args, "verbose", 0) > 0
    )
    if command is None or has_dask():
        return cluster
    if cluster.remote:
        return dask_missing(command)
    log.warning("dask is not installed: the tasks run in this process")
    return None


def scheduler_refusal(args: argparse.Namespace) -> str | None:
    """Why ``--scheduler-file`` cannot be used (``--scheduler-file FILE: reason``), or
    None: checked before any work, as dask would wait for a missing file without end."""
    from dda.parallel import scheduler_file_problem

    path = getattr(args, "scheduler_file", None)
    if getattr(args, "serial", False) or not path:
        return None
    problem = scheduler_file_problem(path)
    return None if problem is None else f"--scheduler-file {path}: {problem}"


def local_workers(args: argparse.Namespace) -> int:
    """The local cluster's workers: ``--workers``, else the command's default."""
    if args.workers is not None:
        return args.workers
    return getattr(args, "default_workers", DEFAULT_WORKERS)


def dask_missing(command: str) -> str:
    """The one-line refusal when a cluster is asked for without dask installed."""
    return (
        f"dda {command}: a cluster needs dask[distributed], a dependency of dda-rock "
        "that is missing here: pip install 'dask[distributed]', or run with --serial"
    )
