"""dda: two-dimensional Discontinuous Deformation Analysis of blocky rock.

Shi's DDA (six unknowns per block, elastic blocks, Coulomb joints, static and
dynamic analysis) with the augmented-Lagrangian contact and the
Mohr-Coulomb block fracturing of Lin, Amadei, Sture & Jung (1994).
"""

from collections.abc import Callable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

from dda.errors import SceneError, SimulationError
from dda.result import Contacts, FractureEvent, Frame, Result
from dda.scene import Scene, load_scene

try:
    __version__ = metadata.version("dda-rock")
except metadata.PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"


def simulate(
    scene: Scene | Path | str | Mapping[str, Any],
    progress: bool | Callable[[float, dict], None] = False,
    on_frame: Callable[[Frame], None] | None = None,
    *,
    keep_frames: bool = True,
    stop: Callable[[], bool] | None = None,
    checkpoints: Any = None,
    resume: Any = None,
) -> Result:
    """Run a scene (``Scene``, path, TOML text or dict) to its end.

    ``progress``: True for a bar on stderr (a long rock-mass cut's too,
    :mod:`dda.run.cut_bar`), or a callable(fraction, info); ``on_frame``: called with
    every kept frame; ``keep_frames``: False keeps only the first and the latest in the
    Result; ``stop``: asked before every step, True ends the run "interrupted";
    ``checkpoints``: a :class:`dda.run.checkpoint.CheckpointPlan`; ``resume``: a
    :class:`dda.run.checkpoint.Checkpoint` of this scene to go on from. The parameters
    and what they raise: :func:`dda.run.simulation.run`."""
    from dda.run.cut_bar import CutBar
    from dda.run.simulation import run

    if not isinstance(scene, Scene):
        if progress is True:
            with CutBar(scene.name if isinstance(scene, Path) else "scene") as bar:
                scene = load_scene(scene, progress=bar)
                bar.finish()
        else:
            scene = load_scene(scene)
    options = {"keep_frames": keep_frames, "stop": stop, "checkpoints": checkpoints}
    return run(scene, progress, on_frame, resume=resume, **options)


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
