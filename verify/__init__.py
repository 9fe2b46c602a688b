"""verify: the DDA's blocks re-solved with finite elements (scikit-fem), compared.

Pipeline per case (``cases/verify/NAME.toml`` + ``NAME.expect.toml``)::

    scene --dda.simulate--> DdaSide (final frame by scene block)
    scene --mesh_blocks--> BlockMesh --solve_fem (penalty contact on the
          interfaces the DDA closed)--> FemSolution
    compare(DdaSide, FemSolution) -> rows -> verdicts against the expectations
    images, report.md, report.json

``dda`` never imports ``verify``.
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
