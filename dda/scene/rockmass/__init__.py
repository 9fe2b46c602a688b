"""Rock masses from joint sets: Shi's block cutting.

A scene may describe the rock (``[[regions]]``), the joints that cut it
(``[[joint_sets]]``, ``[[joint_lines]]``) and the openings
(``[[excavations]]``) instead of listing block polygons. The scene loader
hands such a raw scene to :func:`expand_rock_mass`, which returns the same
scene with explicit ``[[blocks]]`` (see ``docs/rock_masses.md``).
"""

import importlib
from typing import Any

__all__ = ["ROCK_MASS_KEYS", "TRIGGER_KEYS", "CutRockMass", "cut_rock_mass", "expand_rock_mass"]


def __getattr__(name: str) -> Any:
    """The names of :mod:`dda.scene.rockmass.expand`, imported on first use (``dda cut`` loads
    this package to register itself; a run of an explicit scene never needs it)."""
    if name in __all__:
        return getattr(importlib.import_module("dda.scene.rockmass.expand"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
