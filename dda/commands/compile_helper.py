"""``dda run``'s compile helper: a process that compiles the step's kernels while the run
compiles the rest.

A model's first run on a machine (and its first after an upgrade) compiles the kernels
it uses one after another, on one core: 73-94 s of the rock slope's first run on
the 2-core benchmark machine, the band step's kernel and its callees about half of it
(docs/benchmarks.md, start-up). A run compiles its contact search's and equilibrium
start's kernels first, and the step's kernels (those of ``STEP_MODULES``) only when
the start's last solve or the first step needs them. So when a second core is free
(the solver's thread policy would give two threads) ``dda run`` offers its scene file
(:func:`offer`), and when the run's first kernel compile begins (a warm cache never
begins one) a helper starts on that core, ``python -P -m dda.commands.compile_helper
SCENE SIGNAL`` (:func:`serve`). It runs the scene's first step, unloaded, writing
nothing, with the kernels of ``STEP_MODULES`` only (``DDA_KERNEL_MODULES``,
:data:`dda.jit.KERNEL_MODULES`: every other kernel's numpy twin runs there), and
touches the file SIGNAL when it begins to compile: it compiles the step's kernels into
numba's on-disk cache while the run compiles its own. Before the run first uses a
kernel of those modules it waits for the helper to end, then loads the kernel from the
cache: the same machine code, compiled for the same argument types, as it would have
compiled itself (the numbers are those of a run without the helper, to the bit).

Where the helper cannot help, the run compiles as before: no free core, the kernels
off (``DDA_NO_NUMBA=1``), ``DDA_COMPILE_HELPER=0``, or the run's first compile being
a step kernel's. A helper that fails (its scene cannot run its first step) ends at
once; one still starting the scene when the run needs its kernels (a model too large
to reach its first step soon on numpy) is stopped, and the run compiles. The helper
never outlives the run (:func:`withdraw`).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

import dda
from dda import jit

log = logging.getLogger(__name__)

# the modules whose kernels the helper compiles: the step's band loop and Newton, the
# sparse systems' scatter and line step, the update and material damping. The rest
# (the contact search, the equilibrium start's interior point, the contact law's own
# kernels, the blocks' moments and masses) the run compiles before it needs these
STEP_MODULES = (
    "dda.solve.band_step",
    "dda.solve.band_newton",
    "dda.solve.line_step",
    "dda.solve.assembly",
    "dda.solve.update",
    "dda.effects.damping",
)
# environment: "0" turns the helper off; the helper's own process has it at "0"
SWITCH = "DDA_COMPILE_HELPER"
# the longest wait for a helper that is compiling, in seconds (then the run compiles)
WAIT_SECONDS = 600.0
_offered: Path | None = None  # the scene file of the run that may start a helper
_helper: _Helper | None = None


class _Helper:
    """A started helper process and the file it touches when it begins to compile."""

    def __init__(self, process: subprocess.Popen, signal: Path) -> None:
        self.process, self.signal = process, signal

    def compiling(self) -> bool:
        return self.signal.exists()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.signal.unlink(missing_ok=True)


def offer(scene_file: str | os.PathLike[str], second_core: bool) -> None:
    """Let the run of ``scene_file`` start a helper at its first kernel compile, when
    ``second_core`` (the solver's thread policy would give two threads) and the helper
    is not switched off."""
    global _offered
    if not (second_core and os.environ.get(SWITCH, "1") != "0" and sys.executable):
        return
    try:  # a shipped case inside an archive has no path: no helper
        _offered = Path(scene_file).resolve(strict=True)
    except (TypeError, OSError):
        return
    jit.on_first_compile(compile_begins)
    jit.before_first_use(wait_for)


def withdraw() -> None:
    """The run is over: no helper starts, and a running one is stopped."""
    global _offered, _helper
    _offered = None
    if _helper is not None:
        _helper.stop()
        _helper = None


def compile_begins(module: str) -> None:
    """A kernel of ``module`` begins to compile in this process: the first time, start the
    offered helper (unless the kernel is one of the step's: the helper would compile it
    again)."""
    global _offered, _helper
    scene, _offered = _offered, None
    if scene is None or module in STEP_MODULES:
        return
    _helper = _start(scene)


def wait_for(module: str) -> None:
    """Before this process first uses a kernel of ``module``: if it is a step kernel and a
    helper is compiling, wait for it to end (its kernels are then in the cache); a helper
    that has not begun to compile is stopped."""
    global _helper
    if _helper is None or module not in STEP_MODULES:
        return
    helper, _helper = _helper, None
    if helper.process.poll() is None and helper.compiling():
        began = time.perf_counter()
        try:
            helper.process.wait(timeout=WAIT_SECONDS)
        except subprocess.TimeoutExpired:
            pass
        waited = time.perf_counter() - began
        jit.waited_for_kernels(waited)
        log.info("waited %.1f s for the compile helper", waited)
    elif helper.process.poll() is None:
        log.info("the compile helper had not begun compiling: the run compiles")
    helper.stop()


def _start(scene: Path) -> _Helper | None:
    """The helper's process, on its own (None if it cannot start)."""
    import tempfile

    signal = Path(tempfile.gettempdir()) / f"dda-compile-helper-{os.getpid()}"
    signal.unlink(missing_ok=True)
    environment = {**os.environ, SWITCH: "0", jit.KERNEL_MODULES: ",".join(STEP_MODULES)}
    command = [sys.executable, "-P", "-m", __name__, str(scene), str(signal)]
    try:
        process = subprocess.Popen(
            command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, env=environment, start_new_session=True,
        )  # fmt: skip
    except OSError as exc:
        log.debug("no compile helper: %s", exc)
        return None
    log.debug("compile helper %d started for %s", process.pid, scene)
    return _Helper(process, signal)


def serve(scene_file: str, signal: str) -> int:
    """The helper's side: run the first step of ``scene_file``, unloaded, writing nothing,
    with the kernels its environment allows; touch ``signal`` when a kernel begins to
    compile. Exits 0, or 1 when the scene cannot run (the run compiles what this did not)."""
    jit.on_first_compile(lambda module: Path(signal).touch())
    scene = dda.load_scene(scene_file)
    analysis = dataclasses.replace(scene.analysis, duration=None, steps=1)
    if analysis.mode == "dynamic":
        analysis = dataclasses.replace(analysis, start="unloaded")
    with jit.run_work(jit.MIN_WORK, jit.MIN_STEPS):
        dda.simulate(dataclasses.replace(scene, analysis=analysis))
    return 0


if __name__ == "__main__":
    try:
        code = serve(sys.argv[1], sys.argv[2])
    except Exception:  # the run compiles what this did not
        code = 1
    os._exit(code)
