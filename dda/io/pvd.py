"""The ``.pvd`` index: which file holds which time, for ParaView and pyvista.

A PVD is a small XML collection::

    <VTKFile type="Collection" version="0.1">
      <Collection>
        <DataSet timestep="0.01" part="0" file="frames/blocks_000010.vtu"/>
      </Collection>
    </VTKFile>

:class:`PvdIndex` rewrites the whole index atomically after every frame, so
a run that stops early still leaves a readable index of what was written.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path

from dda.io.atomic import write_text


class PvdIndex:
    """A time series index that is kept written to disk.

    Parameters
    ----------
    path
        The ``.pvd`` file. Data set file names are stored relative to its
        directory.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._entries: dict[str, float] = {}

    def __len__(self) -> int:
        return len(self._entries)

    def add(self, time: float, file: str | os.PathLike[str]) -> None:
        """Record ``file`` at ``time`` (replacing an earlier entry for the same file) and save.

        Parameters
        ----------
        time
            Simulated time of the data set.
        file
            The data set file (absolute, or relative to the working directory);
            stored relative to the index's directory.
        """
        relative = os.path.relpath(Path(file).resolve(), self.path.parent.resolve())
        self._entries[Path(relative).as_posix()] = float(time)
        self.save()

    def save(self) -> None:
        """Write the index atomically."""
        write_text(self.path, pvd_text(self._entries.items()))


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
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    collection = ET.SubElement(root, "Collection")
    for file, time in entries:
        ET.SubElement(
            collection, "DataSet", timestep=repr(float(time)), group="", part="0", file=str(file)
        )
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


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
    root = ET.parse(path).getroot()
    return [
        (float(d.get("timestep", "nan")), path.parent / d.get("file", ""))
        for d in root.iter("DataSet")
    ]
