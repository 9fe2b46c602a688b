"""Block fracturing by the three-parameter Mohr–Coulomb criterion (paper §4).

``criterion``: which blocks fail and along which planes (eqs. 22–25).
``split``: cutting one polygon by lines through its centroid, safely.
``children``: the motion and stress the pieces inherit.
"""

from dda.fracture.children import children_state, velocity_at
from dda.fracture.criterion import (
    NONE,
    SHEAR,
    TENSION,
    FailureState,
    PrincipalStresses,
    evaluate,
    principal_stresses,
    strength_numbers,
)
from dda.fracture.split import SplitResult, split_polygon, split_polygon_detailed

__all__ = [
    "NONE",
    "SHEAR",
    "TENSION",
    "FailureState",
    "PrincipalStresses",
    "SplitResult",
    "children_state",
    "evaluate",
    "principal_stresses",
    "split_polygon",
    "split_polygon_detailed",
    "strength_numbers",
    "velocity_at",
]
