"""Output of runs: VTU + PVD for ParaView, CSV/JSON tables, PNG pictures.

The names below are loaded from their modules when first used (PEP 562), so that
``import dda.io.atomic`` (the checkpoints) or ``dda.io.fields`` (the command line)
does not import meshio; :mod:`dda.io.images` imports matplotlib only when a picture
is made.
"""

from __future__ import annotations

import importlib
from typing import Any

_MODULE_OF = {
    "atomic_path": "atomic",
    "write_bytes": "atomic",
    "write_text": "atomic",
    "render_frame": "images",
    "render_side_by_side": "images",
    "PvdIndex": "pvd",
    "read_pvd": "pvd",
    "RunWriter": "run_writer",
    "write_run": "run_writer",
    "to_jsonable": "tables",
    "write_history": "tables",
    "write_summary": "tables",
    "read_frame": "vtu",
    "write_blocks_vtu": "vtu",
    "write_bolts_vtu": "vtu",
    "write_contacts_vtu": "vtu",
}

__all__ = sorted(_MODULE_OF, key=str.lower)


def __getattr__(name: str) -> Any:
    """``dda.io.NAME``: the name from its module, imported now."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'dda.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"dda.io.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return list(__all__)
