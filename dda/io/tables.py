"""Tables of a run: ``history.csv`` (long format) and ``summary.json``.

``history.csv`` has one row per block per kept frame::

    step,time,block,id,x,y,ux,uy,rotation,vx,vy,omega,sxx,syy,sxy

``x, y`` is the centroid, ``ux, uy`` its displacement since the start,
``rotation`` the accumulated rotation (rad), ``vx, vy, omega`` the centroid
velocity and ``sxx, syy, sxy`` the block stress.

``history_points.csv`` (with ``[[measure]]``) has one row per step::

    step,time,NAME.COMPONENT,...

(docs/scene.md lists the components). ``steps.csv`` has one row per step of the run's
own history (:attr:`dda.Result.history`): its time, Δt, linear solves, deepest
penetration and energy account::

    step,time,dt,iterations,max_penetration,kinetic_energy,...,external_work,...
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from dda.io.atomic import write_text
from dda.result import Frame

HISTORY_COLUMNS = (
    "step", "time", "block", "id", "x", "y", "ux", "uy", "rotation",
    "vx", "vy", "omega", "sxx", "syy", "sxy",
)  # fmt: skip


def history_rows(frame: Frame) -> str:
    """CSV rows (no header) of one frame, one line per block.

    Parameters
    ----------
    frame
        The frame.

    Returns
    -------
    str
        Lines ending in ``"\\n"``; floats written with ``repr`` (exact).
    """
    n = len(frame.names)
    numbers = np.column_stack(
        [
            np.asarray(frame.centroids, float).reshape(n, 2),
            np.asarray(frame.displacements, float).reshape(n, 2),
            np.asarray(frame.rotations, float).reshape(n, 1),
            np.asarray(frame.velocities, float).reshape(n, 3),
            np.asarray(frame.stresses, float).reshape(n, 3),
        ]
    ).tolist()
    ids = np.asarray(frame.ids).reshape(n).tolist()
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    step, time = int(frame.step), float(frame.time)
    writer.writerows(
        [step, time, name, ident, *values]
        for name, ident, values in zip(frame.names, ids, numbers, strict=True)
    )
    return buffer.getvalue()


POINTS_NAME = "history_points.csv"


def points_header(measured: dict[str, np.ndarray]) -> str:
    """The header line of ``history_points.csv``: ``step,time,name.component,...``."""
    return ",".join(measured) + "\n"


def points_rows(measured: dict[str, np.ndarray]) -> str:
    """CSV rows (no header) of the ``[[measure]]`` rows a frame brings, one per step.

    Parameters
    ----------
    measured
        Columns ``step``, ``time``, ``name.component``, ... (:attr:`dda.result.Frame.measured`).

    Returns
    -------
    str
        Lines ending in ``"\n"``; the step as an integer, numbers with ``repr`` (exact).
    """
    columns = list(measured.values())
    steps = np.asarray(columns[0]).astype(np.int64).tolist()
    values = np.column_stack([np.asarray(c, float) for c in columns[1:]]).tolist()
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(
        [step, *row] for step, row in zip(steps, values, strict=True)
    )
    return buffer.getvalue()


STEPS_NAME = "steps.csv"


def steps_table(history: Mapping[str, Any]) -> str:
    """``steps.csv``: a header and one row per step (from 1) of ``history``'s columns,
    floats with ``repr`` (exact); the header alone for a run of no step."""
    names = list(history)
    table = np.column_stack([np.asarray(history[name], dtype=float) for name in names])
    rows = (",".join([str(k), *map(repr, row)]) for k, row in enumerate(table.tolist(), 1))
    return "\n".join([",".join(["step", *names]), *rows]) + "\n"


def history_header() -> str:
    """The header line of ``history.csv``."""
    return ",".join(HISTORY_COLUMNS) + "\n"


def write_history(path: str | os.PathLike[str], frames: Iterable[Frame]) -> Path:
    """Write ``history.csv`` for ``frames`` atomically.

    Parameters
    ----------
    path
        Destination file.
    frames
        The kept frames, in order.

    Returns
    -------
    Path
        ``path``.
    """
    return write_text(path, history_header() + "".join(history_rows(f) for f in frames))


def to_jsonable(value: Any) -> Any:
    """Convert a value to plain JSON types (numpy, tuples, paths, dataclasses...).

    Non-finite floats become ``None`` (JSON has no NaN or infinity); objects
    that are none of the known kinds become their ``str``.

    Parameters
    ----------
    value
        Any value.

    Returns
    -------
    Any
        ``dict``/``list``/``str``/``int``/``float``/``bool``/``None`` only.
    """
    kind = type(value)  # the plain kinds first: a big scene's values are mostly these
    if kind is float:
        return value if math.isfinite(value) else None
    if kind is int or kind is str or kind is bool or value is None:
        return value
    if kind is list or kind is tuple:
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray | np.generic):
        return to_jsonable(value.tolist())
    if isinstance(value, bool | int | str) or value is None:
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if hasattr(value, "_asdict"):  # NamedTuple
        return to_jsonable(value._asdict())
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        # field by field, not dataclasses.asdict: its deep copy of every value took
        # 0.39 s of the 60 x 60 wall's scene fingerprint, against 0.1 s (the same text)
        return {f.name: to_jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, list | tuple | set | frozenset):
        return [to_jsonable(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return str(value)


def write_summary(path: str | os.PathLike[str], summary: Mapping[str, Any]) -> Path:
    """Write ``summary.json`` atomically (indented, keys in the given order).

    Parameters
    ----------
    path
        Destination file.
    summary
        The run summary (numpy values allowed).

    Returns
    -------
    Path
        ``path``.
    """
    text = json.dumps(to_jsonable(summary), indent=2, allow_nan=False)
    return write_text(path, text + "\n")
