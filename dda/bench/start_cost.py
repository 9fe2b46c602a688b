"""The equilibrium start's cost against the run's own steps, on the shipped rock cases.

``python -m dda.bench.start_cost [NAME ...]`` (default :data:`CASES`) prints one
Markdown row per case: its blocks, the start's seconds and Newton iterations
(``summary["start_seconds"]``, ``summary["start_newton_iterations"]``), the seconds of
one of its steps, and the start over 20 steps (docs/contact.md, "What the equilibrium
start costs"). Each case runs in this process with the kernels of a long run
(:func:`dda.jit.run_work`), after one run that loads them:

* the start: the smallest of ``starts`` one-step runs;
* a step: (the smallest of ``runs`` ``long``-step runs less the smallest of ``runs``
  ``short``-step runs, each without its start) / (``long`` − ``short``), so that what a
  run costs once (its start, its first step's set-up) cancels. A case whose duration
  holds fewer steps is lengthened (``analysis.duration``); each run stops after its
  steps (:func:`dda.simulate`'s ``stop``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from contextlib import nullcontext
from pathlib import Path
from typing import NamedTuple

import dda
import dda.cases
from dda.jit import run_work

CASES = ("tunnel", "tunnel_staged", "tunnel_deep", "rock_slope", "jointed_slope_fos")


class StartCost(NamedTuple):
    case: str
    blocks: int
    start_seconds: float
    start_newton: int
    step_seconds: float

    @property
    def in_steps(self) -> float:
        """The start over 20 of the run's steps."""
        return self.start_seconds / (20.0 * self.step_seconds)

    def row(self) -> str:
        return (
            f"| `cases/{self.case}.toml` | {self.blocks:,} | {self.start_seconds:.4f} | "
            f"{self.start_newton} | {1e3 * self.step_seconds:.3f} | {self.in_steps:.3f} |"
        )


HEADER = (
    "| model | blocks | start (s) | Newton iterations | ms a step | start / 20 steps |\n"
    "|---|---|---|---|---|---|"
)


def start_cost(
    case: str,
    starts: int = 5,
    runs: int = 3,
    long: int = 120,
    short: int = 40,
    kernels: bool = True,
) -> StartCost:
    """The start's and a step's cost of the shipped case ``case`` (module docstring);
    ``kernels`` False: the numpy path (a quick check of the measurement itself)."""
    scene = dda.load_scene(Path(str(dda.cases.folder().joinpath(f"{case}.toml"))))
    analysis = scene.analysis
    if analysis.duration is not None and analysis.duration < (long + 1) * analysis.time_step:
        longer = dataclasses.replace(analysis, duration=(long + 1) * analysis.time_step)
        scene = dataclasses.replace(scene, analysis=longer)

    def run(steps: int) -> tuple[float, dict]:
        asked = [0]

        def stop() -> bool:
            asked[0] += 1
            return asked[0] > steps

        began = time.perf_counter()
        with run_work(1000, 10_000) if kernels else nullcontext():
            summary = dda.simulate(scene, stop=stop, keep_frames=False).summary
        return time.perf_counter() - began - summary["start_seconds"], summary

    run(1)  # loads the kernels and the solver
    first = [run(1)[1] for _ in range(starts)]
    start = min(summary["start_seconds"] for summary in first)
    long_run = min(run(long)[0] for _ in range(runs))
    short_run = min(run(short)[0] for _ in range(runs))
    return StartCost(
        case,
        len(scene.blocks),
        start,
        int(first[0]["start_newton_iterations"]),
        (long_run - short_run) / (long - short),
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dda.bench.start_cost")
    parser.add_argument("cases", nargs="*", default=list(CASES), help="shipped case names")
    args = parser.parse_args(argv)
    sys.stdout.write(HEADER + "\n")
    for case in args.cases:
        sys.stdout.write(start_cost(case).row() + "\n")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
