"""verify: the DDA's blocks re-solved with finite elements (scikit-fem), compared.

Pipeline per case (``cases/verify/NAME.toml`` + ``NAME.expect.toml``)::

    scene --dda.simulate--> DdaSide (a frame by scene block, strains from vertices)
    scene --mesh_blocks--> BlockMesh --solve_fem (penalty contact on every
          interface of the scene, its own open/closed and stick/slip states)
          --> FemSolution   (dynamic cases: verify.fem.dynamics.integrate;
                             fracture cases: verify.fem.fracture.onset_factors)
    rows (signed: DDA - FEM - predicted offset) -> verdicts against the expectations
    block-refinement study (verify.studies.refinement), FEM convergence study
    images, report.md, report.json

The FEM side reads the scene only; ``verify`` uses the engine's public API
(``dda.load_scene``, ``dda.simulate``, the scene and result types). ``dda``
never imports ``verify``.

Its folders, each importing only those above it in this list: ``fem/`` (the FEM
side), ``studies/`` (the convergence and block-refinement studies), ``comparison/``
(expectations, the DDA side, rows), ``references/`` (the closed forms of kind
``motion``), ``harness/`` (a case: discover, run by kind, judge), ``pictures/``; then
``report.py``, ``suite.py`` and ``cli.py`` (``dda verify``, ``python -m verify``).
"""

import importlib
from typing import Any

_WHERE = {
    "BlockMesh": "verify.fem.mesh",
    "CaseResult": "verify.harness.cases",
    "FemOptions": "verify.fem.statics",
    "FemSolution": "verify.fem.statics",
    "discover": "verify.harness.cases",
    "mesh_blocks": "verify.fem.mesh",
    "run_case": "verify.harness.cases",
    "run_suite": "verify.suite",
    "solve_fem": "verify.fem.statics",
}
__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    """The public names, imported on first use (``dda`` loads ``verify.cli`` for every
    command to register ``dda verify``; scikit-fem is needed only when it runs)."""
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
