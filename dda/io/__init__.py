"""Output of runs: VTU + PVD for ParaView, CSV/JSON tables, PNG pictures.

The light parts (VTU, tables, the run writer) import meshio and numpy only;
:mod:`dda.io.images` imports matplotlib only when a picture is made.
"""

from dda.io.atomic import atomic_path, write_bytes, write_text
from dda.io.images import render_frame, render_side_by_side
from dda.io.pvd import PvdIndex, read_pvd
from dda.io.run_writer import RunWriter, write_run
from dda.io.tables import to_jsonable, write_history, write_summary
from dda.io.vtu import read_frame, write_blocks_vtu, write_contacts_vtu

__all__ = [
    "PvdIndex",
    "RunWriter",
    "atomic_path",
    "read_frame",
    "read_pvd",
    "render_frame",
    "render_side_by_side",
    "to_jsonable",
    "write_blocks_vtu",
    "write_bytes",
    "write_contacts_vtu",
    "write_history",
    "write_run",
    "write_summary",
    "write_text",
]
