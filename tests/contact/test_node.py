"""Corner pairs at a node: the ones other blocks separate are no contact."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest

import dda
import dda.contact.node as node
from dda.bench.scenes import wall_scene
from dda.contact.broad import candidate_pairs
from dda.contact.contact_set import ContactSet
from dda.contact.node import ANGLE_FILL
from dda.contact.pipeline import refresh_contacts
from dda.model import build
from dda.solve.policy import DEFAULT
from dda.solve.step import pattern_neighbours


def corners(starts_deg, spans_deg):
    """One corner per block at the origin: (owner, to_next, to_prev) of wedges given in degrees."""
    start = np.radians(np.asarray(starts_deg, float))
    end = start + np.radians(np.asarray(spans_deg, float))
    to_next = np.column_stack([np.cos(start), np.sin(start)])
    to_prev = np.column_stack([np.cos(end), np.sin(end)])
    return np.arange(len(start)), to_next, to_prev


def separated(starts_deg, spans_deg, compiled=True, at=None, tight=1e-3):
    """{(i, j): separated} for every pair of the corners (all at the origin, or ``at``)."""
    owner, to_next, to_prev = corners(starts_deg, spans_deg)
    pairs = np.array(list(combinations(range(len(owner)), 2)))
    start, span = node.wedges(to_next, to_prev)
    p1, p2 = pairs[:, 0], pairs[:, 1]
    indptr, mates = node._mates(p1, p2, len(owner))
    v = np.zeros((len(owner), 2)) if at is None else at
    if compiled == "one call" and node.separated_corners_kernel is not None:  # fans in
        mask = node.separated_corners_kernel(v, owner, to_next, to_prev, p1, p2, tight)
    elif compiled:  # the kernel, or its Python source where numba is missing
        kernel = node._separated_kernel or node._separated
        mask = kernel(v, owner, start, span, p1, p2, indptr, mates, tight, ANGLE_FILL)
    else:
        mask = node._separated_numpy(v, owner, start, span, p1, p2, indptr, mates, tight)
    return {tuple(p): bool(m) for p, m in zip(pairs.tolist(), mask, strict=True)}


PATHS = [True, False, "one call"]  # the kernel, numpy, the kernel from the fans


@pytest.mark.parametrize("compiled", PATHS)
def test_diagonal_corners_of_a_four_block_node_are_separated(compiled):
    """Four quarters (a wall's node): the two diagonal pairs only."""
    result = separated([0, 90, 180, 270], [90, 90, 90, 90], compiled)
    assert [p for p, s in result.items() if s] == [(0, 2), (1, 3)]


@pytest.mark.parametrize("compiled", PATHS)
def test_corners_meeting_across_voids_stay_a_pair(compiled):
    """Two squares corner to corner, nothing beside them: either may move into the other."""
    assert separated([0, 180], [90, 90], compiled) == {(0, 1): False}


@pytest.mark.parametrize("compiled", PATHS)
def test_thin_corners_in_the_gaps_do_not_separate_but_filling_ones_do(compiled):
    """A 10-degree wedge in each 90-degree gap leaves voids: the pair stays.
    Wedges that fill the gaps to within ANGLE_FILL separate it."""
    assert not separated([0, 180, 130, 310], [90, 90, 10, 10], compiled)[(0, 1)]
    fill = np.degrees(ANGLE_FILL) / 2  # a void of half the fill angle on each side
    assert separated([0, 180, 90 + fill, 270], [90, 90, 90 - fill, 90], compiled)[(0, 1)]
    void = np.degrees(ANGLE_FILL) * 2  # twice it: the corners may meet through it
    assert not separated([0, 180, 90 + void, 270], [90, 90, 90 - void, 90], compiled)[(0, 1)]


@pytest.mark.parametrize("compiled", PATHS)
def test_neighbours_overlapping_by_a_small_rotation_have_no_gap(compiled):
    """Wedges overlapping by 1e-4 rad (one block turned) come out as a gap near 2 pi,
    which nothing fills: neighbours, never a separated pair. The diagonals still are."""
    turn = np.degrees(1e-4)
    result = separated([0, 90 - turn, 180, 270], [90, 90 + 2 * turn, 90, 90], compiled)
    assert [p for p, s in result.items() if s] == [(0, 2), (1, 3)]


@pytest.mark.parametrize("compiled", PATHS)
def test_a_loose_node_keeps_its_pairs(compiled):
    """Corners more than ``tight`` apart do not fill each other's gaps: a node whose
    blocks have moved apart by a millimetre is no node (fragments of a pile)."""
    quarters = ([0, 90, 180, 270], [90, 90, 90, 90])
    apart = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [2e-3, 0.0]])
    result = separated(*quarters, compiled, at=apart, tight=1e-3)
    assert [p for p, s in result.items() if s] == []  # (0, 2) lost its filler 3
    close = apart * 0.25
    result = separated(*quarters, compiled, at=close, tight=1e-3)
    assert [p for p, s in result.items() if s] == [(0, 2), (1, 3)]


