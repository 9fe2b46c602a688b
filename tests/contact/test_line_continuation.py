"""The lines a vertex moved along last step (dda.contact.line_continuation): the edges it
slid along, and its own edges under which a corner slid, where that corner is at the
vertex."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.contact.line_continuation import LastStep, continues_moved_line, previous_partners
from dda.model import build
from tests.helpers import rectangle
from tests.standing.scenes import block, scene

SLACK = 7.5e-3
COSINE = np.cos(0.01)


def passing(own: bool, corner: tuple[float, float], corners_block: bool = False) -> bool:
    """A candidate onto an edge of normal +y starting on the line y = 0, its vertex on
    that line; the line moved along: an edge of normal +y (slid along) or, ``own``, the
    vertex's own edge of normal −y (it faces the candidate's edge)."""
    other = (0.0, -1.0) if own else (0.0, 1.0)
    return bool(
        continues_moved_line(
            0.0, 1.0, *other, 0.5, 0.0, 0.0, own, *corner, corners_block, SLACK, 1e-6, COSINE
        )
    )


def test_an_edge_slid_along_is_a_line_wherever_the_corner_is():
    assert passing(False, (5.0, 0.0))


@pytest.mark.parametrize(
    ("corner", "corners_block", "expected"),
    [
        ((0.005, 0.0), False, True),  # the corner under the face is at the vertex
        ((0.0, -0.007), False, True),
        ((0.008, 0.0), False, False),  # further than the slack: a corner elsewhere
        ((2.5, 0.0), False, False),
        ((0.005, 0.0), True, False),  # the candidate's edge is of the corner's block
    ],
)
def test_an_own_edge_is_a_line_only_past_a_corner_at_the_vertex(corner, corners_block, expected):
    assert passing(True, corner, corners_block) is expected


def test_an_own_edge_faces_the_edge_it_continues_onto():
    """An own edge whose outward normal is the candidate edge's (not reversed): the
    candidate's block would lie on the vertex's own side, no line."""
    hit = continues_moved_line(
        0.0, 1.0, 0.0, 1.0, 0.5, 0.0, 0.0, True, 0.005, 0.0, False, SLACK, 1e-6, COSINE
    )
    assert not hit


def test_the_edge_under_which_a_corner_slid_is_a_line_of_both_its_vertices():
    """Block B on A: a sliding contact of A's corner w onto B's bottom edge e gives both
    ends of e the line (−(e + 1), w); w itself gets (e, −1)."""
    raw = scene(
        [block("A", rectangle(-3, -1, 0, 0), fixed=True), block("B", rectangle(-1, 0, 0, 1))]
    )
    blocks = build(dda.load_scene(raw)).blocks

    def at(block_row, point):
        rows = np.arange(blocks.offsets[block_row], blocks.offsets[block_row + 1])
        return int(rows[np.all(np.isclose(blocks.vertices[rows], point), axis=1)][0])

    corner = at(0, (0.0, 0.0))  # A's top right corner
    bottom = at(1, (-1.0, 0.0))  # B's bottom edge starts there (counter-clockwise)
    last = LastStep(np.array([corner]), np.array([bottom]), np.zeros(0, np.int64))
    indptr, lines = previous_partners(blocks, last)
    for vertex, expected in (
        (corner, [[bottom, -1]]),
        (bottom, [[-(bottom + 1), corner]]),
        (blocks.next_vertex[bottom], [[-(bottom + 1), corner]]),
    ):
        assert lines[indptr[vertex] : indptr[vertex + 1]].tolist() == expected
    assert indptr[-1] == 3
