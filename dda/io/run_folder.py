"""An output directory belongs to one run: its lock file, and what a new run may do there.

``OUTDIR/run.lock`` names the run that owns the directory (JSON: run id,
process id, host, start time). While the run goes on it holds an exclusive
``flock`` on that file, which the operating system drops when the process
ends, however it ends (SIGKILL too): a lock is never left stale. A run asked
to write into a directory

- that another live run holds is refused;
- that holds outputs of an earlier run (its lock file, summary, indexes,
  frames or checkpoint) is refused, unless it was asked to replace them
  (``mode="overwrite"``) or to continue that run (``mode="resume"``);
- that is a file, lies under a file or cannot be written is refused.

Every refusal is an :class:`~dda.io.output_paths.OutputError` naming the
directory and the reason; nothing has been written or removed then.
"""

from __future__ import annotations

import json
import logging
import os
import secrets
import socket
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dda.io.atomic import TEMP_MARK
from dda.io.output_paths import OutputError, check_output_dir

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX: the lock file records, it does not lock
    fcntl = None

logger = logging.getLogger(__name__)

LOCK_NAME = "run.lock"
CHECKPOINT_NAME = "checkpoint.npz"
SUMMARY_NAME = "summary.json"
BOLTS_INDEX = "bolts.pvd"  # a run with [[bolts]]
OUTPUTS = ("blocks.pvd", "contacts.pvd", BOLTS_INDEX, "history.csv", "history_points.csv",
           "steps.csv", SUMMARY_NAME, "final.png", CHECKPOINT_NAME)  # fmt: skip
FRAME_PATTERNS = ("blocks_*.vtu", "contacts_*.vtu", "bolts_*.vtu", f"*{TEMP_MARK}*")
# drawn from a run: dda render's default PNGs, dda plot's folder, dda movie's file
DRAWN_PATTERNS = ("blocks_[0-9]*_*.png", "plots/*.png", "movie.gif", "movie.mp4")
MODES = ("new", "overwrite", "resume")


@dataclass(frozen=True)
class PreviousRun:
    """What a directory says about the run that wrote it."""

    run_id: str | None
    status: str | None  # the summary's status ("running" left by a killed run)
    steps: int | None
    has_checkpoint: bool
    fingerprint: dict | None = None  # the summary's scene_fingerprint (of the run's scene)

    def describe(self) -> str:
        """E.g. ``"run 20240101-120000-ab12cd (interrupted at step 400)"``."""
        name = f"run {self.run_id}" if self.run_id else "an earlier run"
        status = "stopped without finishing" if self.status == "running" else self.status
        if status is None:
            return name
        at = f" at step {self.steps}" if self.steps is not None and status != "finished" else ""
        return f"{name} ({status}{at})"


class RunFolder:
    """The hold of one run on an output directory, until :meth:`release`.

    Made, it holds the lock and has checked the directory; :meth:`claim`
    then makes the directory the run's (the writer does, when it starts).

    Parameters
    ----------
    outdir
        The output directory (created, with its parents, if missing).
    mode
        ``"new"``: refuse a directory holding an earlier run; ``"overwrite"``:
        remove that run's outputs; ``"resume"``: keep them (there must be a run).

    Raises
    ------
    OutputError
        The directory cannot be used (see the module docstring).
    """

    def __init__(self, outdir: str | os.PathLike[str], mode: str = "new") -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        self.outdir = Path(outdir)
        self.mode = mode
        if mode == "resume" and not self.outdir.is_dir():
            raise OutputError(self.outdir, "holds no run to resume")
        self._made = _make_directory(self.outdir)
        self._lock_existed = (self.outdir / LOCK_NAME).exists()
        self._fd: int | None = None
        self.claimed = False
        try:
            self._fd = _open_lock_file(self.outdir)
            record = _lock(self._fd, self.outdir)
            self.previous = _previous_run(self.outdir, record)
            self._check_mode()
            resumed = self.previous.run_id if mode == "resume" and self.previous else None
            self.run_id = resumed or new_run_id()
            self.started = time.time()
        except BaseException:
            self.abandon()
            raise

    def abandon(self) -> None:
        """Give the directory up unclaimed, as it was: release it, remove the lock file and
        the directories made for the run (for a run refused before :meth:`claim`)."""
        if self.claimed:
            raise RuntimeError(f"{self.outdir}: claimed by this run; release it instead")
        self.release()
        if not self._lock_existed:
            (self.outdir / LOCK_NAME).unlink(missing_ok=True)
        for path in self._made:
            path.rmdir()
        self._made = []

    def claim(self) -> None:
        """Make the directory this run's: remove an earlier run's outputs (``overwrite``),
        write the lock file's record, make ``frames/``. Until then nothing is changed."""
        if self.claimed:
            return
        if self.mode == "overwrite" and self.previous is not None:
            remove_outputs(self.outdir)
        self._write_record()
        (self.outdir / "frames").mkdir(exist_ok=True)
        self.claimed = True

    def reclaimable_bytes(self) -> int:
        """Bytes of an earlier run's files that :meth:`claim` removes (``overwrite``)."""
        if self.mode != "overwrite" or self.previous is None:
            return 0
        return sum(path.stat().st_size for path in output_files(self.outdir))

    @property
    def checkpoint_path(self) -> Path:
        """Where this run's checkpoint lives."""
        return self.outdir / CHECKPOINT_NAME

    def record(self) -> dict[str, Any]:
        """The lock file's content: run id, process id, host and start time."""
        started = time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(self.started))
        return {"run_id": self.run_id, "pid": os.getpid(), "host": socket.gethostname(),
                "started": started}  # fmt: skip

    def release(self) -> None:
        """Let other runs have the directory (the lock file stays, naming this run)."""
        if self._fd is not None:
            os.close(self._fd)  # drops the flock
            self._fd = None

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def _check_mode(self) -> None:
        previous = self.previous
        if self.mode == "new" and previous is not None:
            hint = "--overwrite replaces it"
            if previous.has_checkpoint and previous.status != "finished":
                hint = "--resume continues it from its checkpoint, " + hint
            raise OutputError(self.outdir, f"holds {previous.describe()}; {hint}")
        if self.mode == "resume" and previous is None:
            raise OutputError(self.outdir, "holds no run to resume")

    def _write_record(self) -> None:
        data = (json.dumps(self.record()) + "\n").encode("utf-8")
        os.ftruncate(self._fd, 0)
        os.pwrite(self._fd, data, 0)  # in place: the flock is on this file


