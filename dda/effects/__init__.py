"""Physical effects: one module per term of the potential energy.

An effect adds 6x6 blocks to the diagonal of K and 6-vectors to F
(docs/theory.md §3); ``build`` instantiates only the effects a scene needs.
"""
