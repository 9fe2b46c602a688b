"""Compiled kernels (numba), used where a run is large enough to repay loading them.

Every kernel made with :func:`kernel` has a vectorised numpy twin at its call
site. numba is a dependency of the default install, but it is imported only
when a kernel is first called: compiling a kernel (once per installation;
numba caches the machine code on disk, ``cache=True``) or loading it from
that cache costs time and memory that a short run never earns back (about
0.5 s and 120 MiB; the numpy twins are 1.5-3 ms per step slower on models
of 2-100 blocks, whatever their size: the twins' cost there is numpy's per
call). Call sites therefore ask :func:`compiled`, which says yes outside a
run and, inside one (:func:`run_work`), when the run's expected steps reach
:data:`MIN_STEPS` or its work (blocks x steps) :data:`MIN_WORK`.

Kernels copy an array into a slice or an index set element by element, in loops
(``for k in range(n): a[k] = b[k]``), never by ``a[:] = b`` or ``a[rows] = b``: for such
an assignment numba compiles its shape-mismatch error message with its string
formatting, about 9 s of CPU more in a process's first compile of the rock slope's
kernels (docs/design.md, "Compiled kernels and start-up"). ``tests/jit/test_jit.py``
checks the kernels' slices.

``DDA_NO_NUMBA=1`` turns the kernels off altogether (the tests compare both
paths with it); without numba installed the numpy twins run.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

import numpy as np

from dda.jit.cache import cached_dispatcher

log = logging.getLogger(__name__)

# block-steps from which a run uses the kernels: loading them costs ~0.5 s, and they
# save ~1-4 ms per step on 10-100 blocks (break-even after 150-500 steps there)
MIN_WORK = 10_000
# ... and steps, whatever the blocks: whole `dda run` processes, CPU s, numpy twins against
# kernels (loading included), two runs each: the six-block stack, 1,000 steps, 6.7-7.0
# against 3.9-5.2; the paper's two blocks stretched to 1,500 steps 6.3-7.2 against
# 4.8-5.0 (about 1.5 ms a step saved); at its own 315 steps 1.6-2.3 against 2.4-2.8,
# and the sliding block's 100 steps 1.2-1.3 against 1.8
MIN_STEPS = 500

# (work, steps) of the run being made, None outside a run
_RUN_WORK: ContextVar[tuple[float, float] | None] = ContextVar("dda_run_work", default=None)


# 1: no compiled kernels, numpy's path throughout (0 or unset: the kernels; the run's
# policy refuses any other value, dda.solve.policy.StepPolicy.from_environment)
NO_NUMBA_VARIABLE = "DDA_NO_NUMBA"


def numba_enabled() -> bool:
    """True when numba is installed and ``DDA_NO_NUMBA`` is not set to 1 (nothing imported)."""
    if os.environ.get(NO_NUMBA_VARIABLE, "").strip() == "1":
        return False
    return importlib.util.find_spec("numba") is not None


class Kernel:
    """A function compiled by ``numba.njit(nogil=True)`` at its first call, cached on disk
    under a stamp of all its sources (:mod:`dda.jit.cache`).

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
        """The numba dispatcher (imports numba and binds the helpers the first time,
        after the callbacks of :func:`before_first_use`)."""
        if self._dispatcher is None:
            for callback in _BEFORE_FIRST_USE:
                callback(self.function.__module__)
            _quick_compiles()
            namespace = self.function.__globals__
            for name in self.function.__code__.co_names:
                helper = namespace.get(name)
                if isinstance(helper, Kernel):
                    namespace[name] = helper.dispatcher
                elif isinstance(helper, Lapack):
                    namespace[name] = helper.external()
            _register_formulas()
            _announce_compiling()
            self._dispatcher = cached_dispatcher(self.function, nogil=True)
            log.debug("numba kernel %s", self.function.__qualname__)
        return self._dispatcher

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher(*args)


class Lapack:
    """A LAPACK routine (scipy's ``cython_lapack``) that kernels call by name.

    Bound in a kernel's globals like a helper kernel: the routine's address is
    registered with LLVM under ``dda_lapack_<name>`` and the kernel calls it as an
    external function of ``arguments`` pointers (every LAPACK argument is passed by
    address). Being resolved by symbol at load time, not baked in as an address, the
    kernels that call it stay in numba's on-disk cache.
    """

    __slots__ = ("name", "arguments", "_external")

    def __init__(self, name: str, arguments: int) -> None:
        self.name, self.arguments = name, arguments
        self._external = None

    def external(self):
        """The numba ``ExternalFunction`` (registers the symbol the first time)."""
        if self._external is None:
            import llvmlite.binding as llvm
            from numba import types
            from numba.extending import get_cython_function_address

            symbol = f"dda_lapack_{self.name}"
            address = get_cython_function_address("scipy.linalg.cython_lapack", self.name)
            llvm.add_symbol(symbol, address)
            pointers = [types.voidptr] * self.arguments
            self._external = types.ExternalFunction(symbol, types.void(*pointers))
        return self._external


