"""Rock masses from joint sets: Shi's block cutting.

A scene may describe the rock (``[[regions]]``), the joints that cut it
(``[[joint_sets]]``, ``[[joint_lines]]``) and the openings
(``[[excavations]]``) instead of listing block polygons. The scene loader
hands such a raw scene to :func:`expand_rock_mass`, which returns the same
scene with explicit ``[[blocks]]`` (see ``docs/rock_masses.md``).
"""

from dda.rockmass.expand import (
    ROCK_MASS_KEYS,
    TRIGGER_KEYS,
    CutRockMass,
    cut_rock_mass,
    expand_rock_mass,
)

__all__ = ["ROCK_MASS_KEYS", "TRIGGER_KEYS", "CutRockMass", "cut_rock_mass", "expand_rock_mass"]
