"""One case from its files to its verdicts: discover, run and judge (cases.py), each kind
run by its runner (runners.py: static, dynamic, fracture, motion) on the FEM side, the
closed-form references and the comparison."""
