"""Running independent tasks at once: in this process, in local worker processes, or on
a dask cluster (``cluster.py``: where; ``workers.py``: the pool that hands results back
as they finish). Used by the sweeps of :mod:`dda.tradeoff` and the trials of
:mod:`dda.stability`. Imports no engine code.
"""

from dda.parallel.cluster import Cluster, ClusterError, connect, has_dask, scheduler_file_problem
from dda.parallel.workers import Workers

__all__ = ["Cluster", "ClusterError", "Workers", "connect", "has_dask", "scheduler_file_problem"]