# LLVM's optimisation level of the kernels (numba's NUMBA_OPT) unless the environment
# sets one: -O1 compiles the rock slope's kernels in 51.6 s of CPU against 57.1-57.7 at
# numba's default -O3 (an empty cache, two rounds), gives the same numbers to the bit
# (the rock slope, the tunnel, the 10 x 10 wall) and runs as fast: warm runs, one
# solver thread, medians of five, the tunnel 7.43 s against 7.46, the rock slope 2.18
# against 2.12; the walls of dda bench within their noise
OPTIMISATION_LEVEL = "1"


def _quick_compiles() -> None:
    """Set numba's optimisation level to :data:`OPTIMISATION_LEVEL` before numba is
    first imported, unless ``NUMBA_OPT`` is set (numba reads it once, on import; a
    process that imported numba first keeps its level)."""
    if "numba" not in sys.modules:
        os.environ.setdefault("NUMBA_OPT", OPTIMISATION_LEVEL)


_FORMULAS: list[Callable] = []  # functions of :func:`formula`, in the order defined
_REGISTERED = [0]  # how many of them numba knows


def select(condition, if_true, if_false):
    """``np.where(condition, if_true, if_false)`` in a formula: an array of arrays, a
    number of numbers.

    In a kernel, of numbers, it compiles to the plain choice ``if_true if condition else
    if_false``: numba's ``np.where`` of numbers makes a 0-d array on the heap, about
    330 ns a call against 1 ns (a loop of 10^6 calls), which made the contact law's
    loops several times slower (:func:`_register_select`).
    """
    return np.where(condition, if_true, if_false)[()]


def _register_select() -> None:
    """Compile :func:`select` of numbers to a branch, of arrays to ``np.where``."""
    from numba import types
    from numba.extending import overload

    @overload(select)
    def _select(condition, if_true, if_false):
        if isinstance(condition, (types.Boolean, types.Number)):

            def choose(condition, if_true, if_false):
                return if_true if condition else if_false

            return choose

        def where(condition, if_true, if_false):
            return np.where(condition, if_true, if_false)

        return where


def formula(function: Callable) -> Callable:
    """Mark ``function`` as a formula: written with numpy's elementwise functions and
    arithmetic only, it takes arrays from numpy code (called as it is) and numbers from
    kernels, which compile it into themselves (numba's ``register_jitable``, done when
    the first kernel compiles). One definition serves both paths."""
    _FORMULAS.append(function)
    return function


def _register_formulas() -> None:
    """Let numba compile the formulas defined so far into the kernels that call them."""
    if _REGISTERED[0] == len(_FORMULAS):
        return
    from numba.extending import register_jitable

    if _REGISTERED[0] == 0:
        _register_select()

    for function in _FORMULAS[_REGISTERED[0] :]:
        register_jitable(function)
    _REGISTERED[0] = len(_FORMULAS)


_COMPILING_LISTENER: Any = None  # the numba event listener of :func:`_announce_compiling`
# callbacks of a kernel's module: when this process first begins to compile a kernel, and
# before it first uses each kernel (dda.commands.compile_helper's)
_FIRST_COMPILE: list[Callable[[str], None]] = []
_BEFORE_FIRST_USE: list[Callable[[str], None]] = []
_WAITED = [0.0]  # seconds spent waiting for kernels that another process compiles


def on_first_compile(callback: Callable[[str], None]) -> None:
    """Call ``callback(module)`` when this process first begins to compile a kernel
    (not to load one from the cache), ``module`` the kernel's."""
    if callback not in _FIRST_COMPILE:
        _FIRST_COMPILE.append(callback)


def before_first_use(callback: Callable[[str], None]) -> None:
    """Call ``callback(module)`` before this process first uses each kernel (compiles it
    or loads it from the cache), ``module`` the kernel's."""
    if callback not in _BEFORE_FIRST_USE:
        _BEFORE_FIRST_USE.append(callback)


def waited_for_kernels(seconds: float) -> None:
    """Count ``seconds`` spent waiting for another process to compile kernels in
    :func:`compile_seconds`."""
    _WAITED[0] += seconds


