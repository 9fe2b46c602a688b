"""One time step: the step's incremental potential minimised by Newton's method.

``step`` (the step's solve and its outer loop on the contact law), ``newton`` (Newton
with an exact line search and chord steps), ``assembly`` (K from 6x6 blocks),
``linsolve``, ``low_rank`` and ``pardiso_call`` (the linear solvers), ``integrator``
(the velocity update), ``update`` (applying an accepted step to the blocks) and
``timing`` (the stage timer). Imports the model, the contacts, the effects, the scene
and the shared vocabulary; not the time loop.
"""
