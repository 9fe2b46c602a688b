"""The terms of every comparison: what a case expects (expect.py), the DDA run read by
scene block (dda_side.py) and the compared numbers, DDA against the FEM (compare.py:
:class:`~verify.comparison.compare.Row` and its frames). The closed-form references,
the harness and the pictures build on them; they use the FEM side only."""
