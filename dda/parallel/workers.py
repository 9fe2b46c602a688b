"""A pool of workers that runs batches of tasks and hands back each result as it finishes.

``Workers(cluster)`` connects once (a local dask cluster or an existing scheduler) and
is used for several batches: a search that decides its next trials from the last
ones does not pay for a new cluster per round. ``Workers(None)`` runs every task in
this process, in order. Leaving the ``with`` block (also by Ctrl-C) cancels what is
still queued and closes the client and any local cluster.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Any

from dda.parallel.cluster import Cluster, ClusterError, connect

# seconds a named scheduler may take to have a worker
WAIT_FOR_WORKERS = 60


class Workers:
    """Run ``function(item)`` for batches of items, serially or on a dask cluster."""

    def __init__(self, cluster: Cluster | None = None) -> None:
        self.cluster = cluster
        self._client = None
        self._local = None
        self._pending: list[Any] = []

    @property
    def size(self) -> int:
        """How many tasks can run at once (1 in this process)."""
        if self._client is None:
            return 1
        return max(1, len(self._client.scheduler_info().get("workers", {})))

    def __enter__(self) -> Workers:
        """Connect (:func:`dda.parallel.cluster.connect`); a named scheduler that cannot
        be reached, or that has no worker within ``WAIT_FOR_WORKERS`` seconds, raises
        :class:`dda.parallel.cluster.ClusterError`."""
        if self.cluster is not None:
            self._client, self._local = connect(self.cluster)
            if self.cluster.remote:
                try:
                    self._client.wait_for_workers(1, timeout=WAIT_FOR_WORKERS)
                except TimeoutError as exc:
                    self.__exit__(None, None, None)
                    raise ClusterError(
                        f"{self.cluster.option}: no worker joined it within {WAIT_FOR_WORKERS} s"
                    ) from exc
        return self

    def __exit__(self, *exc: object) -> None:
        if self._client is not None:
            for future in self._pending:
                future.cancel()
            self._client.close()
        if self._local is not None:
            self._local.close()
        self._client = self._local = None

    def map_unordered(self, function: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        """``function(item)`` for every item, yielded in the order they finish."""
        items = list(items)
        if self._client is None:
            for item in items:
                yield function(item)
            return
        from dask.distributed import as_completed

        self._pending = self._client.map(function, items, pure=False)
        try:
            for future in as_completed(self._pending):
                yield future.result()
        finally:
            self._pending = []

    def submit(self, function: Callable[[Any], Any], item: Any, priority: int = 0) -> Any:
        """A future of ``function(item)`` (a finished one in this process)."""
        if self._client is None:
            return _Done(function(item))
        return self._client.submit(function, item, pure=False, priority=priority)


class _Done:
    """The result of a task run in this process, shaped like a future."""

    def __init__(self, value: Any) -> None:
        self._value = value

    def result(self) -> Any:
        return self._value
