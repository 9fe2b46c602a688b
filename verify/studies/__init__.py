"""The suite's two convergence studies: the FEM against a closed form (convergence.py)
and a body cut into ever smaller DDA blocks against the continuum (refinement.py).
They use the FEM side (:mod:`verify.fem`)."""
