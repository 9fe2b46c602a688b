"""What a run's numbers depend on besides the scene: versions, solver, threads.

Written into every summary (``summary["environment"]``) so that two runs
that differ can be told apart: docs/runs.md says which of these settings
give bit-identical repeats.
"""

from __future__ import annotations

import functools
import os
import platform
from importlib import metadata
from typing import Any

import numpy as np
import scipy

from dda.jit import numba_enabled
from dda.solve.linsolve import pardiso_available
from dda.solve.policy import current_policy


def environment() -> dict[str, Any]:
    """Versions, compiled kernels, sparse solver and its threads, MKL's reproducibility mode."""
    return {
        "dda": _version("dda-rock"),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": _version("numba") if numba_enabled() else None,
        "sparse_solver": "pardiso" if pardiso_available() else "superlu",
        "pypardiso": _version("pypardiso") if pardiso_available() else None,
        "threads": current_policy().solver_threads(),
        "mkl_cbwr": os.environ.get("MKL_CBWR"),
        "machine": platform.machine(),
    }


@functools.cache
def _version(package: str) -> str | None:
    """The installed version of ``package`` (None: not installed), read once a process:
    reading a package's metadata takes about 1 ms, and every run asks for three."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None
