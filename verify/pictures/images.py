"""Pictures of the verification: which tool draws what.

- A static or fracture case (:func:`case_image`): the DDA blocks coloured by
  their constant stress and displacement beside the FEM field on its mesh, and
  the signed differences on a ± tolerance scale, rendered off screen with
  pyvista through EGL (:mod:`verify.pictures.field_pictures`).
- A motion case (:func:`case_image`): the DDA against its closed form and
  the errors against the time step, drawn with matplotlib.
- A dynamic case (:func:`case_image`), the summary bar chart and the
  block-refinement convergence plot: curves, drawn with matplotlib
  (:mod:`verify.pictures.plots`).

pyvista (and VTK) are imported only when a field picture is drawn.
"""

from __future__ import annotations

from pathlib import Path

from verify.harness.cases import CaseResult
from verify.pictures.plots import (
    history_picture,
    momentum_picture,
    motion_picture,
    refinement_chart,
    summary_chart,
)

__all__ = ["case_image", "case_title", "refinement_chart", "summary_chart"]


def case_image(result: CaseResult, path: Path) -> Path:
    """Write the picture of one case (PNG); returns the path."""
    title = case_title(result)
    if result.expectation.kind == "dynamic":
        return history_picture(result, title, path)
    if result.expectation.reference == "momentum":
        return momentum_picture(result, title, path)
    if result.expectation.kind == "motion":
        return motion_picture(result, title, path)
    from verify.pictures.field_pictures import state_picture

    return state_picture(result, title, path)


def case_title(result: CaseResult) -> str:
    """The name and verdict; a fracture case's onsets (second line); the components' frame."""
    title = f"{result.case.name}: {'PASS' if result.passed else 'FAIL'}"
    if result.expectation.kind == "fracture":
        onset, broke, nan = result.series["onset"], result.series["broke"], float("nan")
        title += f", the state before the break (load factor {result.series['factor_before']:.4g})"
        title += "".join(
            f"\n{n}: onset at load factor {f:.4g} (FEM), broke at {broke.get(n, nan):.4g} (DDA)"
            for n, f in onset.items()
        )
    e = result.expectation
    if e.fem_turn:
        title += f"; compared at rest, the scene turned by {e.fem_turn:.4g}° about {e.fem_about}"
    if result.expectation.frame:
        title += f"; components along a frame at {result.expectation.frame:g}°"
    return title
