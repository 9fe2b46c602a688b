"""Checks of output paths before anything is written: one clear reason, no traceback.

A path given for output may exist as the wrong kind (a file where a
directory is wanted), lie under a file, or be on a file system that cannot
be written (read-only, no permission, a pseudo file system such as
``/proc``). These functions find that out without leaving anything behind
and raise :class:`OutputError` naming the path. Permission bits do not
answer the question (``root`` passes every ``os.access`` check, yet cannot
create a file in ``/proc``), so the nearest existing folder is asked to hold
a file for a moment: :func:`probe_folder`.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path


class OutputError(Exception):
    """An output path that cannot be used: ``str(exc)`` is ``"<path>: <reason>"``."""

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")


def check_output_dir(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` for a directory path that exists as a file, lies under
    one or cannot be written (read-only file system, no permission, no files there)."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise OutputError(path, "exists and is not a directory")
        reason = probe_folder(path)
        if reason:
            raise OutputError(path, f"cannot write in it ({reason})")
        return
    _check_creatable(path, path.absolute().parents)


def check_output_file(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` for a file path that is a directory, or whose directory
    cannot be made or written."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(path, "is a directory, not a file")
    _check_creatable(path, path.parents)


def _check_creatable(path: Path, parents: Sequence[Path]) -> None:
    """Raise :class:`OutputError` when ``path`` cannot be made in the first of ``parents``
    that exists (a file, or a folder that takes no file)."""
    folder = next((p for p in parents if p.exists()), None)
    if folder is None:
        return
    if not folder.is_dir():
        raise OutputError(path, f"{folder} is a file, not a directory")
    reason = probe_folder(folder)
    if reason:
        raise OutputError(path, f"cannot create it in {folder} ({reason})")


def probe_folder(folder: Path) -> str | None:
    """Why no file can be made in the existing ``folder`` (the system's words, e.g.
    ``"Read-only file system"``), or None when one can: a hidden empty file is made and
    removed at once, and the folder's times are set back (the probe leaves no trace)."""
    if not os.access(folder, os.W_OK | os.X_OK):
        return "read-only or no permission"
    before = os.stat(folder)
    try:
        descriptor, name = tempfile.mkstemp(prefix=".dda-probe-", dir=folder)
    except OSError as exc:
        return exc.strerror or str(exc)
    os.close(descriptor)
    os.unlink(name)
    with contextlib.suppress(OSError):
        os.utime(folder, ns=(before.st_atime_ns, before.st_mtime_ns))
    return None
