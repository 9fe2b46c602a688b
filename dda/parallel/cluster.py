"""Where tasks run: an existing dask scheduler (address or file), else a new local cluster.

dask (a dependency) is imported only when a cluster is used.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Cluster:
    """Where the tasks run: a scheduler (address or file), else a local cluster."""

    scheduler: str | None = None
    scheduler_file: str | None = None
    workers: int = 2  # local cluster only
    verbose: bool = False  # distributed's INFO logs

    @property
    def remote(self) -> bool:
        """True when an existing scheduler is named."""
        return bool(self.scheduler or self.scheduler_file)


def has_dask() -> bool:
    """True when dask.distributed (the ``tradeoff`` extra) can be imported."""
    from importlib.util import find_spec

    return find_spec("dask") is not None and find_spec("distributed") is not None


def connect(cluster: Cluster):
    """A client of the given scheduler, or of a new local cluster (returned second)."""
    import dask
    from dask.distributed import Client, LocalCluster

    # quiet unless -v: a Ctrl-C would otherwise print the workers' shutdown warnings
    level = logging.INFO if cluster.verbose else logging.ERROR
    dask.config.set({"logging.distributed": logging.getLevelName(level).lower()})
    logging.getLogger("distributed").setLevel(level)
    if cluster.remote:
        client = Client(address=cluster.scheduler, scheduler_file=cluster.scheduler_file)
        log.info("connected to %s (dashboard %s)", client.scheduler.address, client.dashboard_link)
        return client, None
    with _sigint_ignored():  # Ctrl-C stops the client, which closes the workers
        local = LocalCluster(
            n_workers=cluster.workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port, never a fixed one another program may hold
            silence_logs=level,
        )
    client = Client(local)
    log.info("local cluster of %d workers (dashboard %s)", cluster.workers, client.dashboard_link)
    return client, local


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while worker processes start: they inherit it, so Ctrl-C in the
    terminal (sent to the whole process group) reaches the client only, which closes
    them, and the workers do not die printing tracebacks of their own."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
