"""Contact distance rows (paper eqs. 9-13): sign and derivatives."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dda
import dda.contact.rows as rows_module
from dda.bench.scenes import wall_scene
from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet, merge
from dda.contact.pipeline import refresh_contacts
from dda.contact.rows import contact_rows, edge_geometry
from dda.geometry import pack_polygons
from dda.kinematics import move_points
from dda.model import build


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
    d, t, _ = edge_geometry(blocks, vertex, edge)
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
        trial = dataclasses.replace(blocks, vertices=moved, centroid=None)
        exact = edge_geometry(trial, contacts.vertex, contacts.edge)[0][0]
        linear = rows.penetration[0] + rows.normal_i[0] @ d[1] + rows.normal_j[0] @ d[0]
        assert exact == pytest.approx(linear, abs=1e-12)


@pytest.mark.parametrize("compiled", [True, False])
def test_gaps_after_a_step_are_the_linearised_distances(monkeypatch, compiled):
    """d = S0/l + E D_a + G D_b and s = s0 + Es D_a + Gs D_b for every contact of a wall."""
    if not compiled:
        monkeypatch.setattr(rows_module, "_gaps_kernel", None)
    model = build(dda.load_scene(wall_scene(3, 3)))
    contacts = refresh_contacts(model.blocks, ContactSet.empty(), model.contact)
    rows = contact_rows(model.blocks, contacts)
    d = np.random.default_rng(2).normal(scale=1e-3, size=(model.blocks.count, 6))
    pen, slip = rows_module.gaps_after(rows, contacts.block_a, contacts.block_b, d)
    assert len(pen) == 30  # 6 on the base, 24 at the ends of the 12 shared edges
    for c in range(len(pen)):
        a, b = contacts.block_a[c], contacts.block_b[c]
        expected_pen = rows.penetration[c] + rows.normal_i[c] @ d[a] + rows.normal_j[c] @ d[b]
        expected_slip = rows.slip[c] + rows.shear_i[c] @ d[a] + rows.shear_j[c] @ d[b]
        assert pen[c] == pytest.approx(expected_pen, rel=1e-12, abs=1e-15)
        assert slip[c] == pytest.approx(expected_slip, rel=1e-12, abs=1e-15)


@pytest.mark.skipif(rows_module._rows_kernel is None, reason="numba is not in use")
@pytest.mark.parametrize("case", ["wall", "tunnel"])
def test_compiled_rows_equal_the_numpy_rows(monkeypatch, case):
    """The compiled pass gives every array of the numpy formulas (to round-off)."""
    if case == "wall":
        scene = dda.load_scene(wall_scene(4, 3))
    else:
        scene = dda.load_scene("cases/tunnel.toml")
    model = build(scene)
    contacts = refresh_contacts(model.blocks, ContactSet.empty(), model.contact)
    contacts.reference[:] = np.random.default_rng(3).random(len(contacts))
    compiled = contact_rows(model.blocks, contacts)
    monkeypatch.setattr(rows_module, "_rows_kernel", None)
    expected = contact_rows(model.blocks, contacts)
    assert len(contacts) > 40
    for name in expected.__dataclass_fields__:
        want = getattr(expected, name)
        scale = max(float(np.abs(want).max()), 1.0)
        np.testing.assert_allclose(getattr(compiled, name), want, rtol=0, atol=1e-13 * scale)


@pytest.mark.parametrize("compiled", [True, False])
def test_edge_geometry_gives_depth_parameter_and_segment_distance(monkeypatch, compiled):
    """d, t against the two-block picture, r against shapely's point-segment distance."""
    if not compiled:
        monkeypatch.setattr(rows_module, "_edge_geometry_kernel", None)
    import shapely

    model = build(dda.load_scene("cases/tunnel.toml"))
    blocks = model.blocks
    rng = np.random.default_rng(6)
    vertex = rng.integers(0, len(blocks.vertices), 300)
    edge = rng.integers(0, len(blocks.vertices), 300)
    d, t, r = rows_module.edge_geometry(blocks, vertex, edge)
    ends = blocks.vertices[blocks.next_vertex[edge]]
    segments = shapely.linestrings(np.stack([blocks.vertices[edge], ends], axis=1))
    expected = shapely.distance(shapely.points(blocks.vertices[vertex]), segments)
    np.testing.assert_allclose(r, expected, rtol=1e-12, atol=1e-12)
    inside = (t >= 0) & (t <= 1)
    np.testing.assert_allclose(np.abs(d[inside]), r[inside], rtol=1e-9, atol=1e-12)
    assert 0 < inside.sum() < 300
    square = two_blocks(-0.01)
    d, t, r = rows_module.edge_geometry(square, np.array([4]), np.array([2]))
    assert (
        d[0] == pytest.approx(0.01) and t[0] == pytest.approx(0.5) and r[0] == pytest.approx(0.01)
    )


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("kink, bonded", [(90.0, 2.0), (60.0, 1.0), (30.0, 1.0), (2.0, 1.0)])
def test_a_corner_in_a_concave_corner_carries_each_own_edge_once(monkeypatch, compiled, kink,
                                                                  bonded):  # fmt: skip
    """A unit square on a fixed base whose top bends up at its corner (by ``kink``; 90°:
    an L): the corner is two contacts, one on each edge there, and the length the square's
    contacts with the base carry for cohesion and tensile strength is that of its edges
    lying on the base: 1 m, both edges (2 m) in the L. Each contact took half the own
    edge best aligned with its edge: 1.5 m at 2° to 60° (the bottom edge twice, or the
    left edge, which touches nothing), and the square held 1.7 times its cohesion's
    load at 2°."""
    import math

    from dda.model import build
    from tests.helpers import rectangle
    from tests.standing.scenes import block, scene

    if not compiled:
        monkeypatch.setattr(rows_module, "_rows_kernel", None)
        monkeypatch.setattr(rows_module, "_carried_once_kernel", None)
    if kink == 90.0:
        base = [(-3, -1), (3, -1), (3, 0), (0, 0), (0, 3), (-3, 3)]
    else:
        base = [(-3, -1), (3, -1), (3, 0), (0, 0), (-3, 3 * math.tan(math.radians(kink)))]
    raw = scene([block("base", base, fixed=True), block("b", rectangle(0, 0, 1, 1))])
    model = build(dda.load_scene(raw))
    contacts = refresh_contacts(model.blocks, ContactSet.empty(), model.contact)
    assert contact_rows(model.blocks, contacts).length.sum() == pytest.approx(bonded, rel=1e-12)