@pytest.mark.parametrize("seed", range(5))
def test_compiled_and_numpy_give_the_same_pairs(seed):
    """Random nodes of 3-7 wedges filling the circle, then opened or overlapped a little."""
    rng = np.random.default_rng(seed)
    for _ in range(40):
        k = int(rng.integers(3, 8))
        cuts = np.sort(rng.random(k)) * 360.0
        spans = np.diff(np.append(cuts, cuts[0] + 360.0))
        spans = spans * (1.0 + rng.normal(scale=0.03, size=k))
        assert separated(cuts, spans, True) == separated(cuts, spans, False)


def test_a_diagonal_contact_carries_no_load_across_a_node():
    """Two columns of two blocks, frictionless joints, no gravity; the upper-left block
    pushed by 0.5 MN against the upper-right one and a fixed wall (plane strain).
    Equilibrium: the upper blocks carry sxx = -F/h = -0.5 MPa, the lower ones nothing.

    With a contact between the diagonal corners at the node, the upper-left corner
    pressed on the line of the lower-right block's edge and carried 46 % of the load
    straight into it (sxx = -0.228 MPa there, -0.272 MPa in the upper-right block)."""
    result = dda.simulate(dda.load_scene(pushed_node_scene()))
    stress = dict(zip(result.final.names, result.final.stresses[:, 0], strict=True))
    expected = {"lower_left": 0.0, "lower_right": 0.0, "upper_left": -5e5, "upper_right": -5e5}
    for name, sxx in expected.items():
        assert abs(stress[name] - sxx) <= 1e-3 * 5e5, name


def pushed_node_scene() -> dict:
    """The scene of :func:`test_a_diagonal_contact_carries_no_load_across_a_node`."""
    rock = {"density": 2700.0, "young": 5.0e9, "poisson": 0.25}
    fixed = [
        ("base", [[-1.0, -1.0], [3.0, -1.0], [3.0, 0.0], [-1.0, 0.0]]),
        ("wall", [[2.0, 0.0], [2.5, 0.0], [2.5, 2.5], [2.0, 2.5]]),
    ]
    free = [
        ("lower_left", 0.0, 0.0),
        ("lower_right", 1.0, 0.0),
        ("upper_left", 0.0, 1.0),
        ("upper_right", 1.0, 1.0),
    ]
    blocks = [{"name": n, "material": "rock", "fixed": True, "vertices": v} for n, v in fixed]
    blocks += [
        {
            "name": n,
            "material": "rock",
            "vertices": [[x, y], [x + 1, y], [x + 1, y + 1], [x, y + 1]],
        }
        for n, x, y in free
    ]
    return {
        "analysis": {
            "mode": "static",
            "time_step": 0.01,
            "steps": 200,
            "gravity": [0.0, 0.0],
            "plane": "strain",
        },
        "contact": {"method": "penalty"},
        "materials": {"rock": rock},
        "joints": {"default": {"friction_angle": 0.0}},
        "blocks": blocks,
        "loads": [{"block": "upper_left", "point": [0.0, 1.5], "force": [5.0e5, 0.0]}],
    }


def test_a_new_pattern_leaves_out_blocks_that_meet_only_at_filled_nodes():
    """3 x 3 wall on its base: the boxes of 23 block pairs touch, the 8 diagonal ones only
    at the four inner nodes. A new pattern holds the 15 others (K needs no fill-in for
    the diagonals), and a diagonal pair again once it has a contact."""
    model = build(dda.load_scene(wall_scene(3, 3)))
    blocks, settings = model.blocks, model.contact
    contacts = refresh_contacts(blocks, ContactSet.empty(), settings)
    near = candidate_pairs(blocks, DEFAULT.neighbour_margin * settings.search_distance)
    held = {
        tuple(p)
        for p in np.sort(
            pattern_neighbours(blocks, contacts, settings, DEFAULT.neighbour_margin), axis=1
        )
    }
    diagonal = {tuple(p) for p in np.sort(near, axis=1)} - held
    assert (len(near), len(held), len(diagonal)) == (23, 15, 8)
    centroids = blocks.centroid
    for a, b in diagonal:
        assert np.allclose(np.abs(centroids[a] - centroids[b]), 1.0)  # one block across
    a, b = sorted(diagonal)[0]
    contacts.block_a[0], contacts.block_b[0] = a, b  # pretend the node opened
    held = {
        tuple(p)
        for p in np.sort(
            pattern_neighbours(blocks, contacts, settings, DEFAULT.neighbour_margin), axis=1
        )
    }
    assert (a, b) in held and len(held) == 16
