"""Optional compiled kernels: numba when it is installed, numpy otherwise.

Every kernel compiled with :func:`kernel` has a vectorised numpy twin used
when numba is missing (or when ``DDA_NO_NUMBA=1`` is set, which the tests
use to check that both give the same numbers). numba is not a dependency:
it makes assembly and contact search several times faster on large models
(docs/benchmarks.md), nothing more.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable

log = logging.getLogger(__name__)


def numba_enabled() -> bool:
    """True when numba can be imported and ``DDA_NO_NUMBA`` is not set to 1."""
    if os.environ.get("DDA_NO_NUMBA", "") == "1":
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def kernel(function: Callable) -> Callable | None:
    """``numba.njit(cache=True)`` of ``function``, or None without numba.

    Callers keep a numpy path for None. Compilation happens lazily, at the
    first call, and is cached on disk next to the module.
    """
    if not numba_enabled():
        return None
    import numba

    return numba.njit(cache=True, nogil=True)(function)
