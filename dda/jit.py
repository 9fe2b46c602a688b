"""Compiled kernels (numba), used where a run is large enough to repay loading them.

Every kernel made with :func:`kernel` has a vectorised numpy twin at its call
site. numba is a dependency of the default install, but it is imported only
when a kernel is first called: compiling a kernel (once per installation;
numba caches the machine code on disk, ``cache=True``) or loading it from
that cache costs time and memory that a small run never earns back (about
0.6 s and 120 MiB for the 19 kernels; the numpy twins are 1-4 ms per step
slower on walls of 10-100 blocks). Call sites therefore ask
:func:`compiled`, which says yes outside a run and, inside one, when the
run's expected work (blocks x steps, :func:`run_work`) reaches
:data:`MIN_WORK`.

``DDA_NO_NUMBA=1`` turns the kernels off altogether (the tests compare both
paths with it); without numba installed the numpy twins run.
"""

from __future__ import annotations

import importlib.util
import logging
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

log = logging.getLogger(__name__)

# block-steps from which a run uses the kernels: loading them costs ~0.6 s, and they
# save ~1-4 ms per step on 10-100 blocks (break-even after 150-500 steps there)
MIN_WORK = 10_000

_RUN_WORK: ContextVar[float | None] = ContextVar("dda_run_work", default=None)


def numba_enabled() -> bool:
    """True when numba is installed and ``DDA_NO_NUMBA`` is not set to 1 (nothing imported)."""
    if os.environ.get("DDA_NO_NUMBA", "") == "1":
        return False
    return importlib.util.find_spec("numba") is not None


class Kernel:
    """A function compiled by ``numba.njit(cache=True, nogil=True)`` at its first call.

    Kernels that call other kernels (helpers bound to a module-level name)
    get the helpers' compiled dispatchers in their globals before they
    compile, as numba needs.
    """

    __slots__ = ("function", "_dispatcher")

    def __init__(self, function: Callable) -> None:
        self.function = function
        self._dispatcher: Callable | None = None

    @property
    def dispatcher(self) -> Callable:
        """The numba dispatcher (imports numba and binds the helpers the first time)."""
        if self._dispatcher is None:
            import numba

            namespace = self.function.__globals__
            for name in self.function.__code__.co_names:
                helper = namespace.get(name)
                if isinstance(helper, Kernel):
                    namespace[name] = helper.dispatcher
            self._dispatcher = numba.njit(cache=True, nogil=True)(self.function)
            log.debug("numba kernel %s", self.function.__qualname__)
        return self._dispatcher

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher(*args)


def kernel(function: Callable) -> Kernel | None:
    """A :class:`Kernel` of ``function``, or None when numba is off (callers keep numpy)."""
    return Kernel(function) if numba_enabled() else None


def compiled(compiled_kernel: Kernel | None) -> bool:
    """Whether a call site should use ``compiled_kernel`` rather than its numpy twin.

    False without the kernel; outside a run True; inside a run (:func:`run_work`)
    True when the run's work reaches :data:`MIN_WORK`.
    """
    if compiled_kernel is None:
        return False
    work = _RUN_WORK.get()
    return work is None or work >= MIN_WORK


@contextmanager
def run_work(blocks: int, steps: float) -> Iterator[bool]:
    """Within the block, kernels are used if ``blocks x steps`` reaches :data:`MIN_WORK`.

    Nested in another such block the larger work counts: a caller that stands for
    a long run (the benchmark, which times 100 steps of runs that last thousands)
    opens one around the run, and the run's own (smaller) figure does not turn the
    kernels off. Yields whether they are used.
    """
    outer = _RUN_WORK.get()
    work = float(blocks) * float(steps)
    token = _RUN_WORK.set(work if outer is None else max(outer, work))
    try:
        yield _RUN_WORK.get() >= MIN_WORK
    finally:
        _RUN_WORK.reset(token)