def new_run_id() -> str:
    """A run id: local start time and 6 random hex digits, e.g. ``20240101-120000-ab12cd``."""
    return time.strftime("%Y%m%d-%H%M%S") + "-" + secrets.token_hex(3)


def remove_outputs(outdir: Path) -> int:
    """Remove the files a run writes in ``outdir``, and those drawn from it by ``dda
    render``, ``dda plot`` and ``dda movie`` in their default places (others are left);
    return how many."""
    old = output_files(outdir)
    for path in old:
        path.unlink(missing_ok=True)
    for folder in (outdir / "plots", outdir / "frames"):
        if folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
    if old:
        logger.info("removed %d files of an earlier run in %s", len(old), outdir)
    return len(old)


def output_files(outdir: Path) -> list[Path]:
    """The files of a run in ``outdir`` that :func:`remove_outputs` removes."""
    old = [outdir / name for name in OUTPUTS if (outdir / name).is_file()]
    old += [p for pattern in FRAME_PATTERNS for p in (outdir / "frames").glob(pattern)]
    old += list(outdir.glob(f"*{TEMP_MARK}*"))
    old += [p for pattern in DRAWN_PATTERNS for p in outdir.glob(pattern) if p.is_file()]
    return old


def _make_directory(outdir: Path) -> list[Path]:
    """Create ``outdir`` and its missing parents; return those made, deepest first."""
    check_output_dir(outdir)
    made = [p for p in [outdir, *outdir.parents] if not p.exists()]
    try:
        outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(outdir, f"cannot create it ({exc.strerror or exc})") from None
    return made


def _open_lock_file(outdir: Path) -> int:
    try:
        return os.open(outdir / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise OutputError(outdir, f"cannot write in it ({exc.strerror or exc})") from None


def _lock(fd: int, outdir: Path) -> dict[str, Any]:
    """Take the flock; return the record the lock file held before (empty if none)."""
    if fcntl is not None:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_record(fd)
            who = "another run, starting"
            if holder.get("run_id"):
                who = f"run {holder['run_id']} (process {holder.get('pid', '?')} on "
                who += f"{holder.get('host', '?')}, started {holder.get('started', '?')})"
            reason = f"in use by {who}; wait for it to end or write elsewhere"
            raise OutputError(outdir, reason) from None
    return _read_record(fd)


def _read_record(fd: int) -> dict[str, Any]:
    data = os.pread(fd, 1 << 16, 0)
    try:
        record = json.loads(data.decode("utf-8")) if data.strip() else {}
    except (UnicodeDecodeError, ValueError):
        return {"run_id": None}
    return record if isinstance(record, dict) else {"run_id": None}


def _previous_run(outdir: Path, record: dict[str, Any]) -> PreviousRun | None:
    """The earlier run in ``outdir``, or ``None`` when it holds none of a run's files."""
    frames = any(True for pattern in FRAME_PATTERNS[:2] for _ in (outdir / "frames").glob(pattern))
    if not record and not frames and not any((outdir / n).is_file() for n in OUTPUTS):
        return None
    summary = _read_summary(outdir / SUMMARY_NAME)
    steps = summary.get("steps")
    return PreviousRun(
        run_id=record.get("run_id") or summary.get("run_id"),
        status=summary.get("status"),
        steps=steps if isinstance(steps, int) else None,
        has_checkpoint=(outdir / CHECKPOINT_NAME).is_file(),
        fingerprint=summary.get("scene_fingerprint")
        if isinstance(summary.get("scene_fingerprint"), dict)
        else None,
    )


def _read_summary(path: Path) -> dict[str, Any]:
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return {}
    return summary if isinstance(summary, dict) else {}
