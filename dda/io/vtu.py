"""One VTU file per frame (meshio): the blocks as polygons, the contacts as points.

Blocks file: 3-D points (``z = 0``), one cell per block. meshio keeps one cell
block per vertex count (``triangle``, ``quad``, ``polygon`` of k vertices), so
the cells are grouped by vertex count; the ``row`` cell array gives each
cell's row in the frame and ``block_id`` its stable id. Cell arrays:
``row, block_id, fixed, area, rotation, omega, centroid, velocity,
displacement`` (vectors with ``z = 0``) and the stress measures of
:func:`dda.io.fields.stress_measures` (``sxx, syy, sxy, s1, s2, von_mises``; ``szz``, the
out-of-plane stress, in a plane-strain scene).

Contacts file: one ``vertex`` cell per contact point, point arrays
``normal_force, shear_force, penetration, state`` (0 open, 1 sliding,
2 locked), ``block_a, block_b`` (block ids), ``normal`` and
``normal_force_vector`` (``normal_force * normal``, the normal force on
``block_a``). A frame without contacts gives a file with no points and one
empty ``polygon`` cell, written without compression: meshio 5.3 reads
neither a grid without cells nor an empty compressed array, and this is the
empty grid that meshio, pyvista and ParaView all read.

Bolts file (a scene with ``[[bolts]]``): one ``line`` cell per rock bolt, from its
start to its end point in place, cell array ``bolt`` (its row). A frame with no bolt
in place (before a stage installs them, after all broke) gives a file with no points and
one empty ``polygon`` cell of ``bolt`` -1, as an empty contacts file.
"""

from __future__ import annotations

import os
from pathlib import Path

import meshio
import numpy as np

from dda.io.atomic import atomic_path
from dda.io.fields import as_3d, stress_measures
from dda.result import Contacts, Frame

CELL_TYPES = {3: "triangle", 4: "quad"}  # any other count: "polygon"