@pytest.mark.skipif(rows_module._carried_once_kernel is None, reason="numba is not in use")
@pytest.mark.parametrize("seed", range(3))
def test_carried_once_compiled_equals_numpy(seed):
    """The declared pair of :func:`dda.contact.rows.carried_once`: the compiled pass and
    the numpy sort give the same lengths, on random contacts of a jittered wall's
    vertices, a third of them paired with a second contact with the same block, their
    edges at random directions (some within 10° of an own edge, some not)."""
    from tests.contact.test_detection import wall_blocks

    _, blocks = wall_blocks(4, 3, jitter=0.3, seed=seed)
    rng = np.random.default_rng(seed)
    n = len(blocks.vertices)
    vertex = rng.permutation(n)[: n // 2]
    block_b = rng.integers(0, blocks.count, len(vertex))
    twice = vertex[: len(vertex) // 3]
    vertex = np.concatenate([vertex, twice])
    block_b = np.concatenate([block_b, block_b[: len(twice)]])
    order = rng.permutation(len(vertex))
    vertex, block_b = vertex[order], block_b[order]
    own = blocks.vertices[blocks.next_vertex[vertex]] - blocks.vertices[vertex]
    angle = np.arctan2(own[:, 1], own[:, 0]) + rng.normal(scale=0.3, size=len(vertex))
    tangents = np.column_stack([np.cos(angle), np.sin(angle)])
    carried = rng.random(len(vertex))
    args = (blocks.vertices, vertex.astype(np.int64), block_b.astype(np.int64),
            blocks.next_vertex.astype(np.int64), blocks.previous_vertex.astype(np.int64),
            tangents, carried)  # fmt: skip
    numpy_lengths = rows_module._carried_once_numpy(*args)
    compiled_lengths = rows_module._carried_once_kernel(*args, rows_module.ALONG)
    assert not np.array_equal(numpy_lengths, carried)  # pairs were changed
    np.testing.assert_array_equal(compiled_lengths, numpy_lengths)
