"""Everything a run leaves on disk, written as the run goes.

Layout of ``outdir``::

    run.lock                the run that owns the directory (dda.io.run_folder)
    blocks.pvd              time index of the block files (ParaView: open this)
    contacts.pvd            time index of the contact files
    bolts.pvd               time index of the bolts files (a scene with [[bolts]])
    frames/blocks_NNNNNN.vtu    one per kept frame (NNNNNN = step)
    frames/contacts_NNNNNN.vtu
    frames/bolts_NNNNNN.vtu     the rock bolts in place (a scene with [[bolts]]; every
                                frame, so none in place is an empty file, not a missing one)
    history.csv             one row per block per kept frame
    history_points.csv      one row per step of the [[measure]] quantities (with [[measure]])
    steps.csv               one row per step: time, dt, solves, penetration, energy account
    summary.json            the run summary (status "running", "finished", "failed", ...)
    checkpoint.npz          the last checkpoint, while the run is not finished (dda.run.checkpoint)
    final.png               the last frame, coloured by a stress component

Per kept frame, in this order: the VTU files (each atomically), a line
in each PVD index (O(1), the index stays a whole document), the frame's rows
appended to ``history.csv`` (one write, so the file holds whole frames) and
``summary.json`` rewritten atomically with status ``"running"``. Whenever the
run stops, even by SIGKILL, the directory holds a readable prefix of the run;
the writer keeps no frame and no history in memory.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import os
import time
from pathlib import Path
from typing import Any

from dda.io.atomic import TEMP_MARK, append_whole, write_text
from dda.io.images import render_frame
from dda.io.picture_process import PictureProcess
from dda.io.pvd import PvdIndex, read_pvd_entries, step_of_file
from dda.io.run_folder import BOLTS_INDEX, FRAME_PATTERNS, SUMMARY_NAME, RunFolder
from dda.io.tables import (
    POINTS_NAME,
    STEPS_NAME,
    history_header,
    history_rows,
    points_header,
    points_rows,
    steps_table,
    write_summary,
)
from dda.io.vtu import write_blocks_vtu, write_bolts_vtu, write_contacts_vtu
from dda.result import Frame, Result

logger = logging.getLogger(__name__)


class RunWriter:
    """Writes the frames of a run as they come, then the summary and the picture.

    Parameters
    ----------
    outdir
        Output directory, or a :class:`~dda.io.run_folder.RunFolder` already
        claimed. A directory is claimed here: refused (``OutputError``) when
        another run holds it or it holds an earlier run, unless ``overwrite``.
    scalars
        Colouring of ``final.png`` (see :func:`dda.io.images.render_frame`).
    image
        Whether :meth:`finish` renders ``final.png``.
    overwrite
        Replace the outputs of an earlier run in ``outdir``.
    resume_step
        Continue the run in ``outdir`` from this step (its checkpoint's):
        frames, index entries and history rows of later steps are removed,
        the rest is kept and extended.
    scene
        The scene (title and source for the summaries written while running).
    picture
        A helper process to draw ``final.png`` (:mod:`dda.io.picture_process`), or
        None to draw it in this process.
    """

    def __init__(
        self,
        outdir: str | os.PathLike[str] | RunFolder,
        scalars: str = "syy",
        image: bool = True,
        overwrite: bool = False,
        resume_step: int | None = None,
        scene: Any = None,
        picture: PictureProcess | None = None,
    ) -> None:
        if isinstance(outdir, RunFolder):
            self.folder = outdir
        else:
            mode = "resume" if resume_step is not None else "overwrite" if overwrite else "new"
            self.folder = RunFolder(outdir, mode)
        self.folder.claim()
        self.outdir = self.folder.outdir
        self.frames_dir = self.outdir / "frames"
        self.frames_dir.mkdir(parents=True, exist_ok=True)
        self.scalars = scalars
        self.image = image
        self.scene = scene
        self.picture = picture
        self.history_path = self.outdir / "history.csv"
        if resume_step is None:
            blocks, contacts, bolts = [], [], []
            write_text(self.history_path, history_header())
        else:
            blocks, contacts, bolts = _truncate_run(self.outdir, int(resume_step))
        self.resumed_from = resume_step
        self.blocks_index = PvdIndex(self.outdir / "blocks.pvd", blocks)
        self.contacts_index = PvdIndex(self.outdir / "contacts.pvd", contacts)
        # made with the first frame that has bolts: a run without [[bolts]] has no bolts.pvd
        self.bolts_index = PvdIndex(self.outdir / BOLTS_INDEX, bolts) if bolts else None
        self.frame_count = len(blocks)
        self.last_step = step_of_file(blocks[-1][0]) if blocks else -1
        self.last_frame: Frame | None = None
        self._history_fd: int | None = os.open(self.history_path, os.O_WRONLY | os.O_APPEND)
        self.points_path = self.outdir / POINTS_NAME
        self._points_fd: int | None = None
        self._start = time.perf_counter()
        self.done = False  # the closing summary.json is written (by finish)

    @property
    def run_id(self) -> str:
        """The id of the run (kept when a run is resumed)."""
        return self.folder.run_id

    def add_frame(self, frame: Frame) -> None:
        """Write one frame: VTU files, index lines, history rows, a "running" summary.

        Frames come in step order; a frame with the step of the last one
        replaces its files and index entries (its history rows stay).

        Parameters
        ----------
        frame
            The frame (usually passed by the engine's ``on_frame`` callback).
        """
        step = int(frame.step)
        if step < self.last_step:
            raise ValueError(f"frame of step {step} after step {self.last_step}")
        stem = f"{step:06d}"
        blocks, contacts = (
            self.frames_dir / f"{kind}_{stem}.vtu" for kind in ("blocks", "contacts")
        )
        write_blocks_vtu(frame, blocks)  # atomic writes: a full disk names the file
        write_contacts_vtu(frame, contacts)
        bolts = None
        if frame.bolts is not None:  # drawn by dda render and movie; none in place: empty
            bolts = self.frames_dir / f"bolts_{stem}.vtu"
            write_bolts_vtu(frame, bolts)
        self.blocks_index.add(frame.time, blocks)
        self.contacts_index.add(frame.time, contacts)
        if bolts is not None:
            self._add_bolts_entry(frame.time, bolts)
        if step > self.last_step:
            append_whole(self._history_fd, history_rows(frame), self.history_path)
            self.frame_count += 1
        if frame.measured is not None and len(frame.measured.get("step", ())):
            self._write_points(frame.measured)
        self.last_step = step
        self.last_frame = frame
        write_summary(self.outdir / SUMMARY_NAME, self._summary(None, "running", None, frame))
        logger.debug("frame step %d t=%g written", step, frame.time)

    def _add_bolts_entry(self, time: float, bolts: Path) -> None:
        """List ``bolts`` in ``bolts.pvd``, made with the first bolts file of the run."""
        if self.bolts_index is None:
            self.bolts_index = PvdIndex(self.outdir / BOLTS_INDEX)
        self.bolts_index.add(time, bolts)

    def finish(
        self,
        result: Result | None = None,
        scene: Any = None,
        status: str | None = None,
        error: str | None = None,
    ) -> dict[str, Any]:
        """Write ``summary.json`` and ``final.png``; release the directory.

        When no frame came through :meth:`add_frame`, the frames of ``result``
        are written first (:func:`write_run`). Without a result (the run failed)
        the summary holds what is known: the status, the error and the last
        frame written. A finished run's checkpoint is removed.

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
        if scene is not None:
            self.scene = scene
        if result is not None and self.frame_count == 0:
            for frame in result.frames:
                self.add_frame(frame)
        final = result.final if result is not None and result.frames else self.last_frame
        if final is not None and self.last_frame is not None and final.step < self.last_step:
            final = self.last_frame
        summary = self._summary(result, status, error, final)
        self.close()
        if result is not None and result.history:  # the energy account, a row a step
            write_text(self.outdir / STEPS_NAME, steps_table(result.history))
        if self.image and final is not None:
            summary["image"] = self._render_final(final, summary)
        elif self.picture is not None:
            self.picture.cancel()
        write_summary(self.outdir / SUMMARY_NAME, summary)
        self.done = True
        if summary["status"] == "finished":
            self.folder.checkpoint_path.unlink(missing_ok=True)
        self.folder.release()
        return summary

    def _write_points(self, measured: dict) -> None:
        """Append the ``[[measure]]`` rows a frame brings (the header first, in a new file)."""
        if self._points_fd is None:
            if not self.points_path.is_file():
                write_text(self.points_path, points_header(measured))
            self._points_fd = os.open(self.points_path, os.O_WRONLY | os.O_APPEND)
        append_whole(self._points_fd, points_rows(measured), self.points_path)

    def close(self) -> None:
        """Close ``history.csv`` and ``history_points.csv`` (all rows are written already)."""
        for name in ("_history_fd", "_points_fd"):
            if getattr(self, name) is not None:
                os.close(getattr(self, name))
                setattr(self, name, None)

    def _summary(self, result, status, error, final) -> dict[str, Any]:
        summary: dict[str, Any] = {"run_id": self.run_id}
        summary.update(result.summary if result is not None else {})
        summary["status"] = (
            status or summary.get("status") or ("finished" if result is not None else "failed")
        )
        if error:
            summary["error"] = error
        if self.scene is not None:
            summary.setdefault("title", getattr(self.scene, "title", None))
            summary.setdefault("scene", getattr(self.scene, "source", None))
            units = getattr(self.scene, "units", None)
            if units is not None:
                summary.setdefault("units", dataclasses.asdict(units))
            water = getattr(self.scene, "water", None)
            if water is not None:  # for the pictures drawn from the run (dda render, movie)
                summary.setdefault("water_table", [list(point) for point in water.table])
                seismic = getattr(self.scene, "seismic", None)  # the ground carries it
                summary.setdefault("water_follows", list(seismic.blocks) if seismic else [])
        if final is not None:
            summary.setdefault("steps", int(final.step))
            summary.setdefault("time", float(final.time))
        if result is None:
            summary["wall_seconds"] = round(time.perf_counter() - self._start, 6)
        if summary["status"] == "running":
            summary["pid"] = os.getpid()
        summary["frames_written"] = self.frame_count
        if self.resumed_from is not None:
            summary["resumed_from_step"] = self.resumed_from
        if result is not None:
            summary.setdefault("fracture_events", list(result.fracture_events))
        return summary

    def _render_final(self, frame: Frame, summary: dict[str, Any]) -> str | None:
        path = self.outdir / "final.png"
        options = {
            "scalars": self.scalars, "scene_title": summary.get("title") or "",
            "units": summary.get("units"), "water_table": summary.get("water_table"),
            "water_follows": summary.get("water_follows") or (),
        }  # fmt: skip
        if self.picture is not None and self.picture.draw(frame, path, **options):
            return "final.png"
        try:
            render_frame(frame, path, **options)
        except Exception as exc:  # a picture that fails must not cost the run's data
            reason = " ".join(str(exc).split()) or type(exc).__name__
            logger.error("could not draw %s: %s (summary.json has no image)", path, reason)
            logger.debug("the picture's error", exc_info=True)
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
        Passed to :class:`RunWriter` (``scalars``, ``image``, ``overwrite``).

    Returns
    -------
    dict
        The summary as written.
    """
    return RunWriter(outdir, **options).finish(result, scene)


def check_outputs_reach(outdir: Path, step: int, measured: bool) -> None:
    """Refuse to resume at ``step`` where the folder's tables end before the last frame it
    keeps (the last in ``blocks.pvd`` at or before ``step``): ``history.csv`` holds the
    rows of every kept frame, ``history_points.csv`` (with ``[[measure]]``) those of every
    step up to the last frame; a resumed run writes the rest. A table cut short (written
    without fsync before a power loss) or deleted would leave a gap the resumed run cannot
    fill (it was resumed silently: rows 19 to 25 missing, or a history from step 30 only).

    Raises
    ------
    OutputError
        naming the table, where it ends and the frame it must reach.
    """
    from dda.io.output_paths import OutputError

    index = outdir / "blocks.pvd"
    entries = read_pvd_entries(index) if index.is_file() else []
    last = max((step_of_file(f) for f, _ in entries if step_of_file(f) <= step), default=-1)
    if last < 0:
        return
    for name in ("history.csv", POINTS_NAME) if measured else ("history.csv",):
        path = outdir / name
        if not path.is_file():
            raise OutputError(path, f"is missing: its rows up to step {last} (the last frame "
                              "kept) are lost and a resumed run cannot write them; "
                              "--overwrite runs it again")  # fmt: skip
        ends = _last_row_step(path)
        if ends < last:
            raise OutputError(path, f"ends at step {ends}, before step {last} (the last frame "
                              "kept): the rows in between are lost and a resumed run cannot "
                              "write them; --overwrite runs it again")  # fmt: skip


def _last_row_step(path: Path) -> int:
    """The step of the last whole row of a table whose rows start with their step (-1:
    none)."""
    return max((step for step, _ in _whole_rows(path)), default=-1)


def _whole_rows(path: Path):
    """(step, end offset) of each whole row of a table after its header, in order (rows
    start with their step); a row cut short, or one whose step is no integer, ends them."""
    with open(path, "rb") as stream:
        end = len(stream.readline())
        for line in stream:
            try:
                step = int(line.split(b",", 1)[0])
            except ValueError:
                return
            if not line.endswith(b"\n"):
                return
            end += len(line)
            yield step, end


def _truncate_run(outdir: Path, step: int) -> tuple[list, list, list]:
    """Cut the outputs in ``outdir`` back to ``step``; return the index entries kept (of
    ``blocks.pvd``, ``contacts.pvd`` and ``bolts.pvd``)."""
    kept = []
    for name in ("blocks.pvd", "contacts.pvd"):
        path = outdir / name
        entries = read_pvd_entries(path) if path.is_file() else []
        kept.append([(file, t) for file, t in entries if 0 <= step_of_file(file) <= step])
    for pattern in FRAME_PATTERNS:
        for path in (outdir / "frames").glob(pattern):
            if TEMP_MARK in path.name or step_of_file(path) > step:
                path.unlink(missing_ok=True)
    for path in outdir.glob(f"*{TEMP_MARK}*"):  # a write the stop cut short (a picture)
        path.unlink(missing_ok=True)
    _truncate_history(outdir / "history.csv", step)
    # the measurements were written up to the last frame kept (dda.run.measure)
    last = max((step_of_file(file) for file, _ in kept[0]), default=-1)
    _truncate_history(outdir / POINTS_NAME, last, header=None)
    bolts = _bolts_entries(outdir, kept[0])
    if not bolts:
        (outdir / BOLTS_INDEX).unlink(missing_ok=True)  # listed only frames removed now
    logger.info("resuming %s at step %d: %d frames kept", outdir, step, len(kept[0]))
    return kept[0], kept[1], bolts


def _bolts_entries(outdir: Path, blocks: list[tuple[str, float]]) -> list[tuple[str, float]]:
    """The ``bolts.pvd`` entries of the frames ``blocks`` lists: those with a bolts file
    (so a run written before there was a ``bolts.pvd`` gets one when resumed)."""
    entries = []
    for file, t in blocks:
        bolts = Path(file).with_name(Path(file).name.replace("blocks_", "bolts_", 1))
        if bolts.name != Path(file).name and (outdir / bolts).is_file():
            entries.append((bolts.as_posix(), t))
    return entries


def _truncate_history(path: Path, step: int, header: str | None = "") -> None:
    """Keep the header and the whole rows of steps up to ``step`` (rows are in step order).

    ``header``: what a missing or empty file starts again with (``""``: the header of
    ``history.csv``; None: no file, the writer makes it with the first rows).
    """
    header = history_header() if header == "" else header
    if not path.is_file():
        if header is not None:
            write_text(path, header)
        return
    with open(path, "rb") as stream:
        head = stream.readline()
    end = 0
    if head.endswith(b"\n"):  # a whole header, then the whole rows up to ``step``
        kept = itertools.takewhile(lambda row: row[0] <= step, _whole_rows(path))
        end = max((row_end for _, row_end in kept), default=len(head))
    if end == 0:
        if header is None:
            path.unlink()
        else:
            write_text(path, header)
        return
    os.truncate(path, end)
