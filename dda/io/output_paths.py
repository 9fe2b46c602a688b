"""Checks of output paths before anything is written: one clear reason, no traceback.

A path given for output may exist as the wrong kind (a file where a
directory is wanted), lie under a file, or be on a file system that cannot
be written (read-only, no permission). These functions find that out
without creating anything and raise :class:`OutputError` naming the path.
"""

from __future__ import annotations

import os
from pathlib import Path


class OutputError(Exception):
    """An output path that cannot be used: ``str(exc)`` is ``"<path>: <reason>"``."""

    def __init__(self, path: str | os.PathLike[str], reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")


def check_output_dir(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` for a directory path that exists as a file, lies under
    one or cannot be written (read-only file system, no permission)."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise OutputError(path, "exists and is not a directory")
        if not os.access(path, os.W_OK):
            raise OutputError(path, "cannot write in it (read-only or no permission)")
        return
    ancestor = next((p for p in path.absolute().parents if p.exists()), None)
    if ancestor is not None and not ancestor.is_dir():
        raise OutputError(path, f"{ancestor} is a file, not a directory")
    if ancestor is not None and not os.access(ancestor, os.W_OK):
        raise OutputError(path, f"cannot create it in {ancestor} (read-only or no permission)")


def check_output_file(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` for a file path that is a directory, or whose directory
    cannot be made or written."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(path, "is a directory, not a file")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise OutputError(path, f"{parent} is a file, not a directory")
    try:
        check_output_dir(parent)
    except OutputError as exc:
        raise OutputError(path, exc.reason) from None
