"""Benchmark measurements as a Markdown table (for the terminal and docs/benchmarks.md)."""

from __future__ import annotations

import math
import os
import platform
import subprocess
from collections.abc import Iterable

from dda.bench.run import STAGES, Measurement
from dda.solve.policy import THREADS_VARIABLE, current_policy

SHORT = {
    "contact_search": "search",
    "assembly": "assembly",
    "factorisation": "factor",
    "solve": "solve",
    "contact_law": "law",
    "update": "update",
    "output": "output",
}
# the table's columns before and after the stages' (each stage's: "<SHORT> ms/step")
LEADING = (
    "wall",
    "blocks",
    "method",
    "start",
    "start s",
    "start Newton",
    "start in steps",
    "ms/step",
    "after step 1",
    "block-steps/s",
    "iter/step",
    "Newton/step",
    "factorisations",
)
TRAILING = ("peak MiB", "status")


def machine_line() -> str:
    """CPU model, core count (``lscpu``), Python and the solver threads, for the caption."""
    model, cores = platform.processor() or "unknown CPU", None
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    except OSError:
        out = ""
    for line in out.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "Model name":
            model = value.strip()
        elif key.strip() == "CPU(s)":
            cores = value.strip()
    reproducible = os.environ.get("MKL_CBWR")
    return (
        f"{model}, {cores or '?'} cores, Python {platform.python_version()}, {_threads_said()}"
        + (f", MKL_CBWR={reproducible}" if reproducible else "")
    )


def _threads_said() -> str:
    """``DDA_THREADS``'s count, or the policy's words: each size's process decides its
    threads as it runs (:mod:`dda.solve.thread_policy`), not this one."""
    if not os.environ.get(THREADS_VARIABLE, "").strip():
        return f"solver threads by the thread policy ({THREADS_VARIABLE} unset)"
    threads = current_policy().solver_threads()
    return f"{threads} solver thread{'s' if threads > 1 else ''} ({THREADS_VARIABLE})"


def table(measurements: Iterable[Measurement]) -> str:
    """Markdown table: one row per (size, method, start); the equilibrium start's wall
    time, Newton iterations and time in steps after step 1 ("start in steps"); ms/step
    is the whole run's (the start included) per step, "after step 1" a later step's;
    "factorisations" the run's total; each stage's ms per step ("search ms/step", ...).
    Every column: docs/benchmarks.md."""
    names = (*LEADING, *(f"{SHORT[s]} ms/step" for s in STAGES), *TRAILING)
    head = "| " + " | ".join(names) + " |"
    lines = [head, "|" + "---|" * len(names)]
    for m in measurements:
        start = ["–", "–", "–"]  # Shi's unloaded start: no start to report
        if m.start == "equilibrium":
            in_steps = _figure(m.start_in_steps, ".1f")
            start = [f"{m.start_seconds:.3f}", str(m.start_newton_iterations), in_steps]
        cells = [
            f"{m.columns}x{m.rows}", str(m.blocks), m.method, m.start, *start,
            _figure(m.ms_per_step), _figure(m.ms_per_later_step),
            _figure(m.block_steps_per_second, ",.0f"), _figure(m.iterations_per_step),
            _figure(m.newton_iterations_per_step), str(m.factorisations),
            *(_stage(m, s) for s in STAGES),
            _figure(m.peak_memory_mib, ".0f"), m.status[:40],
        ]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _stage(m: Measurement, stage: str) -> str:
    """A stage's ms per step; "(in solve)" for the factorisations of a run that made some
    but timed none apart (band systems: the compiled loop factorises inside "solve")."""
    seconds = m.stage_seconds.get(stage, 0.0)
    if stage == "factorisation" and m.factorisations > 0 and seconds == 0.0:
        return "(in solve)"
    return _figure(m.stage_ms_per_step(stage))


def _figure(value: float, spec: str = ".2f") -> str:
    """``value`` formatted by ``spec``, or "–" when it is not a number (nan: a run that
    did no step has no time a step)."""
    return "–" if math.isnan(value) else format(value, spec)


def growth_exponent(small: Measurement, large: Measurement) -> float:
    """Exponent a of cost ∝ N^a between two sizes (N = blocks)."""
    return math.log(large.ms_per_step / small.ms_per_step) / math.log(large.blocks / small.blocks)
