"""``[[interfaces]]`` overrides follow a block's fragments after it breaks."""

from __future__ import annotations

import numpy as np

import dda
from dda.contact.contact_set import ContactSet
from dda.fracture.fragments import Fragments, replace_blocks
from dda.model import build
from tests.helpers import ROCK, rectangle


def scene() -> dda.Scene:
    return dda.load_scene(
        {
            "analysis": {"time_step": 0.001, "steps": 1},
            "materials": {"rock": ROCK},
            "joints": {
                "default": {"friction_angle": 30.0},
                "smooth": {"friction_angle": 5.0},
                "crack": {"friction_angle": 40.0},
            },
            "fracture": {"joint": "crack"},
            "blocks": [
                {"name": "slider", "material": "rock", "vertices": rectangle(0, 0, 2, 0.5)},
                {
                    "name": "base",
                    "material": "rock",
                    "vertices": rectangle(-1, -1, 3, 0),
                    "fixed": True,
                },
            ],
            "interfaces": [{"blocks": ["slider", "base"], "joint": "smooth"}],
        }
    )


def test_fragments_meet_the_base_through_the_interface_and_each_other_through_the_crack():
    model = build(scene())
    table = model.contact.joints
    crack = table.names.index("crack")
    halves = [np.array(rectangle(0, 0, 1, 0.5)), np.array(rectangle(1, 0, 2, 0.5))]
    pieces = Fragments.of(
        model.blocks, 0, halves, ("slider/1", "slider/2"), np.array([2, 3]), crack
    )
    blocks = replace_blocks(model.blocks, [pieces])
    assert blocks.names == ["base", "slider/1", "slider/2"]
    base_edge = int(blocks.offsets[0])  # the base's bottom edge: no joint of its own
    left_crack_edge = int(blocks.offsets[1]) + 1  # slider/1's right side (x = 1), the crack
    empty = ContactSet.empty()
    contacts = ContactSet(**{k: np.zeros(3, a.dtype) for k, a in vars(empty).items()})
    contacts.block_a[:] = [1, 2, 2]
    contacts.block_b[:] = [0, 0, 1]
    contacts.edge[:] = [base_edge, base_edge, left_crack_edge]
    rows = table.rows_for(blocks, contacts)
    assert [table.names[r] for r in rows] == ["smooth", "smooth", "crack"]
