"""Finding a written frame again: from an output directory or a VTU file name."""

from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path

from dda.io.pvd import read_pvd, step_of_file

log = logging.getLogger(__name__)

# the labels of a frame whose run's units are not known (no summary.json beside it: the
# VTU files hold numbers only): each quantity labelled by its dimension, "stress yy
# (force/length²)", rather than as SI it may not be in
UNKNOWN_UNITS = {"length": "length", "force": "force", "time": "time"}


@dataclass(frozen=True)
class FrameFiles:
    """The files of one written frame and what the index says about it."""

    blocks: Path
    contacts: Path | None
    time: float
    step: int
    bolts: Path | None = None  # the rock bolts beside the frame (a scene with [[bolts]])

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

    def units(self, summary: dict) -> dict[str, str]:
        """The run's ``[units]`` from its ``summary`` (:func:`run_units`)."""
        return run_units(summary, self.run_folder, self.blocks.name)


def run_units(summary: dict, run_folder: Path, subject: str) -> dict[str, str]:
    """The run's ``[units]`` from its ``summary`` (of ``run_folder``); where it has none
    (a file read without its run folder), :data:`UNKNOWN_UNITS`, with a warning naming
    ``subject``, the file drawn: its pictures label each quantity by its dimension, never
    by an SI unit the run may not have used."""
    units = summary.get("units")
    if isinstance(units, dict):
        return units
    there = (run_folder / "summary.json").exists()
    why = "holds no units" if summary else "cannot be read" if there else "is not there"
    log.warning(
        "%s: the summary.json of %s %s, so the units are unknown: the picture labels "
        "each quantity by its dimension (force/length², not Pa)",
        subject,
        run_folder,
        why,
    )
    return UNKNOWN_UNITS


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
    ValueError
        ``source`` is a file but not a blocks ``.vtu`` file.
    """
    source = Path(source)
    if source.is_file():
        if source.suffix != ".vtu" or source.name.startswith("contacts_"):
            raise ValueError(
                f"{source}: not a blocks frame file (expected an output directory or "
                "frames/blocks_NNNNNN.vtu; contacts files are drawn with their blocks)"
            )
        return _describe(source, _times(source.parent.parent / "blocks.pvd"))
    if not source.is_dir():
        raise FileNotFoundError(f"{source}: no such file or directory")
    source = _run_folder(source)
    times = _times(source / "blocks.pvd")
    candidates = list(times) or sorted((source / "frames").glob("blocks_*.vtu"), key=step_of_file)
    written = candidates
    if step is not None:
        candidates = [path for path in candidates if step_of_file(path) == step]
    if not candidates:
        wanted = f"step {step}" if step is not None else "any frame"
        raise FileNotFoundError(f"{source}: no written frame ({wanted}){_steps_note(written)}")
    return _describe(candidates[-1], times)


def _run_folder(folder: Path) -> Path:
    """The run's output folder of ``folder``: its parent where ``folder`` is the run's
    ``frames`` folder (given for the run's, it held no frame of its own)."""
    in_frames = folder.name == "frames" and not (folder / "blocks.pvd").exists()
    return folder.parent if in_frames and any(folder.glob("blocks_*.vtu")) else folder


def _steps_note(written: list[Path]) -> str:
    """ "; written steps: 0, 10, ..., 300" for an error that names a missing step."""
    steps = sorted({step_of_file(path) for path in written})
    if not steps:
        return ""
    shown = steps if len(steps) <= 8 else [*steps[:4], "...", *steps[-3:]]
    return "; written steps: " + ", ".join(str(step) for step in shown)


def all_frames(folder: str | os.PathLike[str]) -> list[FrameFiles]:
    """Every frame an output directory holds, in step order (its ``blocks.pvd``, else
    ``frames/blocks_*.vtu``).

    Raises
    ------
    FileNotFoundError
        ``folder`` is not a directory, or holds no frame.
    """
    folder = Path(folder)
    if not folder.exists():
        raise FileNotFoundError(f"{folder}: no such directory")
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: not an output directory of `dda run`")
    folder = _run_folder(folder)
    times = _times(folder / "blocks.pvd")
    files = list(times) or sorted((folder / "frames").glob("blocks_*.vtu"), key=step_of_file)
    if not files:
        raise FileNotFoundError(f"{folder}: no written frame (no blocks.pvd or frames/)")
    return sorted((_describe(path, times) for path in files), key=lambda f: f.step)


def read_found_frame(found: FrameFiles):
    """The :class:`~dda.result.Frame` in ``found``'s files.

    Raises
    ------
    ValueError
        A file that is not a frame written by :mod:`dda.io.vtu` (or is damaged).
    """
    import meshio

    from dda.io.vtu import read_frame

    try:
        return read_frame(
            found.blocks, found.contacts, time=found.time, step=found.step,
            bolts_path=found.bolts,
        )  # fmt: skip
    except (meshio.ReadError, OSError, KeyError, IndexError, ValueError, SyntaxError) as exc:
        detail = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise ValueError(f"{found.blocks}: cannot read it as a frame ({detail})") from None


def _times(pvd: Path) -> dict[Path, float]:
    if not pvd.is_file():
        return {}
    try:
        entries = read_pvd(pvd)
    except SyntaxError:  # xml.etree's ParseError: a damaged index lists nothing
        return {}
    missing = [file for _, file in entries if not file.is_file()]
    if missing:  # said, not skipped silently (an audit: a movie one frame short, unsaid)
        log.warning("%s: %d frame(s) it lists are missing, left out: %s%s", pvd, len(missing),
                    missing[0].name, ", ..." if len(missing) > 1 else "")  # fmt: skip
    return {file.resolve(): time for time, file in entries if file.is_file()}


def _describe(blocks: Path, times: dict[Path, float]) -> FrameFiles:
    contacts, bolts = (_beside(blocks, kind) for kind in ("contacts_", "bolts_"))
    return FrameFiles(
        blocks=blocks,
        contacts=contacts,
        time=times.get(blocks.resolve(), math.nan),
        step=step_of_file(blocks),
        bolts=bolts,
    )


def frame_file(blocks: Path, kind: str) -> Path:
    """The ``kind`` file (``contacts_``, ``bolts_``) of the blocks file's frame, as the
    run writes it beside ``blocks``."""
    return blocks.with_name(blocks.name.replace("blocks_", kind, 1))


def _beside(blocks: Path, kind: str) -> Path | None:
    """The ``kind`` file of the blocks file's frame (``contacts_``, ``bolts_``), if any."""
    path = frame_file(blocks, kind)
    return path if path.is_file() and path != blocks else None
