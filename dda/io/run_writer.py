"""Everything a run leaves on disk, written as the run goes.

Layout of ``outdir``::

    blocks.pvd              time index of the block files (ParaView: open this)
    contacts.pvd            time index of the contact files
    frames/blocks_NNNNNN.vtu    one per kept frame (NNNNNN = step)
    frames/contacts_NNNNNN.vtu
    history.csv             one row per block per kept frame
    summary.json            the run summary (status "finished", "failed", ...)
    final.png               the last frame, coloured by a stress component

Frame files and the PVD indexes are written as each frame arrives, every file
atomically, so a run that stops early leaves a readable partial result.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from itertools import chain
from pathlib import Path
from typing import Any

from dda.io.atomic import TEMP_MARK, write_text
from dda.io.images import render_frame
from dda.io.pvd import PvdIndex
from dda.io.tables import history_header, history_rows, write_summary
from dda.io.vtu import write_blocks_vtu, write_contacts_vtu
from dda.result import Frame, Result

logger = logging.getLogger(__name__)

OUTPUTS = ("blocks.pvd", "contacts.pvd", "history.csv", "summary.json", "final.png")
FRAME_PATTERNS = ("blocks_*.vtu", "contacts_*.vtu", f"*{TEMP_MARK}*")


class RunWriter:
    """Writes the frames of a run as they come, then the tables and the picture.

    Outputs of an earlier run in ``outdir`` (the files listed in the module
    docstring) are removed first, so the directory never mixes two runs.

    Parameters
    ----------
    outdir
        Output directory, created with ``outdir/frames`` if needed.
    scalars
        Colouring of ``final.png`` (see :func:`dda.io.images.render_frame`).
    image
        Whether :meth:`finish` renders ``final.png``.
    """

    def __init__(
        self, outdir: str | os.PathLike[str], scalars: str = "syy", image: bool = True
    ) -> None:
        self.outdir = Path(outdir)
        self.frames_dir = self.outdir / "frames"
        self.scalars = scalars
        self.image = image
        self.frames_dir.mkdir(parents=True, exist_ok=True)
        _remove_old_outputs(self.outdir)
        self.blocks_index = PvdIndex(self.outdir / "blocks.pvd")
        self.contacts_index = PvdIndex(self.outdir / "contacts.pvd")
        self._history: dict[int, str] = {}  # step -> CSV rows of that frame
        self.last_frame: Frame | None = None

    @property
    def frame_count(self) -> int:
        """Number of distinct frames written."""
        return len(self._history)

    def add_frame(self, frame: Frame) -> None:
        """Write one frame's VTU files and update both PVD indexes.

        A frame with the step of an earlier one replaces it.

        Parameters
        ----------
        frame
            The frame (usually passed by the engine's ``on_frame`` callback).
        """
        stem = f"{int(frame.step):06d}"
        blocks = write_blocks_vtu(frame, self.frames_dir / f"blocks_{stem}.vtu")
        contacts = write_contacts_vtu(frame, self.frames_dir / f"contacts_{stem}.vtu")
        self.blocks_index.add(frame.time, blocks)
        self.contacts_index.add(frame.time, contacts)
        self._history[int(frame.step)] = history_rows(frame)
        self.last_frame = frame
        logger.debug("frame step %d t=%g written", frame.step, frame.time)

    def finish(
        self,
        result: Result | None = None,
        scene: Any = None,
        status: str | None = None,
        error: str | None = None,
    ) -> dict[str, Any]:
        """Write ``history.csv``, ``summary.json`` and ``final.png``.

        Frames of ``result`` that were not passed to :meth:`add_frame` are
        written first. Without a result (the run failed) the summary holds
        what is known: the status, the error and the last frame written.

        Parameters
        ----------
        result
            The run's result, or ``None`` if the run did not return one.
        scene
            The scene (its ``title``, ``source`` and ``units`` go into the summary).
        status
            Run status; default ``result.summary["status"]``, else
            ``"finished"`` with a result and ``"failed"`` without.
        error
            Error message, for a failed run.

        Returns
        -------
        dict
            The summary as written.
        """
        if result is not None:
            for frame in result.frames:
                if int(frame.step) not in self._history:
                    self.add_frame(frame)
        final = result.final if result is not None and result.frames else self.last_frame
        summary = self._summary(result, scene, status, error, final)
        self._write_history()
        if self.image and final is not None:
            summary["image"] = self._render_final(final, summary)
        write_summary(self.outdir / "summary.json", summary)
        return summary

    def _summary(self, result, scene, status, error, final) -> dict[str, Any]:
        summary: dict[str, Any] = dict(result.summary) if result is not None else {}
        summary["status"] = (
            status or summary.get("status") or ("finished" if result is not None else "failed")
        )
        if error:
            summary["error"] = error
        if scene is not None:
            summary.setdefault("title", getattr(scene, "title", None))
            summary.setdefault("scene", getattr(scene, "source", None))
            units = getattr(scene, "units", None)
            if units is not None:
                summary.setdefault("units", dataclasses.asdict(units))
        if final is not None:
            summary.setdefault("steps", int(final.step))
            summary.setdefault("time", float(final.time))
        summary["frames_written"] = self.frame_count
        if result is not None:
            summary.setdefault("fracture_events", list(result.fracture_events))
        return summary

    def _write_history(self) -> None:
        rows = (self._history[step] for step in sorted(self._history))
        write_text(self.outdir / "history.csv", "".join(chain([history_header()], rows)))

    def _render_final(self, frame: Frame, summary: dict[str, Any]) -> str | None:
        try:
            render_frame(
                frame, self.outdir / "final.png", scalars=self.scalars,
                scene_title=summary.get("title") or "", units=summary.get("units"),
            )  # fmt: skip
        except Exception:  # a missing OpenGL must not cost the run's data
            logger.exception("could not render final.png")
            return None
        return "final.png"


def write_run(
    result: Result, outdir: str | os.PathLike[str], scene: Any = None, **options: Any
) -> dict[str, Any]:
    """Write a finished run's outputs in one go (see :class:`RunWriter`).

    Parameters
    ----------
    result
        The result.
    outdir
        Output directory.
    scene
        The scene, for the summary's title and source.
    **options
        Passed to :class:`RunWriter` (``scalars``, ``image``).

    Returns
    -------
    dict
        The summary as written.
    """
    return RunWriter(outdir, **options).finish(result, scene)


def _remove_old_outputs(outdir: Path) -> None:
    old = [outdir / name for name in OUTPUTS if (outdir / name).is_file()]
    old += [p for pattern in FRAME_PATTERNS for p in (outdir / "frames").glob(pattern)]
    old += list(outdir.glob(f"*{TEMP_MARK}*"))
    for path in old:
        path.unlink(missing_ok=True)
    if old:
        logger.info("removed %d files of an earlier run in %s", len(old), outdir)
