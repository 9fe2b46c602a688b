"""Keep numpy's and scipy's OpenBLAS on one thread while a run uses PARDISO's threads.

numpy and scipy each load an OpenBLAS library with its own thread pool. The
engine's BLAS calls are small (dot products of one K-sized vector, 16 x 16
capacitance matrices), but a vector of 60,000 numbers is long enough for
OpenBLAS to wake its threads, which then spin for a while. On the 2-core
benchmark machine they took the cores PARDISO's two threads were solving on:
at 10,000 blocks a back-substitution took 23-25 ms inside a run against
12-13 ms with OpenBLAS on one thread, and the whole step 437 against 317 ms
(docs/benchmarks.md). :func:`single_threaded_blas` sets every OpenBLAS
loaded in the process to one thread for the duration of a run and gives the
caller its thread counts back afterwards.

The libraries are found in ``/proc/self/maps`` (Linux) and set through
their exported ``*set_num_threads*`` functions; where neither is possible
(another system, a BLAS that is not OpenBLAS) nothing is changed.
"""

from __future__ import annotations

import ctypes
import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager

log = logging.getLogger(__name__)

# (getter, setter) names exported by the OpenBLAS builds in use: numpy's wheels
# (64-bit integers), scipy's wheels, a system OpenBLAS
_FUNCTION_NAMES = (
    ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
    ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
    ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
    ("openblas_get_num_threads", "openblas_set_num_threads"),
)


def loaded_openblas() -> list[tuple[str, ctypes._CFuncPtr, ctypes._CFuncPtr]]:
    """(path, get_num_threads, set_num_threads) of every OpenBLAS loaded in this process."""
    found = []
    for path in _loaded_libraries():
        if "openblas" not in os.path.basename(path).lower():
            continue
        try:
            library = ctypes.CDLL(path)  # already loaded: the same library, no new copy
        except OSError:
            continue
        for get_name, set_name in _FUNCTION_NAMES:
            getter = getattr(library, get_name, None)
            setter = getattr(library, set_name, None)
            if getter is not None and setter is not None:
                getter.restype, setter.restype = ctypes.c_int, None
                setter.argtypes = [ctypes.c_int]
                found.append((path, getter, setter))
                break
    return found


def _loaded_libraries() -> list[str]:
    """Paths of the shared libraries mapped into this process (empty where unknown)."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            paths = {line.split()[-1] for line in maps if ".so" in line}
    except OSError:
        return []
    return sorted(p for p in paths if p.startswith("/"))


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Within the block every loaded OpenBLAS uses one thread; the counts are restored after."""
    libraries = loaded_openblas()
    before = [getter() for _, getter, _ in libraries]
    for path, _, setter in libraries:
        setter(1)
        log.debug("OpenBLAS set to one thread: %s", path)
    try:
        yield
    finally:
        for (_, _, setter), threads in zip(libraries, before, strict=True):
            setter(threads)