def blocks_mesh(frame: Frame) -> meshio.Mesh:
    """The blocks of ``frame`` as a meshio mesh, one cell per block.

    Parameters
    ----------
    frame
        The frame.

    Returns
    -------
    meshio.Mesh
        Cells grouped by vertex count; cell data as described in the module
        docstring, in the same (grouped) order.
    """
    counts = np.array([len(v) for v in frame.vertices], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    points = as_3d(np.concatenate(frame.vertices) if len(counts) else np.zeros((0, 2)))
    per_block = _block_cell_data(frame)
    cells, cell_data = [], {name: [] for name in per_block}
    for count in np.unique(counts):
        rows = np.flatnonzero(counts == count)
        connectivity = starts[rows, None] + np.arange(count)
        cells.append((CELL_TYPES.get(int(count), "polygon"), connectivity))
        for name, values in per_block.items():
            cell_data[name].append(values[rows])
    return meshio.Mesh(points, cells, cell_data=cell_data)


def _block_cell_data(frame: Frame) -> dict[str, np.ndarray]:
    n = len(frame.vertices)
    velocities = np.asarray(frame.velocities, dtype=float).reshape(n, 3)
    data = {
        "row": np.arange(n, dtype=np.int64),
        "block_id": np.asarray(frame.ids, dtype=np.int64).reshape(n),
        "fixed": np.asarray(frame.fixed, dtype=np.uint8).reshape(n),
        "area": np.asarray(frame.areas, dtype=float).reshape(n),
        "rotation": np.asarray(frame.rotations, dtype=float).reshape(n),
        "omega": velocities[:, 2].copy(),
        "centroid": as_3d(frame.centroids),
        "velocity": as_3d(velocities[:, :2]),
        "displacement": as_3d(frame.displacements),
    }
    data.update(stress_measures(frame.stresses, frame.out_of_plane))
    return data


def contacts_mesh(frame: Frame) -> meshio.Mesh:
    """The contacts of ``frame`` as a meshio mesh of vertex cells.

    Parameters
    ----------
    frame
        The frame; block rows in its contacts are written as block ids.

    Returns
    -------
    meshio.Mesh
        One point and one ``vertex`` cell per contact, with point data.
    """
    c = frame.contacts
    m = len(c)
    ids = np.asarray(frame.ids, dtype=np.int64)
    normals = np.asarray(c.normals, dtype=float).reshape(m, 2)
    normal_force = np.asarray(c.normal_force, dtype=float).reshape(m)
    point_data = {
        "normal_force": normal_force,
        "shear_force": np.asarray(c.shear_force, dtype=float).reshape(m),
        "penetration": np.asarray(c.penetration, dtype=float).reshape(m),
        "state": np.asarray(c.state, dtype=np.int8).reshape(m),
        "block_a": ids[np.asarray(c.block_a, dtype=np.int64)],
        "block_b": ids[np.asarray(c.block_b, dtype=np.int64)],
        "normal": as_3d(normals),
        "normal_force_vector": as_3d(normals * normal_force[:, None]),
    }
    if m == 0:
        cells = [("polygon", np.zeros((1, 0), dtype=np.int64))]  # see the module docstring
    else:
        cells = [("vertex", np.arange(m, dtype=np.int64).reshape(m, 1))]
    return meshio.Mesh(as_3d(c.points), cells, point_data=point_data)


def write_mesh(mesh: meshio.Mesh, path: str | os.PathLike[str]) -> Path:
    """Write a meshio mesh to a ``.vtu`` file atomically (binary, zlib).

    Parameters
    ----------
    mesh
        The mesh.
    path
        Destination; its directory must exist.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    compression = "zlib" if len(mesh.points) else None  # meshio reads no empty zlib array
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu", compression=compression)
    return path


def write_blocks_vtu(frame: Frame, path: str | os.PathLike[str]) -> Path:
    """Write the blocks of ``frame`` to ``path`` (see :func:`blocks_mesh`)."""
    return write_mesh(blocks_mesh(frame), path)


def write_contacts_vtu(frame: Frame, path: str | os.PathLike[str]) -> Path:
    """Write the contacts of ``frame`` to ``path`` (see :func:`contacts_mesh`)."""
    return write_mesh(contacts_mesh(frame), path)


def bolts_mesh(frame: Frame) -> meshio.Mesh:
    """The rock bolts of ``frame`` (its ``bolts``, not None) as a meshio mesh: one
    ``line`` cell a bolt, from its start to its end point, cell arrays ``bolt`` (its index
    among the scene's bolts, ``Frame.bolt_ids``: the same bolt in every file of a run; its
    row where the frame has no ids) and ``tension`` (its tension, the scene's force unit;
    NaN where the frame has none)."""
    ends = np.asarray(frame.bolts, dtype=float).reshape(-1, 2, 2)
    count = len(ends)
    if count == 0:  # see the module docstring
        cells = [("polygon", np.zeros((1, 0), dtype=np.int64))]
        no_bolt = {"bolt": [np.array([-1], dtype=np.int64)], "tension": [np.array([np.nan])]}
        return meshio.Mesh(np.zeros((0, 3)), cells, cell_data=no_bolt)
    lines = np.arange(2 * count, dtype=np.int64).reshape(count, 2)
    tension = np.full(count, np.nan)
    if frame.bolt_tensions is not None:
        tension = np.asarray(frame.bolt_tensions, dtype=float)
    ids = np.arange(count) if frame.bolt_ids is None else np.asarray(frame.bolt_ids)
    cell_data = {"bolt": [ids.astype(np.int64)], "tension": [tension]}
    return meshio.Mesh(as_3d(ends.reshape(-1, 2)), [("line", lines)], cell_data=cell_data)


def write_bolts_vtu(frame: Frame, path: str | os.PathLike[str]) -> Path:
    """Write the rock bolts of ``frame`` to ``path`` (see :func:`bolts_mesh`)."""
    return write_mesh(bolts_mesh(frame), path)


def read_frame(
    blocks_path: str | os.PathLike[str],
    contacts_path: str | os.PathLike[str] | None = None,
    time: float = float("nan"),
    step: int = -1,
    bolts_path: str | os.PathLike[str] | None = None,
) -> Frame:
    """Rebuild a :class:`~dda.result.Frame` from files written by this module.

    Parameters
    ----------
    blocks_path
        A blocks ``.vtu`` file.
    contacts_path
        The matching contacts ``.vtu`` file, if any.
    time, step
        Frame time and step (VTU files do not carry them; the PVD index does).
    bolts_path
        The matching bolts ``.vtu`` file (a scene with ``[[bolts]]``), if any: the
        frame's ``bolts``.

    Returns
    -------
    Frame
        Rows in the original order. Block names are not stored in VTU files:
        they come back as ``"#<id>"``.
    """
    mesh = _read_vtu(blocks_path)
    data = {name: np.concatenate(parts) for name, parts in mesh.cell_data.items()}
    vertices = [mesh.points[cell, :2] for block in mesh.cells for cell in block.data]
    order = np.argsort(data["row"], kind="stable")
    data = {name: values[order] for name, values in data.items()}
    ids = data["block_id"].astype(np.int64)
    stresses = np.column_stack([data["sxx"], data["syy"], data["sxy"]])
    velocities = np.column_stack([data["velocity"][:, :2], data["omega"]])
    return Frame(
        time=float(time),
        step=int(step),
        names=tuple(f"#{i}" for i in ids),
        ids=ids,
        centroids=data["centroid"][:, :2].copy(),
        rotations=data["rotation"].astype(float),
        velocities=velocities,
        stresses=stresses,
        displacements=data["displacement"][:, :2].copy(),
        vertices=[vertices[k] for k in order],
        areas=data["area"].astype(float),
        fixed=data["fixed"].astype(bool),
        contacts=_read_contacts(contacts_path, ids) if contacts_path else Contacts.empty(),
        out_of_plane=data["szz"].astype(float) if "szz" in data else None,
        **_read_bolts(bolts_path),
    )


def _read_bolts(path: str | os.PathLike[str] | None) -> dict:
    """The frame's ``bolts``, (b, 2, 2) bolt ends from a file of :func:`write_bolts_vtu`
    ((0, 2, 2): no bolt in place; None without a file), ``bolt_tensions`` (None from
    a file written without them) and ``bolt_ids`` (the cell array ``bolt``)."""
    if not path or not Path(path).is_file():
        return {"bolts": None, "bolt_tensions": None, "bolt_ids": None}
    mesh = _read_vtu(path)
    kept = [k for k, block in enumerate(mesh.cells) if block.type == "line"]
    if not kept:
        tensions = np.zeros(0) if "tension" in mesh.cell_data else None
        none = np.zeros(0, np.int64)
        return {"bolts": np.zeros((0, 2, 2)), "bolt_tensions": tensions, "bolt_ids": none}
    lines = np.concatenate([mesh.cells[k].data for k in kept])
    ids = np.concatenate([mesh.cell_data["bolt"][k] for k in kept]).astype(np.int64)
    order = np.argsort(ids, kind="stable")
    tensions = None
    if "tension" in mesh.cell_data:
        tensions = np.concatenate([mesh.cell_data["tension"][k] for k in kept])[order]
    bolts = mesh.points[lines[order], :2].copy()
    return {"bolts": bolts, "bolt_tensions": tensions, "bolt_ids": ids[order]}


def _read_contacts(path: str | os.PathLike[str], ids: np.ndarray) -> Contacts:
    if not Path(path).is_file():
        return Contacts.empty()
    mesh = _read_vtu(path)
    d = mesh.point_data
    return Contacts(
        block_a=_rows_of(ids, d["block_a"]),
        block_b=_rows_of(ids, d["block_b"]),
        points=mesh.points[:, :2].copy(),
        normals=d["normal"][:, :2].copy(),
        normal_force=d["normal_force"].astype(float),
        shear_force=d["shear_force"].astype(float),
        penetration=d["penetration"].astype(float),
        state=d["state"].astype(np.int8),
    )


def _rows_of(ids: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Rows of ``ids`` holding each of ``wanted`` (all present)."""
    sorter = np.argsort(ids)
    return sorter[np.searchsorted(ids, wanted, sorter=sorter)].astype(np.int64)


def _read_vtu(path: str | os.PathLike[str]) -> meshio.Mesh:
    """meshio's VTU reader itself: ``meshio.read`` prints a failure and calls ``sys.exit``."""
    return meshio.vtu.read(os.fspath(path))