def compile_seconds() -> float:
    """Seconds this process has spent compiling kernels (not loading them from numba's
    cache), or waiting for another process that compiles them (:func:`waited_for_kernels`):
    0 on a warm install. A run's summary reports its share (``compile_seconds``), which
    its wall time includes."""
    own = 0.0 if _COMPILING_LISTENER is None else _COMPILING_LISTENER.seconds
    return own + _WAITED[0]


def _announce_compiling() -> None:
    """Say once in a process when numba starts compiling a kernel (not loading it from
    its cache), and count the seconds: the first run after installing or upgrading waits
    for the kernels it uses (the rock slope's: 44-54 s on the 2-core benchmark machine
    with the compile helper, 73-94 s without; docs/benchmarks.md), and would otherwise
    seem to hang at its first step.

    Uses numba's event API: ``numba:compile`` fires only for a compilation, never
    for a load from the on-disk cache; a kernel's helpers compile inside it (nested
    events), counted once.
    """
    global _COMPILING_LISTENER
    if _COMPILING_LISTENER is not None:
        return
    import time

    from numba.core import event

    class CompilingListener(event.Listener):
        announced = False
        seconds, depth, started = 0.0, 0, 0.0

        def on_start(self, ev: event.Event) -> None:
            if not self.announced:
                self.announced = True
                dispatcher = ev.data.get("dispatcher")
                module = getattr(getattr(dispatcher, "py_func", None), "__module__", "")
                for callback in _FIRST_COMPILE:
                    callback(module)
                log.warning(
                    "compiling the kernels this run needs for this machine (each once per "
                    "installation; numba keeps them in its cache): it may start about 1 to 3 "
                    "minutes late"
                )
            if self.depth == 0:
                self.started = time.perf_counter()
            self.depth += 1

        def on_end(self, ev: event.Event) -> None:
            self.depth -= 1
            if self.depth == 0:
                self.seconds += time.perf_counter() - self.started

    _COMPILING_LISTENER = CompilingListener()
    event.register("numba:compile", _COMPILING_LISTENER)


def floats(values) -> Any:
    """``values`` as a contiguous float64 array: the kernels' argument type."""
    return np.ascontiguousarray(values, dtype=np.float64)


def kernel(function: Callable) -> Kernel | None:
    """A :class:`Kernel` of ``function``, or None when numba is off (callers keep numpy)."""
    return Kernel(function) if numba_enabled() else None


def compiled(compiled_kernel: Kernel | None) -> bool:
    """Whether a call site should use ``compiled_kernel`` rather than its numpy twin.

    False without the kernel or where ``DDA_KERNEL_MODULES`` leaves its module out
    (:data:`KERNEL_MODULES`); outside a run True; inside a run (:func:`run_work`)
    True when the run's steps reach :data:`MIN_STEPS` or its work :data:`MIN_WORK`.
    """
    if not _used(compiled_kernel):
        return False
    return _kernels_pay(_RUN_WORK.get())


def compiled_in_run(compiled_kernel: Kernel | None) -> bool:
    """:func:`compiled` inside a run, False outside one: for helpers that building a
    model or a scene also calls, which must not load numba for a run too small for it."""
    run = _RUN_WORK.get()
    return _used(compiled_kernel) and run is not None and _kernels_pay(run)


# environment: the modules whose kernels this process uses, comma-separated (unset: all;
# the others' numpy twins run): dda.commands.compile_helper sets it for its helper
KERNEL_MODULES = "DDA_KERNEL_MODULES"
_ONLY = frozenset(name for name in os.environ.get(KERNEL_MODULES, "").split(",") if name)


def _used(compiled_kernel: Kernel | None) -> bool:
    return compiled_kernel is not None and (
        not _ONLY or compiled_kernel.function.__module__ in _ONLY
    )


def _kernels_pay(run: tuple[float, float] | None) -> bool:
    return run is None or run[0] >= MIN_WORK or run[1] >= MIN_STEPS


@contextmanager
def run_work(blocks: int, steps: float) -> Iterator[bool]:
    """Within the block, kernels are used if ``steps`` reach :data:`MIN_STEPS` or
    ``blocks x steps`` reaches :data:`MIN_WORK`.

    Nested in another such block the larger figures count: a caller that stands for
    a long run (the benchmark, which times 100 steps of runs that last thousands)
    opens one around the run, and the run's own (smaller) figures do not turn the
    kernels off. Yields whether they are used.
    """
    outer = _RUN_WORK.get()
    run = (float(blocks) * float(steps), float(steps))
    if outer is not None:
        run = (max(outer[0], run[0]), max(outer[1], run[1]))
    token = _RUN_WORK.set(run)
    try:
        yield _kernels_pay(run)
    finally:
        _RUN_WORK.reset(token)
