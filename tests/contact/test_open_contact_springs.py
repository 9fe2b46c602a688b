"""An open contact adds no spring to K, even where the search distance spans blocks.

With a search distance of several block sizes (a large wall's default, or a large
``max_displacement_ratio``), the contact list holds vertex-edge pairings of blocks
two or three blocks apart. Such a contact starts open and stays open: its normal
force and its friction bound are zero (a gap has no bond, so no cohesion either),
so neither its normal nor its shear spring may enter K (a shear spring there would
join the two blocks in K and in its block pattern: a 100 x 100 wall rebuilt its
pattern every step, 19,800 -> 34,000 pairs).
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
import dda.contact.reach
import dda.solve.step as step
from dda.bench.scenes import wall_scene


@pytest.mark.parametrize("cohesion", [0.0, 10.0])
def test_contacts_a_block_apart_get_no_spring(monkeypatch, cohesion):
    """Also on cohesive joints: a contact found open has no bond (no cohesion)."""
    scene = wall_scene(6, steps=3)
    scene["analysis"]["max_displacement_ratio"] = 0.25  # search distance ≈ 3 blocks
    # every step searches as far as Shi's distance (a run narrows it to the blocks'
    # motion after its first step, dda.contact.reach)
    monkeypatch.setattr(dda.contact.reach, "FLOOR", 1.0)
    scene["joints"]["default"]["cohesion"] = cohesion
    seen = {"far": 0, "sprung": 0}
    original = step._PieceSystem.__call__

    def checked(self, kn, ks, offset_n, offset_t):
        apart = self.rows.penetration < -0.5  # a gap of half a block or more
        seen["far"] += int(apart.sum())
        seen["sprung"] += int(((kn > 0.0) | (ks > 0.0))[apart].sum())
        return original(self, kn, ks, offset_n, offset_t)

    monkeypatch.setattr(step._PieceSystem, "__call__", checked)
    result = dda.simulate(dda.load_scene(scene))
    assert result.summary["status"] == "finished"
    assert seen["far"] > 100  # the search distance did reach across blocks
    assert seen["sprung"] == 0


def test_one_block_pattern_for_a_settling_wall(monkeypatch):
    """The wall's contacts do not change which blocks touch: one pattern for the run."""
    scene = wall_scene(6, steps=5)
    scene["analysis"]["max_displacement_ratio"] = 0.25
    made = []
    original = step.LinearCache.pattern_for

    def recorded(self, *args, **kwargs):
        pattern = original(self, *args, **kwargs)
        if not made or made[-1].pairs is not pattern.pairs:
            made.append(pattern)
        return pattern

    monkeypatch.setattr(step.LinearCache, "pattern_for", recorded)
    dda.simulate(dda.load_scene(scene))
    assert len(made) == 1
    blocks_apart = np.abs(np.diff(made[0].pairs, axis=1)).max()
    assert blocks_apart <= 6 + 1  # neighbours in a row of 6 (and the diagonal ones)
