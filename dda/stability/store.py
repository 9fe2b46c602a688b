"""Finished trials on disk: one CSV row per trial, written as it finishes, reused by a rerun.

Every row carries ``scene_hash``, a digest of the scene (with its ``[fos]`` and
``[ensemble]`` tables and the command's overrides): a rerun of the same search reads
the rows with its own hash back and runs only what is missing; rows of another scene
are dropped when the new search starts. A row is appended and flushed at once, so a
search stopped at any point (Ctrl-C, a lost worker) keeps every finished trial.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from dda.io.atomic import append_whole, write_text

HASH_COLUMN = "scene_hash"
T = TypeVar("T")


def refuse_foreign(store: RowStore, command: str, what: str, overwrite: bool) -> str | None:
    """The one-line refusal of a ``store`` that holds rows of another scene, seed or option
    (``what``: "trial(s)", "realisation(s)"), unless ``overwrite``; else None."""
    foreign = 0 if overwrite else store.foreign()
    if not foreign:
        return None
    return (f"dda {command}: {store.path}: holds {foreign} {what} of another scene, seed or "
            "option (or of a scene in another folder); --overwrite replaces them (or give "
            "another -o)")  # fmt: skip


def scene_hash(raw: Mapping[str, Any], source: str, *extra: object) -> str:
    """A short digest of a raw scene read from ``source``, and anything else that changes
    the answers. Of ``source`` only its folder counts, resolved: the files a scene names
    (a drawing, a seismic record) are read from there, and however its path is written
    (relative, absolute, a shipped case's name) the same scene file is the same scene
    (an audit: ``dda fos cp/s.toml`` then ``dda fos /tmp/aw/cp/s.toml`` was refused as
    another scene)."""
    folder = source if source.startswith("<") else str(Path(source).resolve().parent)
    text = json.dumps([raw, folder, *extra], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class RowStore:
    """A CSV of rows with fixed columns (``HASH_COLUMN`` last), appended row by row."""

    def __init__(self, path: Path, columns: Sequence[str], digest: str) -> None:
        self.path = Path(path)
        self.columns = [*columns, HASH_COLUMN]
        self.digest = digest
        self.dropped = self.damaged = 0  # rows :meth:`open` left out

    def foreign(self) -> int:
        """How many rows of the file are of another scene, seed or option (read only)."""
        return sum(1 for r in self._read() if r.get(HASH_COLUMN) != self.digest)

    def open(self, parse: Callable[[dict[str, str]], T]) -> list[T]:
        """The rows of an earlier run of the same scene, each read by ``parse``; the file
        is started afresh (header and those rows only) so that later rows are appended
        to it. A row ``parse`` cannot read (a damaged value: ValueError, KeyError) is
        left out, to be run again; ``dropped`` counts the rows of another scene (or
        seed) and ``damaged`` those."""
        rows = self._read()
        same = [r for r in rows if r.get(HASH_COLUMN) == self.digest]
        self.dropped = len(rows) - len(same)
        kept, parsed = [], []
        for row in same:
            try:
                parsed.append(parse(row))
            except (ValueError, KeyError, TypeError):
                continue
            kept.append(row)
        self.damaged = len(same) - len(kept)
        lines = [",".join(self.columns)] + [self._line(r) for r in kept]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_text(self.path, "\n".join(lines) + "\n")
        return parsed

    def notes(self) -> list[str]:
        """What :meth:`open` left out of the file, as sentences (none: [])."""
        said = []
        if self.dropped:
            said.append(f"{self.dropped} row(s) of another scene, seed or option dropped")
        if self.damaged:
            said.append(f"{self.damaged} damaged row(s) run again")
        return [f"{self.path.name}: {text}" for text in said]

    def append(self, row: Mapping[str, Any]) -> None:
        """Write one finished row at once, whole or not at all (a full disk)."""
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
        try:
            append_whole(fd, self._line({**row, HASH_COLUMN: self.digest}) + "\n", self.path)
        finally:
            os.close(fd)

    def _read(self) -> list[dict[str, str]]:
        if not self.path.is_file():
            return []
        with self.path.open(encoding="utf-8", newline="") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None or list(reader.fieldnames) != self.columns:
                return []
            return [r for r in reader if None not in r.values()]

    def _line(self, row: Mapping[str, Any]) -> str:
        cells = [_cell(row.get(c, "")) for c in self.columns]
        out = io.StringIO()
        csv.writer(out, lineterminator="").writerow(cells)
        return out.getvalue()


def flag(text: str, refused: bool = False) -> bool | None:
    """A cell written from True or False (and None where ``refused``: a trial refused)
    read back; ValueError for anything else (a damaged row)."""
    values = {"True": True, "False": False, **({"None": None} if refused else {})}
    if text not in values:
        raise ValueError(f"not a flag: {text!r}")
    return values[text]


def _cell(value: Any) -> str:
    """A value as CSV text (floats in full precision)."""
    if isinstance(value, float) and math.isfinite(value):
        return repr(value)
    return str(value)
