"""dda: two-dimensional Discontinuous Deformation Analysis of blocky rock.

Shi's DDA (six unknowns per block, elastic blocks, Coulomb joints, static and
dynamic analysis) with the augmented-Lagrangian contact and the
Mohr-Coulomb block fracturing of Lin, Amadei, Sture & Jung (1994).
"""

from dda.errors import SceneError, SimulationError
from dda.result import Contacts, FractureEvent, Frame, Result
from dda.scene import Scene, load_scene


def simulate(scene, progress: bool = False, **kwargs) -> Result:
    """Run a scene (``Scene``, path, TOML text or dict); see :func:`dda.simulation.run`."""
    from dda.simulation import run

    if not isinstance(scene, Scene):
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
    "load_scene",
    "simulate",
]
