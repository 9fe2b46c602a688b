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


def test_the_compiled_formula_decides_as_numpy():
    """continues_moved_line compiled into a loop (as the resolver's kernel calls it, one
    candidate's numbers at a time) against numpy on arrays: the same on 20,000 draws of
    normals parallel, opposed, turned by 0.005 rad or square, offsets and corners in and
    out of the slack."""
    numba = pytest.importorskip("numba")
    from dda import jit

    jit._register_formulas()

    def loop(a, own, corners_block, out):
        for i in range(a.shape[0]):
            out[i] = continues_moved_line(
                a[i, 0], a[i, 1], a[i, 2], a[i, 3], a[i, 4], a[i, 5], a[i, 6], own[i],
                a[i, 7], a[i, 8], corners_block[i], SLACK, 1e-6, COSINE,
            )  # fmt: skip

    rng = np.random.default_rng(1)
    n = 20_000
    angles = rng.choice([0.0, np.pi, 0.005, np.pi / 2, -0.02, np.pi + 0.005], (n, 2)) + np.pi / 2
    a = np.empty((n, 9))
    a[:, 0], a[:, 1] = np.cos(angles[:, 0]), np.sin(angles[:, 0])
    a[:, 2], a[:, 3] = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    a[:, 4:6] = rng.choice([0.0, 0.003, -0.01, 0.5], (n, 2))
    a[:, 6] = rng.choice([0.0, -0.005, -0.008, 1e-7, 1e-3], n)
    a[:, 7:9] = rng.choice([0.0, 0.005, -0.007, 0.0053, 0.008, 2.0], (n, 2))
    own, corners_block = rng.random(n) < 0.5, rng.random(n) < 0.3
    expected = continues_moved_line(
        *a[:, :7].T, own, a[:, 7], a[:, 8], corners_block, SLACK, 1e-6, COSINE
    )
    out = np.zeros(n, bool)
    numba.njit(loop)(a, own, corners_block, out)
    np.testing.assert_array_equal(out, expected)
    assert (expected & own).sum() > 100 and (expected & ~own).sum() > 100


def test_the_lines_of_several_sliding_contacts_are_listed_by_vertex():
    """Two sliding contacts, given out of vertex order: each vertex's rows are its own,
    in the order given (the CSR of :func:`previous_partners`)."""
    raw = scene(
        [block("A", rectangle(-3, -1, 0, 0), fixed=True), block("B", rectangle(-1, 0, 0, 1)),
         block("C", rectangle(-2, 0, -1, 1))]
    )  # fmt: skip
    blocks = build(dda.load_scene(raw)).blocks
    first, second = blocks.offsets[2] + 1, blocks.offsets[1]  # a C vertex, a B vertex
    edge = blocks.offsets[0] + 2  # one of A's edges
    last = LastStep(np.array([first, second]), np.array([edge, edge]), np.zeros(0, np.int64))
    indptr, lines = previous_partners(blocks, last)
    rows = {v: lines[indptr[v] : indptr[v + 1]].tolist() for v in range(len(blocks.vertices))}
    assert rows[first] == [[edge, -1]] and rows[second] == [[edge, -1]]
    for end in (edge, blocks.next_vertex[edge]):  # both ends of A's edge: C's, then B's
        assert rows[end] == [[-(edge + 1), first], [-(edge + 1), second]]
    assert sum(len(r) for r in rows.values()) == 6
