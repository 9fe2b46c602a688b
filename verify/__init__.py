"""verify: the DDA's blocks re-solved with finite elements (scikit-fem), compared.

Pipeline per case (``cases/verify/NAME.toml`` + ``NAME.expect.toml``)::

    scene --dda.simulate--> DdaSide (final frame by scene block)
    scene --mesh_blocks--> BlockMesh --solve_fem (penalty contact on the
          interfaces the DDA closed)--> FemSolution
    compare(DdaSide, FemSolution) -> rows -> verdicts against the expectations
    images, report.md, report.json

``dda`` never imports ``verify``.
"""

import importlib
from typing import Any

_WHERE = {
    "BlockMesh": "verify.mesh",
    "CaseResult": "verify.cases",
    "FemOptions": "verify.fem",
    "FemSolution": "verify.fem",
    "discover": "verify.cases",
    "mesh_blocks": "verify.mesh",
    "run_case": "verify.cases",
    "run_suite": "verify.suite",
    "solve_fem": "verify.fem",
}
__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    """The public names, imported on first use (``dda`` loads ``verify.cli`` for every
    command to register ``dda verify``; scikit-fem is needed only when it runs)."""
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
