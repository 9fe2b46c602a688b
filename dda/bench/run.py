"""Measure the engine on the wall scene: time per step, iterations, stages, memory.

Each size runs in its own Python process (``python -m dda.bench.run``) so
that its peak resident memory (``getrusage`` maxrss) is its own. Inside that
process small walls run first (:data:`WARM_UPS`: one on each form of a step's
systems, band, dense and sparse), so that one-off costs (imports, compiled kernels
loading, MKL) are not counted as time per step. A process that compiled kernels (an
empty numba cache) keeps LLVM's memory resident, so its peak is not the run's: the size
is measured again in a new process, which loads them from the cache
(:func:`measure_in_subprocess`).
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field

import dda
from dda.bench.limits import wall_blocks
from dda.bench.scenes import wall_scene
from dda.io.environment_variable import environment_variable
from dda.jit import numba_enabled, on_first_compile, run_work
from dda.solve.linsolve import new_pardiso_handle, pardiso_available
from dda.solve.policy import SYSTEMS_VARIABLE, current_policy

log = logging.getLogger(__name__)

# the per-size process's JSON key: True where it compiled kernels (not only loaded them)
COMPILED = "compiled"

# the warm-up walls (size, steps, DDA_SYSTEMS), each run as the measured run is (inside
# the run_work of a long run: the model's build uses the kernels too), one for each form
# of a step's systems (dda.solve.step): a 10 x 10 wall (101 blocks) on band systems
# (dda.solve.band_system, the compiled step loop), a 4 x 4 wall (17 blocks) on dense
# ones (dda.solve.dense_system), and the 10 x 10 wall again on the sparse block pattern
# (DDA_SYSTEMS=sparse), the systems of the walls from 30 x 30 up (the assembly's
# _scatter and _find_slots, the line step, the law's kernels): every kernel a measured
# run uses loads (from numba's cache) here, none inside the measured run
WARM_UPS = ((10, 100, ""), (4, 600, ""), (10, 100, "sparse"))
WARM_UP_WITHOUT_KERNELS = ((2, 3, ""),)  # DDA_NO_NUMBA: the imports alone
# the measured run is timed as a step of a run this long: it uses the compiled kernels
# as such a run does (dda.jit.run_work), whatever the steps timed
LONG_RUN_STEPS = 10_000
STAGES = ("contact_search", "assembly", "factorisation", "solve", "contact_law", "update", "output")


@dataclass
class Measurement:
    """One benchmark run of a ``columns`` x ``rows`` wall with one contact method."""

    columns: int
    rows: int
    method: str
    steps: int
    blocks: int
    seconds: float  # wall time of the run (model build and time loop)
    iterations: int  # linear solves (Newton iterations and chord steps, over all passes)
    factorisations: int
    newton_iterations: int = 0  # assembled systems solved (the rest are chord steps)
    stage_seconds: dict[str, float] = field(default_factory=dict)
    peak_memory_mib: float = float("nan")
    status: str = "finished"
    first_step_seconds: float = float("nan")  # model build and step 1 (pattern, analysis)
    start: str = "unloaded"  # the wall's start (dda.bench.scenes.STARTS)
    start_seconds: float = 0.0  # the equilibrium start's wall time (in first_step_seconds)
    start_newton_iterations: int = 0

    @property
    def ms_per_step(self) -> float:
        """ms a step of the whole run; nan for a run that did no step (it failed)."""
        return 1000.0 * self.seconds / self.steps if self.steps > 0 else float("nan")

    @property
    def ms_per_later_step(self) -> float:
        """ms per step after the first (the one-off model build, pattern and analysis)."""
        later = self.seconds - self.first_step_seconds
        return 1000.0 * later / (self.steps - 1) if self.steps > 1 else float("nan")

    @property
    def start_in_steps(self) -> float:
        """The equilibrium start's time in later steps of the same run."""
        step = self.ms_per_later_step / 1000.0
        return self.start_seconds / step if step > 0 else float("nan")

    @property
    def block_steps_per_second(self) -> float:
        done = self.steps > 0 and self.seconds > 0
        return self.blocks * self.steps / self.seconds if done else float("nan")

    @property
    def iterations_per_step(self) -> float:
        return self.iterations / self.steps if self.steps > 0 else float("nan")

    @property
    def newton_iterations_per_step(self) -> float:
        return self.newton_iterations / self.steps if self.steps > 0 else float("nan")

    def stage_ms_per_step(self, stage: str) -> float:
        """ms a step in ``stage``; nan for a run that did no step."""
        seconds = self.stage_seconds.get(stage, 0.0)
        return 1000.0 * seconds / self.steps if self.steps > 0 else float("nan")


def measure(
    columns: int,
    method: str = "penalty",
    steps: int = 100,
    rows: int | None = None,
    warm_up: bool = True,
    start: str = "equilibrium",
) -> Measurement:
    """Run the wall scene in this process and time it.

    Parameters
    ----------
    columns, rows : wall size (``rows`` defaults to ``columns``)
    method : "penalty" or "augmented-lagrangian"
    steps : time steps
    start : "equilibrium" (the engine's default, what users run) or "unloaded" (Shi's,
        as the C code's: the comparison with it)
    warm_up : run a small wall first (imports; walls with enough work for the compiled
        kernels to load, :data:`WARM_UPS`) and load the PARDISO library when it
        is used. The measured run uses the kernels at every size, as a run of
        :data:`LONG_RUN_STEPS` does: ms/step is the cost of a step of a long run
        (start-up is measured apart)
    """
    rows = columns if rows is None else rows
    return _measure(columns, rows, method, steps, warm_up, start)


