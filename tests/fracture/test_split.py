"""Splitting a block by planes through a point, and what the pieces inherit."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon

from dda.fracture.children import children_state, velocity_at
from dda.fracture.split import split_polygon, split_polygon_detailed
from dda.geometry import pack_polygons, polygon_moments

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]])
L_SHAPE = np.array([[0, 0], [3, 0], [3, 1], [1, 1], [1, 3], [0, 3]], dtype=float)
U_SHAPE = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], dtype=float)


def signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def assert_clean(pieces: list[np.ndarray], min_area: float) -> None:
    for ring in pieces:
        assert ring.ndim == 2 and ring.shape[1] == 2 and len(ring) >= 3
        assert np.all(np.isfinite(ring))
        assert np.any(ring != np.roll(ring, 1, axis=0), axis=1).all(), "repeated vertex"
        assert not np.array_equal(ring[0], ring[-1]), "closing vertex"
        assert signed_area(ring) > 0.0, "not counter-clockwise"
        poly = Polygon(ring)
        assert poly.is_valid and poly.is_simple
        if len(pieces) > 1:
            assert poly.area >= min_area * (1 - 1e-9)


def moments(pieces: list[np.ndarray]) -> dict[str, np.ndarray]:
    return polygon_moments(*pack_polygons(pieces))


# ---------------------------------------------------------------- fixed cases


def test_shear_split_of_a_rectangle_gives_four_pieces():
    angles = [math.radians(90 + 25.45), math.radians(90 - 25.45)]
    pieces = split_polygon(SQUARE, [0.5, 1.0], angles)
    assert len(pieces) == 4
    assert_clean(pieces, 0.0)
    assert sum(Polygon(p).area for p in pieces) == pytest.approx(2.0, rel=1e-14)


def test_tension_split_gives_two_pieces_across_the_pull():
    pieces = split_polygon(SQUARE, [0.5, 1.0], [0.0])
    assert len(pieces) == 2
    areas = sorted(Polygon(p).area for p in pieces)
    assert areas == pytest.approx([1.0, 1.0], rel=1e-14)


def test_plane_through_two_vertices():
    pieces = split_polygon(SQUARE, [0.5, 1.0], [math.atan2(2.0, 1.0)])
    assert len(pieces) == 2
    assert_clean(pieces, 0.0)
    assert all(len(p) == 3 for p in pieces)


def test_concave_block_gives_every_piece():
    # one horizontal line through a point of the notch (outside the block): 3 pieces
    result = split_polygon_detailed(U_SHAPE, [1.5, 2.0], [0.0])
    assert len(result.pieces) == 3 and result.merged == 0
    assert_clean(result.pieces, 0.0)
    # two lines through (2.5, 2.5): both arms tips, the right arm tip in two, ...: 5 pieces
    result = split_polygon_detailed(U_SHAPE, [2.5, 2.5], [0.0, math.pi / 2])
    assert len(result.pieces) == 5 and result.merged == 0
    assert_clean(result.pieces, 0.0)
    assert sum(Polygon(p).area for p in result.pieces) == pytest.approx(7.0, rel=1e-14)


def test_centroid_outside_the_block():
    centroid = Polygon(L_SHAPE).centroid
    assert not Polygon(L_SHAPE).contains(centroid)
    pieces = split_polygon(L_SHAPE, [centroid.x, centroid.y], [math.pi / 4, -math.pi / 4])
    assert len(pieces) >= 2
    assert_clean(pieces, 0.0)
    assert sum(Polygon(p).area for p in pieces) == pytest.approx(5.0, rel=1e-14)


def test_line_missing_the_block_leaves_it_whole():
    pieces = split_polygon(SQUARE, [5.0, 5.0], [0.0])
    assert len(pieces) == 1 and pieces[0] is not None
    np.testing.assert_array_equal(pieces[0], SQUARE)


def test_slivers_are_merged_into_the_neighbour_with_the_longest_shared_edge():
    # a cut 1e-5 below the tips of the U's arms makes three slivers
    point = [0.5, 3.0 - 1e-5]
    result = split_polygon_detailed(U_SHAPE, point, [0.0, math.pi / 2], min_area=1e-3)
    assert result.merged == 3 and len(result.pieces) == 2
    assert_clean(result.pieces, 1e-3)
    assert sum(Polygon(p).area for p in result.pieces) == pytest.approx(7.0, rel=1e-14)
    # the left strip got its tip back and lost the now straight vertices
    strip = min(result.pieces, key=lambda p: Polygon(p).area)
    expected = Polygon([(0, 0), (0.5, 0), (0.5, 3), (0, 3)])
    assert Polygon(strip).symmetric_difference(expected).area < 1e-14
    assert len(strip) == 4


def test_corner_clip_alone_is_merged_back_and_the_block_kept():
    # a line clipping the corner (1, 2) of the rectangle: one sliver of area 5e-9
    result = split_polygon_detailed(SQUARE, [2.0, 1.0 - 1e-4], [-math.pi / 4], min_area=1e-6)
    assert result.merged == 1 and not result.split
    np.testing.assert_array_equal(result.pieces[0], SQUARE)


def test_cut_within_snapping_distance_of_a_vertex_reuses_the_vertex():
    angle = math.atan2(1.0, 0.5 * (1 + 1e-12))
    pieces = split_polygon(SQUARE, [0.5, 1.0], [angle])
    corners = {tuple(v) for p in pieces for v in p}
    assert (1.0, 2.0) in corners and (0.0, 0.0) in corners
    assert len(corners) == 4


def test_shear_pieces_too_small_together_split_along_one_plane():
    """An audit: a 1 x 2 block in compression, shear planes at ±60°, min_area 0.6: the four
    pieces (0.43 and 0.57 each) merged back one by one into the whole block, which then
    stayed beyond its strength. Split along one plane alone, it gives two pieces of 1."""
    planes = [-math.pi / 3, math.pi / 3]
    result = split_polygon_detailed(SQUARE, [0.5, 1.0], planes, min_area=0.6)
    assert result.split and len(result.pieces) == 2
    assert_clean(result.pieces, 0.6)
    assert sorted(Polygon(p).area for p in result.pieces) == pytest.approx([1.0, 1.0])


def test_all_pieces_too_small_keeps_the_parent():
    result = split_polygon_detailed(SQUARE, [0.5, 1.0], [0.3, -0.3], min_area=10.0)
    assert not result.split
    np.testing.assert_array_equal(result.pieces[0], SQUARE)


# ------------------------------------------------------------ property test


@st.composite
def star_polygons(draw):
    """Random simple (generally concave) star-shaped polygons, any scale and place."""
    k = draw(st.integers(3, 14))
    gaps = np.array(draw(st.lists(st.floats(0.05, 1.0), min_size=k, max_size=k)))
    angles = np.cumsum(gaps) / gaps.sum() * 2 * np.pi
    radii = np.array(draw(st.lists(st.floats(0.1, 1.0), min_size=k, max_size=k)))
    scale = 10.0 ** draw(st.floats(-3, 3))
    # blocks up to 100 sizes away from the origin: a new vertex is rounded to
    # ~1e-16 of its coordinates, so the area is kept to ~1e-16 x offset / size
    shift = scale * np.array(draw(st.tuples(st.floats(-100, 100), st.floats(-100, 100))))
    ring = scale * radii[:, None] * np.column_stack([np.cos(angles), np.sin(angles)]) + shift
    if signed_area(ring) < 0:  # a gap wider than a half turn can make it clockwise
        ring = ring[::-1].copy()
    poly = Polygon(ring)
    assume(poly.is_valid and poly.area > 1e-3 * scale**2)
    return ring


@st.composite
def cuts(draw, ring):
    """A point (centroid, a vertex or anywhere near) and one or two directions.

    Directions aimed at a vertex (exactly or nearly) exercise cuts through
    vertices and the slivers they leave.
    """
    centroid = np.asarray(Polygon(ring).centroid.coords[0])
    kind = draw(st.sampled_from(["centroid", "vertex", "random"]))
    if kind == "centroid":
        point = centroid
    elif kind == "vertex":
        point = ring[draw(st.integers(0, len(ring) - 1))]
    else:
        low, high = ring.min(axis=0), ring.max(axis=0)
        u = np.array(draw(st.tuples(st.floats(-0.2, 1.2), st.floats(-0.2, 1.2))))
        point = low + u * (high - low)
    if draw(st.booleans()):  # aim at a vertex, or within round-off of one
        target = ring[draw(st.integers(0, len(ring) - 1))] - point
        wobble = draw(st.sampled_from([0.0, 1e-15, 1e-11, 1e-7]))
        first = math.atan2(target[1], target[0]) + wobble if np.any(target) else 0.0
    else:
        first = draw(st.floats(-math.pi, math.pi))
    if draw(st.booleans()):
        return point, [first]
    half = draw(st.floats(0.05, 1.5))
    return point, [first + half, first - half]


@given(data=st.data())
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
def test_random_concave_splits_are_clean_and_conserve(data):
    ring = data.draw(star_polygons())
    point, directions = data.draw(cuts(ring))
    parent = Polygon(ring)
    min_area = 1e-3 * parent.area
    result = split_polygon_detailed(ring, point, directions, min_area)
    assert_clean(result.pieces, min_area)
    total = sum(Polygon(p).area for p in result.pieces)
    assert total == pytest.approx(parent.area, rel=1e-12)
    if not result.split:
        np.testing.assert_array_equal(result.pieces[0], ring)
        return
    # linear momentum of the pieces equals the parent's
    velocity6 = np.array(data.draw(st.lists(st.floats(-10, 10), min_size=6, max_size=6)))
    whole, parts = moments([ring]), moments(result.pieces)
    v, _ = children_state(velocity6, whole["centroid"][0], np.zeros(3), parts["centroid"])
    momentum = (parts["area"][:, None] * v[:, :2]).sum(axis=0)
    expected = whole["area"][0] * velocity6[:2]
    scale = whole["area"][0] * np.abs(velocity6).max() * max(1.0, np.ptp(ring))
    np.testing.assert_allclose(momentum, expected, rtol=0, atol=1e-12 * scale + 1e-300)


# ------------------------------------------------------------ inheritance


def angular_momentum(velocity6, centroid, area, ixx, iyy, ixy, about):
    """Angular momentum (density 1) of blocks about a point: orbital + spin (M row 3)."""
    u, v, r, ex, ey, g = np.asarray(velocity6).T
    arm = np.asarray(centroid) - about
    orbital = area * (arm[:, 0] * v - arm[:, 1] * u)
    spin = r * (ixx + iyy) + (ey - ex) * ixy + g * (ixx - iyy) / 2
    return float(np.sum(orbital + spin))


def kinetic_energy(velocity6, area, ixx, iyy, ixy):
    """0.5 vᵀ M v with the centroidal mass matrix of THEORY §3 (density 1)."""
    total = 0.0
    for vel, s, xx, yy, xy in zip(np.atleast_2d(velocity6), area, ixx, iyy, ixy, strict=True):
        m = np.zeros((6, 6))
        m[0, 0] = m[1, 1] = s
        m[2, 2:] = [xx + yy, -xy, xy, (xx - yy) / 2]
        m[3, 3:] = [xx, 0, xy / 2]
        m[4, 4:] = [yy, xy / 2]
        m[5, 5] = (xx + yy) / 4
        m = np.triu(m) + np.triu(m, 1).T
        total += 0.5 * vel @ m @ vel
    return total


def test_children_velocity_is_the_parent_field():
    velocity6 = np.array([1.0, -2.0, 0.5, 0.01, -0.02, 0.03])
    v, stress = children_state(velocity6, [1.0, 1.0], [1.0, 2.0, 3.0], [[1.0, 1.0], [2.0, 3.0]])
    np.testing.assert_allclose(v[0], velocity6)
    # at (2, 3): dx = 1, dy = 2
    assert v[1, 0] == pytest.approx(1.0 - 0.5 * 2 + 0.01 * 1 + 0.03 * 2 / 2)
    assert v[1, 1] == pytest.approx(-2.0 + 0.5 * 1 - 0.02 * 2 + 0.03 * 1 / 2)
    np.testing.assert_array_equal(v[1, 2:], velocity6[2:])
    np.testing.assert_array_equal(stress, [[1.0, 2.0, 3.0]] * 2)


def test_momentum_angular_momentum_and_energy_are_kept_by_a_split():
    velocity6 = np.array([0.3, -1.1, 2.0, 0.05, -0.04, 0.07])
    pieces = split_polygon(U_SHAPE, [1.5, 1.2], [0.4, -0.9])
    assert len(pieces) >= 3
    whole, parts = moments([U_SHAPE]), moments(pieces)
    x0 = whole["centroid"][0]
    v, _ = children_state(velocity6, x0, np.zeros(3), parts["centroid"])
    momentum = (parts["area"][:, None] * v[:, :2]).sum(axis=0)
    np.testing.assert_allclose(momentum, whole["area"][0] * velocity6[:2], rtol=1e-13)
    l_parent = angular_momentum(
        velocity6[None], x0[None], whole["area"], whole["ixx"], whole["iyy"], whole["ixy"], x0
    )
    l_children = angular_momentum(
        v, parts["centroid"], parts["area"], parts["ixx"], parts["iyy"], parts["ixy"], x0
    )
    assert l_children == pytest.approx(l_parent, rel=1e-13)
    e_parent = kinetic_energy(velocity6, whole["area"], whole["ixx"], whole["iyy"], whole["ixy"])
    e_children = kinetic_energy(v, parts["area"], parts["ixx"], parts["iyy"], parts["ixy"])
    assert e_children == pytest.approx(e_parent, rel=1e-13)


def test_velocity_at_matches_shi_displacement_matrix():
    velocity6 = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    x0, p = np.array([1.0, -1.0]), np.array([2.5, 0.5])
    dx, dy = p - x0
    t = np.array([[1, 0, -dy, dx, 0, dy / 2], [0, 1, dx, 0, dy, dx / 2]])
    np.testing.assert_allclose(velocity_at(velocity6, x0, p)[0], t @ velocity6)
