"""Pictures of the measurement histories: one PNG per quantity of ``history_points.csv``.

``dda plot OUTDIR`` reads ``OUTDIR/history_points.csv`` (written by ``dda
run`` for a scene with ``[[measure]]``) and the units of ``summary.json``, and
draws, for each quantity measured (displacement, velocity, stress, contact
force, bolt force), every component of every measurement against time: a
title, axes with their units, a legend naming each curve ``name.component``.
Forces are per metre of the section's thickness (``kN/m``): a 2-D model's forces are.
"""

from __future__ import annotations

import contextlib
import csv
import logging
import textwrap
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from dda.io.atomic import atomic_path
from dda.io.fields import engineering_scale, unit_name
from dda.io.fonts import unicode_text
from dda.io.tables import POINTS_NAME
from dda.scene.engineering import BOLT_QUANTITIES, CONTACT_QUANTITIES, POINT_QUANTITIES

logger = logging.getLogger(__name__)

# quantity -> (axis label, dimension of its unit, title)
QUANTITIES = {
    "displacement": ("displacement", "length", "displacement of the measurement points"),
    "velocity": ("velocity", "velocity", "velocity of the measurement points"),
    "stress": ("stress (tension positive)", "stress", "stress of the measured points' blocks"),
    "contact_force": ("contact force", "force_per_length",
                      "contact forces between the measured pairs of blocks "
                      "(N: normal, sum over the contacts; fx, fy: on the first block)"),
    "bolt_force": ("bolt tension", "force_per_length", "tension of the measured bolts"),
}  # fmt: skip
_COMPONENTS = {**POINT_QUANTITIES, **CONTACT_QUANTITIES, **BOLT_QUANTITIES}
_DPI = 100
TITLE_WIDTH = 80  # characters of a title line (fontsize 11 on the 9 in wide figure)


def read_points(path: Path) -> dict[str, np.ndarray]:
    """The columns of a ``history_points.csv``.

    Raises
    ------
    ValueError
        The file is not such a table (one line naming the file and the reason).
    """
    with open(path, newline="", encoding="utf-8") as stream:
        rows = list(csv.reader(stream))
    if not rows or rows[0][:2] != ["step", "time"]:
        raise ValueError(f"{path}: not a history_points.csv (no step,time header)")
    header = rows[0]
    body = [(line, r) for line, r in enumerate(rows[1:], start=2) if len(r) == len(header)]
    for line, row in body:
        try:
            [float(x) for x in row]
        except ValueError as exc:
            raise ValueError(f"{path}: line {line} is not numbers ({exc})") from None
    table = np.array([r for _, r in body], dtype=float).reshape(-1, len(header))
    if not group_columns(header):
        raise ValueError(f"{path}: no measurement columns to draw (name.component: ux, syy, "
                         "normal_force, ...)")  # fmt: skip
    if not len(table):
        raise ValueError(f"{path}: no rows: the run wrote no measurement yet")
    return {name: table[:, k] for k, name in enumerate(header)}


def group_columns(columns: list[str]) -> dict[str, list[str]]:
    """Measurement columns (``name.component``) by quantity, in the file's order."""
    groups: dict[str, list[str]] = {}
    for column in columns[2:]:
        component = column.rsplit(".", 1)[-1]
        quantity = next((q for q, parts in _COMPONENTS.items() if component in parts), None)
        if quantity is not None:
            groups.setdefault(quantity, []).append(column)
    return groups


def plot_histories(
    outdir: Path, folder: Path | None = None, title: str = "", units: Mapping | None = None
) -> list[Path]:
    """Draw one PNG per quantity into ``folder`` (default ``outdir/plots``); return them.
    When one cannot be written (a full disk) into a folder this call made, that folder
    (and the parents it made) and what was written into it are removed: nothing is left
    half done."""
    table = read_points(outdir / POINTS_NAME)
    folder = folder or outdir / "plots"
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # deepest first
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    try:
        for quantity, columns in group_columns(list(table)).items():
            path = folder / f"{quantity}.png"
            _draw(path, table["time"], {c: table[c] for c in columns}, quantity, title, units)
            written.append(path)
            logger.info("wrote %s", path)
    except BaseException:
        if made:
            for path in written:
                path.unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                for path in made:
                    path.rmdir()
        raise
    return written


def _draw(path, time, curves, quantity, title, units) -> None:
    """One quantity's curves; large stresses and forces in k, M or G of their unit; the
    title wrapped to the figure's width."""
    from matplotlib.figure import Figure

    label, dimension, heading = QUANTITIES[quantity]
    largest = max((np.abs(v[np.isfinite(v)]).max(initial=0.0) for v in curves.values()), default=0)
    scale, unit = engineering_scale(float(largest), unit_name(dimension, units))
    with unicode_text():
        figure = Figure(figsize=(9, 5.5), dpi=_DPI, layout="constrained")
        ax = figure.subplots()
        for name, values in curves.items():
            ax.plot(time, values / scale, label=name, linewidth=1.2)
        ax.set_xlabel(f"time ({unit_name('time', units)})")
        ax.set_ylabel(f"{label} ({unit})")
        text = f"{title}: {heading}" if title else heading
        ax.set_title("\n".join(textwrap.wrap(text, TITLE_WIDTH)), fontsize=11)
        ax.grid(True, linewidth=0.4, alpha=0.6)
        ax.legend(fontsize=8, loc="best")
        with atomic_path(path) as tmp:
            figure.savefig(tmp, format="png", dpi=_DPI)
