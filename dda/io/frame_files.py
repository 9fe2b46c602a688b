"""Finding a written frame again: from an output directory or a VTU file name."""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

from dda.io.pvd import read_pvd

BLOCKS_NAME = re.compile(r"blocks_(\d+)\.vtu$")


@dataclass(frozen=True)
class FrameFiles:
    """The files of one written frame and what the index says about it."""

    blocks: Path
    contacts: Path | None
    time: float
    step: int

    @property
    def run_folder(self) -> Path:
        """The output directory of the run (the parent of ``frames/``)."""
        folder = self.blocks.parent
        return folder.parent if folder.name == "frames" else folder

    def default_png(self, scalars: str) -> Path:
        """``<blocks stem>_<scalars>.png``, in the output directory of the run."""
        return self.run_folder / f"{self.blocks.stem}_{scalars}.png"

    def summary(self) -> dict:
        """The run's ``summary.json`` (its title, units, ...), or {} if absent or unreadable."""
        try:
            summary = json.loads((self.run_folder / "summary.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return {}
        return summary if isinstance(summary, dict) else {}


def find_frame(source: str | os.PathLike[str], step: int | None = None) -> FrameFiles:
    """The files of a frame written by :class:`dda.io.RunWriter`.

    Parameters
    ----------
    source
        An output directory (uses its ``blocks.pvd``, else ``frames/blocks_*.vtu``)
        or a blocks ``.vtu`` file.
    step
        With a directory: the step wanted; default the last frame.

    Returns
    -------
    FrameFiles
        Blocks file, contacts file (``None`` if absent), time (NaN if no index
        lists the file) and step (-1 if the name does not tell).

    Raises
    ------
    FileNotFoundError
        Nothing to read at ``source``, or no frame with that step.
    """
    source = Path(source)
    if source.is_file():
        return _describe(source, _times(source.parent.parent / "blocks.pvd"))
    if not source.is_dir():
        raise FileNotFoundError(f"{source}: no such file or directory")
    times = _times(source / "blocks.pvd")
    candidates = list(times) or sorted((source / "frames").glob("blocks_*.vtu"), key=_step_of)
    if step is not None:
        candidates = [path for path in candidates if _step_of(path) == step]
    if not candidates:
        wanted = f"step {step}" if step is not None else "any frame"
        raise FileNotFoundError(f"{source}: no written frame ({wanted})")
    return _describe(candidates[-1], times)


def _times(pvd: Path) -> dict[Path, float]:
    if not pvd.is_file():
        return {}
    return {file.resolve(): time for time, file in read_pvd(pvd) if file.is_file()}


def _describe(blocks: Path, times: dict[Path, float]) -> FrameFiles:
    contacts = blocks.with_name(blocks.name.replace("blocks_", "contacts_", 1))
    return FrameFiles(
        blocks=blocks,
        contacts=contacts if contacts.is_file() and contacts != blocks else None,
        time=times.get(blocks.resolve(), math.nan),
        step=_step_of(blocks),
    )


def _step_of(path: Path) -> int:
    match = BLOCKS_NAME.search(path.name)
    return int(match.group(1)) if match else -1
