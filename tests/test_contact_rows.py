"""Contact distance rows (paper eqs. 9-13): sign and derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet, merge
from dda.contact.rows import contact_rows, edge_projection
from dda.geometry import pack_polygons
from dda.kinematics import move_points


def two_blocks(top_offset: float) -> BlockSet:
    """A triangle whose lowest vertex sits ``top_offset`` above a square's top edge."""
    square = np.array([[0, 0], [2, 0], [2, 1], [0, 1]], float)
    tri = np.array([[1.0, 1.0 + top_offset], [1.5, 2.0], [0.5, 2.0]])
    v, o = pack_polygons([square, tri])
    z = np.zeros
    return BlockSet(
        ["s", "t"],
        np.array([0, 1]),
        np.array([0, 0]),
        v,
        o,
        np.full(len(v), -1),
        z((2, 6)),
        z((2, 3)),
        z(2),
        z((2, 2)),
        np.array([False, False]),
    )


def contact_of(blocks: BlockSet) -> ContactSet:
    vertex, edge = np.array([4]), np.array([2])  # triangle tip on the square's top edge
    d, t = edge_projection(blocks, vertex, edge)
    return merge(ContactSet.empty(), blocks, vertex, edge, d, 1.0, t, 1e-12)


@pytest.mark.parametrize("offset, sign", [(-0.01, 1.0), (0.01, -1.0)])
def test_penetration_is_positive_when_the_vertex_is_inside(offset, sign):
    blocks = two_blocks(offset)
    rows = contact_rows(blocks, contact_of(blocks))
    assert np.sign(rows.penetration[0]) == sign
    assert abs(rows.penetration[0]) == pytest.approx(0.01)


def test_rows_are_the_derivatives_of_the_distance():
    """d(D) = S0/l + E D_i + G D_j to first order for random small D.

    At a touching contact (S0 = 0): elsewhere the paper's linearisation also
    keeps the edge length l at its step-start value, an error of d·δl/l.
    """
    rng = np.random.default_rng(1)
    blocks = two_blocks(0.0)
    contacts = contact_of(blocks)
    rows = contact_rows(blocks, contacts)
    eps = 1e-7
    for _ in range(5):
        d = rng.normal(size=(2, 6)) * eps
        owner = blocks.vertex_owner
        moved = move_points(blocks.vertices, blocks.centroid[owner], d[owner], False)
        trial = BlockSet(**{**blocks.__dict__, "vertices": moved, "centroid": None})
        exact = edge_projection(trial, contacts.vertex, contacts.edge)[0][0]
        linear = rows.penetration[0] + rows.normal_i[0] @ d[1] + rows.normal_j[0] @ d[0]
        assert exact == pytest.approx(linear, abs=1e-12)
