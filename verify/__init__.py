"""verify: the DDA's blocks re-solved with finite elements (scikit-fem), compared.

Pipeline per case (``cases/verify/NAME.toml`` + ``NAME.expect.toml``)::

    scene --dda.simulate--> DdaSide (a frame by scene block, strains from vertices)
    scene --mesh_blocks--> BlockMesh --solve_fem (penalty contact on every
          interface of the scene, its own open/closed and stick/slip states)
          --> FemSolution   (dynamic cases: verify.dynamics.integrate;
                             fracture cases: verify.fracture.onset_factors)
    rows (signed: DDA - FEM - predicted offset) -> verdicts against the expectations
    block-refinement study (verify.refinement), FEM convergence study
    images, report.md, report.json

The FEM side reads the scene only; ``verify`` uses the engine's public API
(``dda.load_scene``, ``dda.simulate``, the scene and result types). ``dda``
never imports ``verify``.
"""

from verify.cases import CaseResult, discover, run_case
from verify.fem import FemOptions, FemSolution, solve_fem
from verify.mesh import BlockMesh, mesh_blocks
from verify.suite import run_suite

__all__ = [
    "BlockMesh",
    "CaseResult",
    "FemOptions",
    "FemSolution",
    "discover",
    "mesh_blocks",
    "run_case",
    "run_suite",
    "solve_fem",
]
