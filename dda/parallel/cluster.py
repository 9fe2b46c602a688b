"""Where tasks run: an existing dask scheduler (address or file), else a new local cluster.

dask (a dependency) is imported only when a cluster is used.
"""

from __future__ import annotations

import contextlib
import json
import logging
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

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

    @property
    def option(self) -> str:
        """The option that names the scheduler, with its value (a remote cluster's)."""
        if self.scheduler:
            return f"--scheduler {self.scheduler}"
        return f"--scheduler-file {self.scheduler_file}"


class ClusterError(Exception):
    """The named scheduler cannot be used: the option, its value and why, in one line."""


SCHEDULER_FILE = 'a dask scheduler file (JSON with an "address")'


def scheduler_file_problem(path: str) -> str | None:
    """Why the scheduler file at ``path`` cannot be used, or None. Checked before any
    work: dask waits without end for a file that is not there."""
    file = Path(path)
    if not file.exists():
        return "no such file"
    if not file.is_file():
        return f"not a file; give {SCHEDULER_FILE}"
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    except (UnicodeDecodeError, json.JSONDecodeError):
        data = None
    if not isinstance(data, dict) or not isinstance(data.get("address"), str):
        return f"not {SCHEDULER_FILE}"
    return None


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
        try:
            client = Client(address=cluster.scheduler, scheduler_file=cluster.scheduler_file)
        except (OSError, TimeoutError, ValueError) as exc:  # unreachable, refused, malformed
            raise ClusterError(f"{cluster.option}: cannot connect ({_reason(exc)})") from exc
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


def _reason(exc: BaseException) -> str:
    """An exception's message on one line, or its type where it has none."""
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


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
