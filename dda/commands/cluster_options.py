"""The options that say where a command's tasks run (``dda tradeoff``, ``dda fos``,
``dda ensemble``): ``--workers N | --scheduler ADDRESS | --scheduler-file FILE |
--serial``."""

from __future__ import annotations

import argparse
from typing import Any


def count(text: str) -> int:
    """A positive integer argument."""
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return int(text)


def add_cluster_options(parser: Any, workers: int = 2) -> None:
    """Add the mutually exclusive options of where the tasks run."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=count,
        default=workers,
        metavar="N",
        help=f"workers of the local cluster (default {workers}; one thread each)",
    )
    where.add_argument("--scheduler", metavar="ADDRESS", help="a running dask scheduler")
    where.add_argument(
        "--scheduler-file", metavar="FILE", help="the file a running dask scheduler wrote"
    )
    where.add_argument("--serial", action="store_true", help="run in this process")


def cluster_of(args: argparse.Namespace):
    """The :class:`dda.parallel.Cluster` the options name, or None for ``--serial``."""
    from dda.parallel import Cluster

    if args.serial:
        return None
    return Cluster(
        args.scheduler, args.scheduler_file, args.workers, getattr(args, "verbose", 0) > 0
    )


def dask_missing(command: str) -> str:
    """The one-line refusal when a cluster is asked for without dask installed."""
    return (
        f"dda {command}: a cluster needs dask[distributed]: pip install 'dda-rock[tradeoff]' "
        "(or from a clone: pip install -e '.[tradeoff]'), or run with --serial"
    )
