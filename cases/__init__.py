"""The scene files shipped with dda, as package data (``dda.cases``).

In a source tree they are the ``cases/`` folder; installed, they live inside
the package and are read with :mod:`importlib.resources`, so they work from a
wheel as from a clone. ``cases/verify`` holds the verification suite's scenes
and expectations (:mod:`verify.harness.cases`).

>>> import dda, dda.cases
>>> scene = dda.load_scene(dda.cases.text("sliding_block"))
"""

from __future__ import annotations

from importlib.resources import files
from importlib.resources.abc import Traversable


def folder(subfolder: str = "") -> Traversable:
    """The folder of the shipped scene files (``"verify"``: the verification cases)."""
    root = files(__name__)
    return root.joinpath(subfolder) if subfolder else root


def names() -> list[str]:
    """Names of the shipped scenes (file names without ``.toml``), sorted."""
    return sorted(
        f.name.removesuffix(".toml") for f in folder().iterdir() if f.name.endswith(".toml")
    )


def text(name: str) -> str:
    """The TOML text of the shipped scene ``name`` (as :func:`dda.load_scene` takes it).

    Raises
    ------
    KeyError
        No shipped scene has that name.
    """
    entry = folder().joinpath(f"{name}.toml")
    if not entry.is_file():
        raise KeyError(f"no shipped scene {name!r}; shipped: {', '.join(names())}")
    return entry.read_text(encoding="utf-8")