def _measure(
    columns: int, rows: int, method: str, steps: int, warm_up: bool, start: str
) -> Measurement:
    if warm_up:
        warm_up_runs(method, start)
    scene = dda.load_scene(wall_scene(columns, rows, method=method, steps=steps, start=start))
    began = time.perf_counter()
    first_step = [float("nan")]

    def note_first_step(_fraction: float, info: dict) -> None:
        if info.get("step") == 1:  # (the equilibrium start reports without a step)
            first_step[0] = time.perf_counter() - began

    status = "finished"
    try:
        with run_work(columns * rows + 1, LONG_RUN_STEPS):  # the kernels of a long run
            result = dda.simulate(scene, progress=note_first_step)
        summary = result.summary
    except dda.SimulationError as exc:
        status = f"failed: {exc}"
        partial = getattr(exc, "result", None)
        summary = partial.summary if partial is not None else {}
    seconds = time.perf_counter() - began
    done = int(summary.get("steps", 0))  # none when it failed without a summary
    return Measurement(
        columns=columns,
        rows=rows,
        method=method,
        steps=done,
        blocks=columns * rows + 1,
        seconds=seconds,
        iterations=int(summary.get("iterations", 0)),
        factorisations=int(summary.get("factorisations", 0)),
        newton_iterations=int(summary.get("newton_iterations", 0)),
        stage_seconds=dict(summary.get("stage_seconds", {})),
        peak_memory_mib=peak_memory_mib(),
        status=status,
        first_step_seconds=first_step[0],
        start=start,
        start_seconds=float(summary.get("start_seconds", 0.0)),
        start_newton_iterations=int(summary.get("start_newton_iterations", 0)),
    )


def warm_up_runs(method: str, start: str) -> None:
    """Run the :data:`WARM_UPS` walls with ``method`` and ``start``, each as a measured run
    is (inside the ``run_work`` of a run of :data:`LONG_RUN_STEPS`) and on its systems,
    and load the PARDISO library when it is used: the one-off costs of the measured run
    (imports, kernels loading from numba's cache, MKL) are paid here."""
    walls = WARM_UPS if numba_enabled() else WARM_UP_WITHOUT_KERNELS
    for size, steps, systems in walls:
        scene = dda.load_scene(wall_scene(size, method=method, steps=steps, start=start))
        with systems_variable(systems), run_work(wall_blocks(size), LONG_RUN_STEPS):
            dda.simulate(scene)
    if pardiso_available():  # finding the MKL library is a one-off cost too
        new_pardiso_handle(current_policy().solver_threads())


@contextmanager
def systems_variable(systems: str) -> Iterator[None]:
    """Within the block, ``DDA_SYSTEMS`` is ``systems`` when given (a run reads it as it
    starts, :meth:`dda.solve.policy.StepPolicy.from_environment`); else left as it is."""
    if not systems:
        yield
        return
    with environment_variable(SYSTEMS_VARIABLE, systems):
        yield


def peak_memory_mib() -> float:
    """Peak resident memory of this process so far, MiB (Linux: maxrss is in KiB)."""
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kib / (1024.0 if sys.platform != "darwin" else 1024.0 * 1024.0)


def measure_in_subprocess(
    columns: int,
    method: str = "penalty",
    steps: int = 100,
    rows: int | None = None,
    start: str = "equilibrium",
) -> Measurement:
    """:func:`measure` in a fresh Python process (its own peak memory), once more in
    another where that one compiled kernels (its peak holds the compiler's memory). Its
    warnings reach this process's stderr as it runs (the first run's "compiling the
    kernels ...", which would otherwise leave a minute or more without a word)."""
    rows = columns if rows is None else rows
    cmd = [sys.executable, "-m", "dda.bench.run", str(columns), str(rows), method, str(steps)]
    cmd.append(start)
    data = _measured(cmd)
    if data.pop(COMPILED):
        log.info("kernels compiled in the %dx%d wall's process: measured again", columns, rows)
        data = _measured(cmd)
        data.pop(COMPILED)
    return Measurement(**data)


def _measured(cmd: list[str]) -> dict:
    """The JSON line of the per-size process ``cmd``."""
    done = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"benchmark process failed ({done.returncode}); its error is above")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _main(argv: list[str] | None = None) -> int:
    """Entry of the per-size process: print one Measurement as JSON."""
    parser = argparse.ArgumentParser(prog="python -m dda.bench.run")
    parser.add_argument("columns", type=int)
    parser.add_argument("rows", type=int)
    parser.add_argument("method")
    parser.add_argument("steps", type=int)
    parser.add_argument("start", nargs="?", default="equilibrium")
    args = parser.parse_args(argv)
    compiled: list[str] = []
    on_first_compile(compiled.append)
    m = measure(args.columns, args.method, args.steps, args.rows, start=args.start)
    sys.stdout.write(json.dumps({**asdict(m), COMPILED: bool(compiled)}) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
