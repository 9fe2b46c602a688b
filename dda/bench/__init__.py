"""Performance benchmarks (results and how they were made: docs/benchmarks.md).

The standard scene (:func:`dda.bench.scenes.wall_scene`): a fixed base block
[0, n+4] x [0, 1] with an n x n grid of 1 x 1 blocks on it (edges exactly shared),
density 2.6, E = 1e6, ν = 0.25, 30° friction, penalty 5e7, Δt = 1e-3 s, dynamic,
100 steps, every spring unloaded at t = 0 (as the C DDA code's).

* ``dda bench`` (:mod:`dda.commands.bench`): sizes 5 10 20 30 50 100, each in its
  own process (:mod:`dda.bench.run`), a Markdown table; every size's wall checked
  first, its scene and its estimated memory (:mod:`dda.bench.limits`);
* ``python -m dda.bench.stages 5 10 30``: one stage of a step, several
  implementations;
* ``python -m dda.bench.contact_methods``: penalty against augmented Lagrangian on
  the contact cases (docs/contact_table.md);
* a profile: ``python -m cProfile -s cumtime -m dda.bench.run 30 30 penalty 100``.
"""
