"""Benchmark measurements as a Markdown table (for the terminal and docs/benchmarks.md)."""

from __future__ import annotations

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
        per_step = {s: 1000.0 * m.stage_seconds.get(s, 0.0) / max(m.steps, 1) for s in STAGES}
        started = m.start == "equilibrium"
        lines.append(
            f"| {m.columns}x{m.rows} | {m.blocks} | {m.method} | {m.start} | "
            + (
                f"{m.start_seconds:.3f} | {m.start_newton_iterations} | {m.start_in_steps:.1f} | "
                if started
                else "– | – | – | "
            )  # fmt: skip
            + f"{m.ms_per_step:.2f} | "
            f"{m.ms_per_later_step:.2f} | "
            f"{m.block_steps_per_second:,.0f} | {m.iterations_per_step:.2f} | "
            f"{m.newton_iterations_per_step:.2f} | {m.factorisations} |"
            + "".join(f" {per_step[s]:.2f} |" for s in STAGES)
            + f" {m.peak_memory_mib:.0f} | {m.status[:40]} |"
        )
    return "\n".join(lines)


def growth_exponent(small: Measurement, large: Measurement) -> float:
    """Exponent a of cost ∝ N^a between two sizes (N = blocks)."""
    import math

    return math.log(large.ms_per_step / small.ms_per_step) / math.log(large.blocks / small.blocks)
