"""Block stacks standing: stick and slip, stacks and arches, energy, awkward geometry,
stiffness extremes and long motion, each run checked (checks.py); not dda/stability."""
