"""Stability: the factor of safety by strength reduction and the probability of failure.

``criterion`` (when a trial fails), ``strength_reduction`` (the scene with its
strengths divided by F), ``trial`` (one run, on any worker), ``search`` (the bracket
and its bisection), ``store`` (finished trials on disk, reused by a rerun), ``report``
(the tables and pictures), ``sampling`` and ``ensemble`` (the realisations of a scene
with random values, and P(failure) with its interval). Runs go through
:mod:`dda.parallel`; the method is in docs/stability.md.
"""
