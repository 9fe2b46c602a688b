"""The closed forms of kind ``motion``, computed from the scene alone: what they share
(block.py), the motion cases and the free, slide and rocking references (motion.py),
water (water.py), impacts (impact.py), ground motion (shaking.py), a bolt (bolt.py),
collisions (collisions.py) and the augmented Lagrangian's rate (al_rate.py). They
return rows of :mod:`verify.comparison` and read the scene through :mod:`verify.fem`'s
geometry and interfaces."""
