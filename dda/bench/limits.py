"""The walls a benchmark can run, checked before its warm-ups: scene and memory.

Each size's wall goes through the checks its run makes (:func:`dda.load_scene`
and :func:`dda.scene.limits.check_run_size`: the block count, the steps), and its
peak memory is estimated from its block count and compared with a bound: by
default the memory this machine has available now, else ``dda bench
--max-memory``. A wall that would not fit is refused at once, with one line that
names the size, the estimate and the bound, rather than after the warm-ups of
every smaller size, in a MemoryError.
"""

from __future__ import annotations

import os
from pathlib import Path

import dda
from dda.bench.scenes import wall_scene
from dda.scene.limits import DEFAULT_MAX_STEPS, check_run_size

# peak resident memory of a size's process: a fixed part and a part per block, fitted to
# the peaks of docs/benchmarks.md (481 MiB at 10,001 blocks, 1,261 MiB at 40,001; this
# gives 484 and 1,275)
MEMORY_BASE_MIB = 220.0
MEMORY_PER_BLOCK_KIB = 27.0
MEMINFO = Path("/proc/meminfo")


class BenchError(ValueError):
    """A benchmark that cannot run: ``str(exc)`` names the option, the value and why."""


def wall_blocks(size: int) -> int:
    """Blocks of the ``size`` x ``size`` wall, its base included."""
    return size * size + 1


def estimated_peak_bytes(blocks: int) -> float:
    """Peak resident memory of a size's process running a wall of ``blocks`` blocks."""
    return (MEMORY_BASE_MIB * 1024.0 + MEMORY_PER_BLOCK_KIB * blocks) * 1024.0


def available_memory_bytes() -> int | None:
    """The memory the machine can give now (Linux: ``MemAvailable``), else its physical
    memory, else None (not known)."""
    try:
        for line in MEMINFO.read_text().splitlines():
            name, _, value = line.partition(":")
            if name == "MemAvailable":
                return int(value.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def check_walls(
    sizes: list[int],
    method: str,
    steps: int,
    start: str,
    max_memory_bytes: float | None,
    bound_said: str,
) -> None:
    """Refuse the first size whose wall would not fit in ``max_memory_bytes`` (None: no
    bound) or whose scene its run would refuse. ``bound_said`` names the bound
    (``"--max-memory 8 GB"``, or where its default came from).

    Raises
    ------
    BenchError
        One line naming ``--sizes`` or ``--steps``, the value and the reason.
    """
    for size in sizes:  # every size's memory first: nothing is built for a wall too big
        _check_memory(size, max_memory_bytes, bound_said)
    for size in sizes:
        _check_scene(size, method, steps, start)


def _check_memory(size: int, max_memory_bytes: float | None, bound_said: str) -> None:
    """Refuse a wall whose estimated peak memory exceeds ``max_memory_bytes``."""
    blocks = wall_blocks(size)
    need = estimated_peak_bytes(blocks)
    if max_memory_bytes is None or need <= max_memory_bytes:
        return
    raise BenchError(
        f"--sizes {size}: a {size} x {size} wall ({blocks:,} blocks) needs about "
        f"{need / 1e9:.3g} GB of memory ({MEMORY_BASE_MIB:g} MiB and "
        f"{MEMORY_PER_BLOCK_KIB:g} KiB a block, the peaks measured in docs/benchmarks.md), "
        f"more than {bound_said}; give smaller sizes or a larger --max-memory"
    )


def _check_scene(size: int, method: str, steps: int, start: str) -> None:
    """Refuse a wall whose scene its run would refuse (the steps, the block count)."""
    try:
        check_run_size(dda.load_scene(wall_scene(size, method=method, steps=steps, start=start)))
    except dda.SceneError as exc:
        if exc.key == "analysis.steps":
            raise BenchError(
                f"--steps {steps}: more than the {DEFAULT_MAX_STEPS:,} steps a run may take "
                "(analysis.max_steps)"
            ) from None
        said = f"--sizes {size}: the {size} x {size} wall: {exc.key}: {exc.reason}"
        raise BenchError(said) from None
