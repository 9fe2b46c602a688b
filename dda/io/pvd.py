"""The ``.pvd`` index: which file holds which time, for ParaView and pyvista.

A PVD is a small XML collection::

    <VTKFile type="Collection" version="0.1">
      <Collection>
        <DataSet timestep="0.01" part="0" file="frames/blocks_000010.vtu"/>
      </Collection>
    </VTKFile>

:class:`PvdIndex` writes the index once, atomically, and then adds each
frame in O(1): one ``pwrite`` of the new ``DataSet`` line and the closing
tags over the old closing tags. After every write the file is a complete
document, so a run that stops early, even by SIGKILL, leaves a readable
index of what was written.
"""

from __future__ import annotations

import html
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path

from dda.io.atomic import naming, write_fully, write_text

HEAD = (
    '<?xml version="1.0"?>\n'
    '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
    "  <Collection>\n"
)
TAIL = "  </Collection>\n</VTKFile>\n"
STEP_OF_FILE = re.compile(r"_(\d+)\.vtu$")


class PvdIndex:
    """A time series index kept written to disk, extended in O(1) per data set.

    Parameters
    ----------
    path
        The ``.pvd`` file. Data set file names are stored relative to its
        directory. It is (re)written at once, holding ``entries``.
    entries
        ``(file, time)`` pairs to start with, files relative to the index's
        directory (as :func:`read_pvd_entries` gives them).
    """

    def __init__(
        self, path: str | os.PathLike[str], entries: Iterable[tuple[str, float]] = ()
    ) -> None:
        self.path = Path(path)
        self._directory = self.path.parent.resolve()
        entries = list(entries)
        text = pvd_text(entries).encode("utf-8")
        write_text(self.path, text.decode("utf-8"))
        self._count = len(entries)
        self._end = len(text) - len(TAIL.encode("utf-8"))  # where the closing tags start
        self._last: tuple[str, int] | None = None  # (file, offset of its line)
        if entries:
            last = _line(*entries[-1]).encode("utf-8")
            self._last = (entries[-1][0], self._end - len(last))

    def __len__(self) -> int:
        return self._count

    def add(self, time: float, file: str | os.PathLike[str]) -> None:
        """Record ``file`` at ``time`` and save; the same file as the last entry replaces it.

        Parameters
        ----------
        time
            Simulated time of the data set.
        file
            The data set file (absolute, or relative to the working directory);
            stored relative to the index's directory.
        """
        relative = os.path.relpath(Path(file).resolve(), self._directory)
        name = Path(relative).as_posix()
        line = _line(name, time).encode("utf-8")
        replace = self._last is not None and self._last[0] == name
        offset = self._last[1] if replace else self._end
        data = line + TAIL.encode("utf-8")
        with naming(self.path):
            fd = os.open(self.path, os.O_RDWR)
            try:
                size, before = os.fstat(fd).st_size, os.pread(fd, len(data), offset)
                try:
                    write_fully(fd, data, offset)  # one write: whole before and after
                except OSError:  # a full disk: put back what was there (its space exists)
                    os.pwrite(fd, before, offset)
                    os.ftruncate(fd, size)
                    raise
                if os.fstat(fd).st_size > offset + len(data):
                    os.ftruncate(fd, offset + len(data))
            finally:
                os.close(fd)
        self._last = (name, offset)
        self._end = offset + len(line)
        self._count += 0 if replace else 1


def _line(file: str | os.PathLike[str], time: float) -> str:
    # html.escape: &, <, >, " and ' as XML reads them (xml.sax.saxutils would import
    # urllib.request, http and ssl: 15 ms of every run's start)
    name = html.escape(str(file), quote=True)
    return f'    <DataSet timestep="{float(time)!r}" group="" part="0" file="{name}"/>\n'


def pvd_text(entries: Iterable[tuple[str, float]]) -> str:
    """XML text of a PVD collection.

    Parameters
    ----------
    entries
        Iterable of ``(file, time)`` pairs, in order.

    Returns
    -------
    str
        The document.
    """
    return HEAD + "".join(_line(file, time) for file, time in entries) + TAIL


def read_pvd_entries(path: str | os.PathLike[str]) -> list[tuple[str, float]]:
    """The ``(file, time)`` entries of the index ``path`` in file order, files as written
    (relative to the index): what :class:`PvdIndex` takes to start from."""
    root = ET.parse(path).getroot()
    return [(d.get("file", ""), float(d.get("timestep", "nan"))) for d in root.iter("DataSet")]


def read_pvd(path: str | os.PathLike[str]) -> list[tuple[float, Path]]:
    """The ``(time, file)`` entries of a PVD index, files resolved against its directory.

    Parameters
    ----------
    path
        The ``.pvd`` file.

    Returns
    -------
    list of (float, Path)
        In file order.
    """
    path = Path(path)
    return [(time, path.parent / file) for file, time in read_pvd_entries(path)]


def step_of_file(file: str | os.PathLike[str]) -> int:
    """The step in a frame file's name (``frames/blocks_000010.vtu`` -> 10); -1 if none."""
    match = STEP_OF_FILE.search(Path(file).name)
    return int(match.group(1)) if match else -1
