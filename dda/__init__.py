"""dda: two-dimensional Discontinuous Deformation Analysis of blocky rock.

Shi's DDA (six unknowns per block, elastic blocks, Coulomb joints, static and
dynamic analysis) with the augmented-Lagrangian contact and the
Mohr-Coulomb block fracturing of Lin, Amadei, Sture & Jung (1994).
"""

from importlib import metadata
from pathlib import Path

from dda.errors import SceneError, SimulationError
from dda.result import Contacts, FractureEvent, Frame, Result
from dda.scene import Scene, load_scene

try:
    __version__ = metadata.version("dda-rock")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"


def simulate(scene, progress: bool = False, **kwargs) -> Result:
    """Run a scene (``Scene``, path, TOML text or dict); see :func:`dda.run.simulation.run`.
    With ``progress=True`` a long rock-mass cut shows a bar too (:mod:`dda.run.cut_bar`)."""
    from dda.run.cut_bar import CutBar
    from dda.run.simulation import run

    if not isinstance(scene, Scene):
        if progress is True:
            with CutBar(scene.name if isinstance(scene, Path) else "scene") as bar:
                scene = load_scene(scene, progress=bar)
                bar.finish()
        else:
            scene = load_scene(scene)
    return run(scene, progress=progress, **kwargs)


__all__ = [
    "Contacts",
    "FractureEvent",
    "Frame",
    "Result",
    "Scene",
    "SceneError",
    "SimulationError",
    "__version__",
    "load_scene",
    "simulate",
]
