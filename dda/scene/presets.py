"""Named accuracy presets: ``[analysis] accuracy = "fast" | "balanced" | "precise"``.

Taken from the Pareto fronts of ``dda tradeoff`` (docs/accuracy.md). A preset
fills in only what the scene leaves at the engine default; anything the
scene sets to another value wins, and the time step is always the scene's.

| preset | method | initial penalty | AL tolerance | g2 (max displacement ratio) |
|---|---|---|---|---|
| fast | penalty | 10 E | – | 0.02 |
| balanced | augmented Lagrangian | 10 E | 1e-4 × model size | 0.01 |
| precise | augmented Lagrangian | 10 E | 1e-6 × model size | 0.002 |

(E: the largest Young's modulus of the scene; model size: the largest extent
of the blocks.) "Left at the engine default" means equal to the default of
:class:`dda.scene.Analysis` / :class:`dda.scene.ContactSettings` (a scene
that writes the default value explicitly is treated as not giving it).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from dda.scene import Analysis, ContactSettings, Scene

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Preset:
    """Defaults one accuracy level sets (penalty and tolerance are relative)."""

    method: str
    penalty_factor: float  # × largest Young's modulus
    tolerance_fraction: float | None  # × model size (AL only)
    max_displacement_ratio: float


PRESETS: dict[str, Preset] = {
    "fast": Preset("penalty", 10.0, None, 0.02),
    "balanced": Preset("augmented-lagrangian", 10.0, 1e-4, 0.01),
    "precise": Preset("augmented-lagrangian", 10.0, 1e-6, 0.002),
}


def _default(cls, name: str):
    return next(f.default for f in dataclasses.fields(cls) if f.name == name)


def model_size(scene: Scene) -> float:
    """Largest extent of the blocks."""
    points = np.concatenate([np.asarray(b.vertices, float) for b in scene.blocks])
    return float(np.ptp(points, axis=0).max())


def apply_preset(scene: Scene) -> Scene:
    """The scene with its accuracy preset's defaults filled in (itself without one).

    Parameters
    ----------
    scene : a validated scene; ``scene.analysis.accuracy`` names the preset

    Returns
    -------
    Scene
        A new scene: contact method, penalty p = factor · E_max, AL tolerance
        = fraction · model size and ``max_displacement_ratio`` set where the
        scene left them at the default.
    """
    name = scene.analysis.accuracy
    if name is None:
        return scene
    preset = PRESETS[name]
    contact, analysis = scene.contact, scene.analysis
    changes: dict = {}
    if contact.method == _default(ContactSettings, "method"):
        changes["method"] = preset.method
    if contact.penalty is None:
        young = max(m.young for m in scene.materials.values())
        changes["penalty"] = preset.penalty_factor * young
    if contact.tolerance is None and preset.tolerance_fraction is not None:
        changes["tolerance"] = preset.tolerance_fraction * model_size(scene)
    ratio = analysis.max_displacement_ratio
    if ratio == _default(Analysis, "max_displacement_ratio"):
        analysis = dataclasses.replace(
            analysis, max_displacement_ratio=preset.max_displacement_ratio
        )
    log.info("accuracy preset %r: %s", name, changes)
    return dataclasses.replace(
        scene, contact=dataclasses.replace(contact, **changes), analysis=analysis
    )
