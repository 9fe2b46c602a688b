"""Per-block quantities derived from a frame, shared by the VTU writer and the images.

Stresses are the block's constant stress ``(sxx, syy, sxy)``. Derived measures
(principal stresses and von Mises) use the in-plane components only:

.. math::

    \\sigma_{1,2} = \\frac{\\sigma_{xx} + \\sigma_{yy}}{2}
        \\pm \\sqrt{\\left(\\frac{\\sigma_{xx} - \\sigma_{yy}}{2}\\right)^2 + \\tau_{xy}^2},
    \\qquad
    \\sigma_{vM} = \\sqrt{\\sigma_{xx}^2 - \\sigma_{xx}\\sigma_{yy} + \\sigma_{yy}^2
        + 3\\tau_{xy}^2}

(von Mises with :math:`\\sigma_{zz} = 0`, i.e. plane stress).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dda.result import Frame


class ScalarInfo(NamedTuple):
    """How to show one per-block scalar: its label and whether it has a sign."""

    label: str
    signed: bool


SCALARS: dict[str, ScalarInfo] = {
    "sxx": ScalarInfo("stress xx", True),
    "syy": ScalarInfo("stress yy", True),
    "sxy": ScalarInfo("stress xy", True),
    "s1": ScalarInfo("major principal stress", True),
    "s2": ScalarInfo("minor principal stress", True),
    "von_mises": ScalarInfo("von Mises stress", False),
    "displacement": ScalarInfo("displacement", False),
    "velocity": ScalarInfo("speed", False),
    "rotation": ScalarInfo("rotation (rad)", True),
}


def stress_measures(stresses: np.ndarray) -> dict[str, np.ndarray]:
    """Stress components, principal stresses and von Mises stress of each block.

    Parameters
    ----------
    stresses
        ``(n, 3)`` array of ``sxx, syy, sxy``.

    Returns
    -------
    dict
        ``sxx, syy, sxy, s1, s2, von_mises``, each ``(n,)`` (``s1 >= s2``).
    """
    stresses = np.asarray(stresses, dtype=float).reshape(-1, 3)
    sxx, syy, sxy = stresses.T
    centre = 0.5 * (sxx + syy)
    radius = np.hypot(0.5 * (sxx - syy), sxy)
    von_mises = np.sqrt(np.maximum(sxx**2 - sxx * syy + syy**2 + 3.0 * sxy**2, 0.0))
    return {
        "sxx": sxx.copy(),
        "syy": syy.copy(),
        "sxy": sxy.copy(),
        "s1": centre + radius,
        "s2": centre - radius,
        "von_mises": von_mises,
    }


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
    return stress_measures(frame.stresses)[name]


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
