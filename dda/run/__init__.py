"""The time loop and what surrounds it.

``simulation`` (the loop: contacts, step, step control, update, frames, events),
``equilibrium_start`` (the loaded start of a dynamic run), ``checkpoint``, ``stop``,
``progress``, ``environment``, ``stages`` (staged excavation applied to a run),
``measure`` (``[[measure]]``), ``energy`` (the energy account) and ``frames`` (a
frame of the run's state). Imports the step solve and everything below it; not the
commands.
"""
