"""Per-block quantities derived from a frame, shared by the VTU writer and the images.

Stresses are the block's constant stress ``(sxx, syy, sxy)``. The principal stresses
are the in-plane ones; von Mises takes the out-of-plane stress σzz too, ν (σxx + σyy)
in a plane-strain scene (the frame's ``out_of_plane``), 0 in plane stress:

.. math::

    \\sigma_{1,2} = \\frac{\\sigma_{xx} + \\sigma_{yy}}{2}
        \\pm \\sqrt{\\left(\\frac{\\sigma_{xx} - \\sigma_{yy}}{2}\\right)^2 + \\tau_{xy}^2},
    \\qquad
    \\sigma_{vM} = \\sqrt{\\tfrac12\\left[(\\sigma_{xx} - \\sigma_{yy})^2
        + (\\sigma_{yy} - \\sigma_{zz})^2 + (\\sigma_{zz} - \\sigma_{xx})^2\\right]
        + 3\\tau_{xy}^2}
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from dda.result import Frame


class ScalarInfo(NamedTuple):
    """How to show one per-block scalar: its label, whether it has a sign, its dimension."""

    label: str
    signed: bool
    dimension: str  # "stress", "length", "velocity" or "angle"


SCALARS: dict[str, ScalarInfo] = {
    "sxx": ScalarInfo("stress xx", True, "stress"),
    "syy": ScalarInfo("stress yy", True, "stress"),
    "sxy": ScalarInfo("stress xy", True, "stress"),
    # tension positive: s1 >= s2, so s1 is the least compressive (rock mechanics' σ3) and
    # s2 the most compressive (its σ1); the labels say so, not "major" / "minor"
    "s1": ScalarInfo("principal stress s1, the least compressive", True, "stress"),
    "s2": ScalarInfo("principal stress s2, the most compressive", True, "stress"),
    "von_mises": ScalarInfo("von Mises stress", False, "stress"),
    "displacement": ScalarInfo("displacement", False, "length"),
    "velocity": ScalarInfo("speed", False, "velocity"),
    "rotation": ScalarInfo("rotation", True, "angle"),
}


def unit_name(dimension: str, units: Mapping[str, str] | None = None) -> str:
    """The unit of a dimension in a scene's ``[units]`` (SI where not given).

    ``force_per_length`` is the unit of a force in this 2-D model (contact forces, bolt
    tensions): per unit thickness of the section, ``N/m``.

    >>> unit_name("stress", {"length": "ft", "force": "lb"})
    'lb/ft²'
    >>> unit_name("force_per_length")
    'N/m'
    """
    from dda.scene import Units

    scene_units = Units(**{k: v for k, v in (units or {}).items() if k in _UNIT_KEYS})
    return {
        "force_per_length": f"{scene_units.force}/{scene_units.length}",
        "stress": scene_units.stress,
        "length": scene_units.length,
        "velocity": scene_units.velocity,
        "force": scene_units.force,
        "energy": scene_units.energy,
        "time": scene_units.time,
        "angle": "rad",
    }[dimension]


_UNIT_KEYS = ("length", "force", "time")
PREFIXED = ("Pa", "N", "J")  # SI units shown with k, M or G when their numbers are large
PREFIXES = {0: "", 3: "k", 6: "M", 9: "G"}


def engineering_scale(magnitude: float, unit: str) -> tuple[float, str]:
    """Divisor and name of the unit to show numbers up to ``magnitude`` in.

    SI units of :data:`PREFIXED` (alone or over a length: ``N/m``) take the prefix k, M
    or G that leaves at most three digits before the point; other units (and small
    numbers) are kept.

    >>> engineering_scale(1.6e6, "Pa")
    (1000000.0, 'MPa')
    >>> engineering_scale(5450.0, "N/m")
    (1000.0, 'kN/m')
    >>> engineering_scale(1.6e6, "lb/ft²")
    (1.0, 'lb/ft²')
    """
    base = unit.split("/", 1)[0]  # N/m: the prefix goes on the N
    if base not in PREFIXED or not np.isfinite(magnitude) or magnitude < 1e3:
        return 1.0, unit
    exponent = min(9, 3 * int(np.floor(np.log10(magnitude) / 3)))
    return 10.0**exponent, PREFIXES[exponent] + unit


def stress_measures(
    stresses: np.ndarray, out_of_plane: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Stress components, principal stresses and von Mises stress of each block.

    Parameters
    ----------
    stresses
        ``(n, 3)`` array of ``sxx, syy, sxy``.
    out_of_plane
        ``(n,)`` szz (plane strain: ν (sxx + syy)); None for plane stress (szz = 0).

    Returns
    -------
    dict
        ``sxx, syy, sxy, s1, s2, von_mises``, each ``(n,)`` (``s1 >= s2``), and ``szz``
        when ``out_of_plane`` is given.

    >>> float(stress_measures([[-2.0, -2.0, 0.0]])["von_mises"][0])
    2.0
    >>> float(stress_measures([[-2.0, -2.0, 0.0]], [-1.0])["von_mises"][0])
    1.0
    """
    stresses = np.asarray(stresses, dtype=float).reshape(-1, 3)
    sxx, syy, sxy = stresses.T
    szz = np.zeros_like(sxx) if out_of_plane is None else np.asarray(out_of_plane, float)
    centre = 0.5 * (sxx + syy)
    radius = np.hypot(0.5 * (sxx - syy), sxy)
    squares = (sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2
    von_mises = np.sqrt(np.maximum(0.5 * squares + 3.0 * sxy**2, 0.0))
    measures = {
        "sxx": sxx.copy(),
        "syy": syy.copy(),
        "sxy": sxy.copy(),
        "s1": centre + radius,
        "s2": centre - radius,
        "von_mises": von_mises,
    }
    if out_of_plane is not None:
        measures["szz"] = szz.copy()
    return measures


def scalar_field(frame: Frame, name: str) -> np.ndarray:
    """One value per block for colouring: a stress measure or a magnitude.

    Parameters
    ----------
    frame
        The frame.
    name
        A key of :data:`SCALARS`: ``sxx, syy, sxy, s1, s2, von_mises``,
        ``displacement`` (centroid displacement magnitude), ``velocity``
        (centroid speed) or ``rotation``.

    Returns
    -------
    numpy.ndarray
        ``(n,)`` floats.
    """
    if name not in SCALARS:
        raise ValueError(f"unknown scalar {name!r}; choose one of {', '.join(SCALARS)}")
    if name == "displacement":
        return np.hypot(*np.asarray(frame.displacements, float).reshape(-1, 2).T)
    if name == "velocity":
        return np.hypot(*np.asarray(frame.velocities, float).reshape(-1, 3)[:, :2].T)
    if name == "rotation":
        return np.asarray(frame.rotations, dtype=float).copy()
    return stress_measures(frame.stresses, frame.out_of_plane)[name]


def as_3d(vectors: np.ndarray) -> np.ndarray:
    """Pad ``(n, 2)`` vectors or points with a zero third component.

    Parameters
    ----------
    vectors
        ``(n, 2)`` array.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` float array with ``z = 0``.
    """
    vectors = np.asarray(vectors, dtype=float).reshape(-1, 2)
    return np.column_stack([vectors, np.zeros(len(vectors))])
