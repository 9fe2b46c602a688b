"""The scene: the format a run is described in, and everything that reads it.

``format`` (the dataclasses and :func:`load_scene`), ``checks`` (the validation
toolkit), ``engineering`` (bolts, seismic input, water, measurement, stages),
``stability`` (``[fos]`` and ``[ensemble]``), ``presets`` (the accuracy presets),
``limits`` (the size limits checked before a run), ``stage_plan`` (the stages
resolved to scene rows) and ``rockmass`` (rock masses described by regions and joint
sets, cut into explicit blocks as the scene is loaded). Imports only the shared
vocabulary of :mod:`dda`.
"""

from dda.scene.format import (
    MAX_BLOCK_VERTICES,
    MAX_BLOCKS,
    Analysis,
    Block,
    ContactSettings,
    FractureSettings,
    Interface,
    Joint,
    Load,
    Material,
    Scene,
    Units,
    load_scene,
    read_scene_file,
)
from dda.scene.stability import Distribution, EnsembleSettings, FosSettings

__all__ = [
    "MAX_BLOCKS",
    "MAX_BLOCK_VERTICES",
    "Analysis",
    "Block",
    "ContactSettings",
    "FractureSettings",
    "Interface",
    "Joint",
    "Load",
    "Material",
    "Scene",
    "Units",
    "load_scene",
    "read_scene_file",
    "Distribution",
    "EnsembleSettings",
    "FosSettings",
]
