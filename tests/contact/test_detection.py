"""Contact search: broad phase against brute force, narrow phase on small grids."""

from __future__ import annotations

import dataclasses
import importlib
import tomllib
from pathlib import Path

import numpy as np
import pytest
import shapely

import dda
import dda.contact.broad as broad
import dda.contact.narrow as narrow
import dda.contact.pipeline as pipeline
import dda.contact.point_distance as pd
from dda.bench.scenes import wall_scene
from dda.contact.broad import candidate_pairs, overlapping_pairs
from dda.contact.contact_set import ContactSet, contact_keys
from dda.contact.line_continuation import LastStep
from dda.contact.narrow import detect
from dda.contact.pipeline import _blocks_touch, _distances_where
from dda.contact.rows import edge_geometry
from dda.model import build
from dda.run import run_warnings
from tests.helpers import rectangle
from tests.standing.scenes import base, block, scene


def brute_force_pairs(boxes: np.ndarray) -> np.ndarray:
    n = len(boxes)
    i, j = np.triu_indices(n, 1)
    hit = ~(
        (boxes[i, 0] > boxes[j, 2])
        | (boxes[j, 0] > boxes[i, 2])
        | (boxes[i, 1] > boxes[j, 3])
        | (boxes[j, 1] > boxes[i, 3])
    )
    return np.column_stack([i[hit], j[hit]])


def random_boxes(seed: int, n: int = 300) -> np.ndarray:
    """Boxes of mixed sizes, a few very long ones, some touching exactly."""
    rng = np.random.default_rng(seed)
    lo = np.round(rng.random((n, 2)) * 40.0, 1)
    size = rng.choice([0.5, 1.0, 2.0], (n, 2))
    size[:3, 0] = 45.0  # long bases: many cells
    return np.column_stack([lo, lo + size])


@pytest.mark.parametrize("seed", range(4))
def test_broad_phase_equals_brute_force(seed):
    boxes = random_boxes(seed)
    np.testing.assert_array_equal(overlapping_pairs(boxes), brute_force_pairs(boxes))


def test_broad_phase_tree_path_equals_brute_force(monkeypatch):
    monkeypatch.setattr(broad, "_grid_kernel", None)
    boxes = random_boxes(9)
    np.testing.assert_array_equal(overlapping_pairs(boxes), brute_force_pairs(boxes))


def wall_blocks(columns: int, rows: int, jitter: float = 0.0, seed: int = 0):
    model = build(dda.load_scene(wall_scene(columns, rows)))
    blocks = model.blocks.copy()
    if jitter:
        rng = np.random.default_rng(seed)
        owner = blocks.vertex_owner
        shift = rng.normal(scale=jitter, size=(blocks.count, 2))
        shift[blocks.fixed] = 0.0
        blocks.vertices = blocks.vertices + shift[owner]
        blocks.update_moments()
    return model, blocks


def test_broad_phase_pairs_of_a_wall():
    """2 x 2 wall: the base with the two bottom blocks, and the blocks among themselves."""
    model, blocks = wall_blocks(2, 2)
    pairs = candidate_pairs(blocks, model.contact.search_distance)
    expected = [[0, 1], [0, 2], [1, 2], [1, 3], [1, 4], [2, 3], [2, 4], [3, 4]]
    np.testing.assert_array_equal(pairs, expected)


@pytest.mark.parametrize("compiled", [True, False])
def test_kept_pairs_equal_a_new_search_as_blocks_move(monkeypatch, compiled):
    """The kept list gives a new search's pairs, in order, after small moves (the list
    is kept) and large ones (pairs appear and go; a new list is made), and after the
    blocks change."""
    if not compiled:
        monkeypatch.setattr(broad, "_still_overlapping_kernel", None)
        monkeypatch.setattr(broad, "_kept_kernel", None)
    model, blocks = jittered_blocks(wall_scene(6, 5), 0.0)
    margin = model.contact.search_distance
    free = ~blocks.fixed
    owner = blocks.vertex_owner
    # blocks set apart by just more than the margin: moves of 0.3 margin make pairs
    blocks.vertices = blocks.vertices + 1.15 * margin * np.floor(blocks.centroid[owner])
    blocks.vertices[~free[owner]] = model.blocks.vertices[~free[owner]]
    kept = broad.KeptPairs()
    rng = np.random.default_rng(4)
    counts = []
    for step in range(12):
        size = margin * (0.3 if step % 4 == 3 else 0.01)  # every 4th move is large
        shift = free[:, None] * rng.uniform(-size, size, size=(blocks.count, 2))
        blocks.vertices = blocks.vertices + shift[owner]
        pairs = candidate_pairs(blocks, margin)
        np.testing.assert_array_equal(kept.pairs(blocks, margin), pairs)
        counts.append(len(pairs))
    assert len(set(counts)) > 2  # pairs came and went
    assert 3 <= kept.searches < 12  # kept between the small moves, new after the large
    _, fewer = jittered_blocks(wall_scene(6, 4), 0.0)
    np.testing.assert_array_equal(kept.pairs(fewer, margin), candidate_pairs(fewer, margin))
    np.testing.assert_array_equal(kept.pairs(fewer, 2 * margin), candidate_pairs(fewer, 2 * margin))


def test_a_run_with_kept_pairs_equals_one_without(monkeypatch):
    """The tunnel's first steps give the same displacements, bit for bit, with the
    pairs kept between steps and with a new search every step."""
    raw = tomllib.loads(Path("cases/tunnel.toml").read_text())
    raw["analysis"].pop("duration", None)
    raw["analysis"]["steps"] = 15
    scene = dda.load_scene(raw)
    monkeypatch.setenv("DDA_THREADS", "1")  # bit for bit: PARDISO's threads fixed
    # the step module bound to the real search before the spy: the spy counts the contact
    # search's own calls, not those of new block patterns (a test run alone would import
    # the step module lazily, inside the first simulate, and bind the spy)
    importlib.import_module("dda.solve.step")
    searches = []
    search = broad.candidate_pairs
    monkeypatch.setattr(broad, "candidate_pairs", lambda *a: searches.append(1) or search(*a))
    kept = dda.simulate(scene)
    assert len(searches) < 5  # the list was kept over most of the 15 steps
    monkeypatch.setattr(broad.KeptPairs, "_same_blocks", lambda self, blocks, margin: False)
    fresh = dda.simulate(scene)
    for ours, theirs in zip(kept.final.vertices, fresh.final.vertices, strict=True):
        np.testing.assert_array_equal(ours, theirs)
    assert kept.summary["iterations"] == fresh.summary["iterations"]


def test_narrow_phase_finds_the_contacts_of_a_small_wall():
    """2 x 1 wall on its base: two vertices on the base's top edge per block (V-E),
    and the shared vertical edge's two vertex pairs (V-V)."""
    model, blocks = wall_blocks(2, 1)
    c = model.contact
    found = detect(
        blocks, candidate_pairs(blocks, c.search_distance), c.search_distance, c.vertex_radius
    )
    owner = blocks.vertex_owner
    ve = sorted(
        zip(
            owner[found.vertex[~found.vertex_vertex]],
            owner[found.edge[~found.vertex_vertex]],
            strict=True,
        )
    )
    assert ve == [(1, 0), (1, 0), (2, 0), (2, 0)]
    vv_pairs = {
        tuple(sorted(p))
        for p in zip(
            owner[found.vertex[found.vertex_vertex]],
            owner[found.edge[found.vertex_vertex]],
            strict=True,
        )
    }
    assert vv_pairs == {(1, 2)} and found.vertex_vertex.sum() == 2


def jittered_blocks(source, jitter: float, seed: int = 0):
    """The blocks of a scene (path or dict) with every free vertex moved at random
    (shapes change too)."""
    model = build(dda.load_scene(source))
    blocks = model.blocks.copy()
    shift = np.random.default_rng(seed).normal(scale=jitter, size=blocks.vertices.shape)
    shift[blocks.fixed[blocks.vertex_owner]] = 0.0
    blocks.vertices = blocks.vertices + shift
    blocks.update_moments()
    return model, blocks


def tunnel_blocks(jitter: float):
    return jittered_blocks("cases/tunnel.toml", jitter)


def tiles_of_ells(jitter: float):
    """3 x 3 cells of 2 x 2, each an L-shaped block and the unit square in its notch:
    the L's reflex corner meets the square's corner, and corners of the cells meet."""
    parts = [base(-1.0, 7.0)]
    for i in range(3):
        for j in range(3):
            x, y = 2.0 * i, 2.0 * j
            ell = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
            parts.append(block(f"ell{i}{j}", [(x + a, y + b) for a, b in ell]))
            parts.append(block(f"square{i}{j}", rectangle(x + 1, y + 1, x + 2, y + 2)))
    return jittered_blocks(scene(parts), jitter)


@pytest.mark.skipif(narrow._fans_kernel is None, reason="numba is not in use")
@pytest.mark.parametrize("make", [tunnel_blocks, tiles_of_ells])
def test_vertex_fans_compiled_equal_numpy(monkeypatch, make):
    """Unit edge vectors, normals, reflex corners and shortest edges: both paths."""
    _, blocks = make(1e-3)
    compiled = narrow.VertexFans(blocks)
    monkeypatch.setattr(narrow, "_fans_kernel", None)
    expected = narrow.VertexFans(blocks)
    assert expected.reflex.any()
    np.testing.assert_array_equal(compiled.reflex, expected.reflex)
    for name in ("to_next", "to_prev", "outward", "shortest"):
        np.testing.assert_allclose(
            getattr(compiled, name), getattr(expected, name), rtol=1e-14, atol=1e-15
        )


def pairings_after_a_nudge(blocks, pairs, c, scale: float = 1e-9):
    """(vertex, edge) of the pairings found with every vertex moved by ``scale`` at random:
    where vertex-vertex candidates tie, round-off picks pairings other than the unmoved
    blocks' own (the last step's in a run)."""
    moved = blocks.copy()
    moved.vertices = moved.vertices + np.random.default_rng(7).normal(
        scale=scale, size=moved.vertices.shape
    )
    found = detect(moved, pairs, c.search_distance, c.vertex_radius)
    return found.vertex, found.edge


@pytest.mark.parametrize(
    "make",
    [
        lambda: wall_blocks(4, 3, jitter=0.0, seed=3),
        lambda: wall_blocks(4, 3, jitter=1e-3, seed=3),
        lambda: tunnel_blocks(0.0),
        lambda: tunnel_blocks(1e-3),  # overlaps: vertices inside blocks
        lambda: tiles_of_ells(0.0),
        lambda: tiles_of_ells(1e-3),
    ],
    ids=["wall", "jittered-wall", "tunnel", "jittered-tunnel", "ells", "jittered-ells"],
)
@pytest.mark.parametrize("moving", [0.0, 1e-4, 3e-2], ids=["at-rest", "moving", "fast"])
def test_narrow_phase_compiled_and_numpy_paths_agree(monkeypatch, make, moving):
    """The compiled narrow phase (one call: screen, corners at filled nodes,
    vertex-vertex resolution, pairings kept — one a vertex-edge pair, the shallower of
    opposed edges) gives the numpy path's contacts (with and without the compiled screen),
    with last step's keys (from a nudged copy) for half of the pairings, a third of them
    sliding, a third locked (the corners that keep to a line), the others decided by
    position, and the contact tolerance as the inside depth; the vertices at rest, moving
    by 1e-4 m (it decides ties) or by 3 cm a step (corners that meet head-on are paired).
    The L's and the tunnel's blocks around the opening have reflex vertices."""
    model, blocks = make()
    c = model.contact
    pairs = candidate_pairs(blocks, c.search_distance)
    vertex, edge = pairings_after_a_nudge(blocks, pairs, c)
    previous = contact_keys(blocks, vertex, edge)[::2]
    sliding = slice(0, None, 6)  # a third of the last step's contacts sliding, a third locked
    closed = np.sort(np.concatenate([previous[::3], previous[1::3]]))
    last = LastStep(vertex[sliding], edge[sliding], closed)
    motion = None  # each vertex's motion over the coming step: it decides open ties
    if moving:
        motion = np.random.default_rng(11).normal(scale=moving, size=blocks.vertices.shape)
    args = (blocks, pairs, c.search_distance, c.vertex_radius, c.law.tolerance, previous, None,
            last, motion)  # fmt: skip
    first = detect(*args)  # one compiled call
    monkeypatch.setattr(narrow, "_detect_kernel", None)
    pieces = detect(*args)  # the numpy path around the compiled screen
    monkeypatch.setattr(narrow, "_screen_kernel", None)
    second = detect(*args)
    assert first.vertex_vertex.sum() >= 20
    for found in (pieces, second):
        np.testing.assert_array_equal(first.vertex, found.vertex)
        np.testing.assert_array_equal(first.edge, found.edge)
        np.testing.assert_array_equal(first.vertex_vertex, found.vertex_vertex)
        np.testing.assert_array_equal(first.shared_line, found.shared_line)


@pytest.mark.parametrize("compiled", [True, False])
def test_corners_that_meet_head_on_within_the_step_are_paired(monkeypatch, compiled):
    """A 1 m block 1 cm above a fixed 5 mm plate, its bottom corners in line with the
    plate's top corners: each projects onto an end of the plate's top edge (no vertex-edge
    candidate) and lies further than the pair's vertex radius (1.25 mm, a quarter of the
    plate's 5 mm edges) from the plate's corner. Falling 2 cm in the coming step (20 m/s
    at Δt = 1e-3 s) they meet there: one vertex-vertex pair at each corner. Falling 5 mm,
    at rest, or sliding sideways by 2 cm, none."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
        monkeypatch.setattr(narrow, "_screen_kernel", None)
    plate = block("plate", rectangle(0.0, -0.005, 1.0, 0.0), fixed=True)
    falling = block("block", rectangle(0.0, 0.01, 1.0, 1.01))
    model = build(dda.load_scene(scene([plate, falling], {"steps": 1, "gravity": [0, 0]})))
    blocks, c = model.blocks, model.contact
    pairs = np.array([[0, 1]])
    mine = blocks.vertex_owner == 1

    def corner_pairs(motion_of_block) -> int:
        motion = np.zeros_like(blocks.vertices)
        motion[mine] = motion_of_block
        found = detect(blocks, pairs, 0.05, c.vertex_radius, c.law.tolerance, motion=motion)
        return int(found.vertex_vertex.sum())

    assert corner_pairs([0.0, -0.02]) == 2
    assert corner_pairs([0.0, -0.005]) == 0
    assert corner_pairs([0.0, 0.0]) == 0
    assert corner_pairs([0.02, 0.0]) == 0


def _beam_on_pillars(mirrored: bool, start: str) -> dict:
    """A 2 m × 0.5 m beam laid corner to corner on two fixed 1 m pillars (an audit's)."""

    def box(name, x0, y0, x1, y1, **more):
        return {"name": name, "material": "rock",
                "vertices": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]], **more}  # fmt: skip

    shift = -2.0 if mirrored else 0.0
    return {
        "analysis": {"time_step": 1e-3, "duration": 0.2, "gravity": [0, -9.81], "start": start},
        "materials": {"rock": {"density": 2600.0, "young": 5e9, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": [
            box("p1", shift - 1, -1, shift, 1, fixed=True),
            box("p2", shift + 2, -1, shift + 3, 1, fixed=True),
            box("beam", shift, 1, shift + 2, 1.5),
        ],
    }


@pytest.mark.parametrize("start", ["equilibrium", "unloaded"])
@pytest.mark.parametrize("mirrored", [False, True], ids=["beam", "mirrored"])
def test_a_beam_laid_corner_to_corner_on_two_pillars_stands(mirrored, start):
    """Each corner of the beam meets a pillar's corner exactly: the four pairings of
    each node tie and no earlier contact decides. The beam's fall under gravity over the
    coming step does: both corners rest on the top faces. It tipped about its left
    corner, 0.116 rad in 0.2 s, the mirrored scene the same way, while such ties went by
    the order of the vertices. Here: no turn beyond round-off, the drop its contacts'
    settlement (5.6e-7 m from the unloaded start, none from the loaded one)."""
    final = dda.simulate(dda.load_scene(_beam_on_pillars(mirrored, start))).final
    assert abs(final.rotations[2]) <= 1e-12
    assert abs(final.displacements[2][1]) <= 1e-6
    assert abs(final.displacements[2][0]) <= 1e-12


@pytest.mark.skipif(pipeline._sift_kernel is None, reason="numba is not in use")
@pytest.mark.parametrize(
    "make", [lambda: tunnel_blocks(1e-3), lambda: tiles_of_ells(1e-3)], ids=["tunnel", "ells"]
)
@pytest.mark.parametrize("depth", [1e-4, 2e-3])
def test_sifting_the_pairings_compiled_equals_numpy(make, depth):
    """The pipeline's tests before the shapely one (geometry, keys, the last step's rows,
    distances where doubtful, plausibility), one compiled call against numpy: with half
    of the keys known from last step, deep overlapping blocks (vertices inside others)
    and a search distance that lets many deep pairings through."""
    model, blocks = make()
    c = model.contact
    pairs = candidate_pairs(blocks, c.search_distance)
    found = detect(blocks, pairs, c.search_distance, c.vertex_radius, c.law.tolerance)
    keys = contact_keys(blocks, found.vertex, found.edge)
    previous = np.random.default_rng(3).permutation(np.concatenate([keys[::2], [-5, 7]]))
    slack = narrow.OUTSIDE_FRACTION * c.search_distance
    args = (blocks, found, previous, c.search_distance, slack, depth, c.law.tolerance)
    compiled = pipeline._sift_compiled(*args)
    expected = pipeline._sift_numpy(*args)
    assert np.count_nonzero(~np.isnan(expected[5])) >= 5  # distances were needed
    assert 0 < np.count_nonzero(expected[4]) < len(found.vertex)  # some pairings refused
    for got, want in zip(compiled, expected, strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("seed", range(3))
def test_vertex_vertex_ties_keep_last_steps_pairing(seed):
    """At the corners of a wall every vertex-vertex candidate ties: round-off decides.

    Moved by 1e-9 at random, about half of the 42 pairings of a 4 x 3 wall
    turn to the other vertex (a new key, and the contact's history lost);
    given the last step's keys, none does.
    """
    model, blocks = wall_blocks(4, 3)
    c = model.contact
    pairs = candidate_pairs(blocks, c.search_distance)
    before = detect(blocks, pairs, c.search_distance, c.vertex_radius)
    keys = np.sort(contact_keys(blocks, before.vertex, before.edge))
    moved = blocks.copy()
    moved.vertices = moved.vertices + np.random.default_rng(seed).normal(
        scale=1e-9, size=moved.vertices.shape
    )

    def new_keys(previous_keys):
        found = detect(moved, pairs, c.search_distance, c.vertex_radius, np.inf, previous_keys)
        return np.setdiff1d(contact_keys(moved, found.vertex, found.edge), keys)

    # 8 on the base, 34 at the ends of shared edges; the 12 diagonal pairs at the 6 inner
    # nodes are separated by the blocks between them (dda.contact.node)
    assert len(keys) == 42
    assert len(new_keys(None)) > 10  # round-off alone turns them
    assert len(new_keys(keys)) == 0


def corner_blocks(gap: float):
    """A unit square and a wedge whose tip is ``gap`` right of the square's top-right
    corner (inside the square when negative) and 0.5 mm below its top edge's line."""

    tip = (1.0002, 0.9995)
    wedge = [tip, (1.5, 0.5), (1.5, 1.5)]
    raw = scene([block("square", rectangle(0, 0, 1, 1)), block("wedge", wedge)])
    blocks = build(dda.load_scene(raw)).blocks.copy()
    blocks.vertices[blocks.vertex_owner == 1, 0] += gap - 2e-4
    return blocks


@pytest.mark.parametrize("gap, kept", [(2e-4, False), (-2e-4, True)])
def test_a_new_pairing_behind_an_edge_line_needs_the_blocks_to_touch(gap, kept):
    """The wedge's tip is 0.5 mm behind the extended line of the square's top edge:
    a penetration only if the blocks touch (the tip inside the square), not when they
    are 0.2 mm apart (enforcing it would launch the wedge)."""

    blocks = corner_blocks(gap)
    tip = np.array([blocks.offsets[1]])
    top_edge = np.array([blocks.offsets[0] + 2])  # from (1, 1) to (0, 1)
    penetration, _, _ = edge_geometry(blocks, tip, top_edge)
    assert penetration[0] == pytest.approx(5e-4, rel=1e-6)
    asked = np.array([True])  # seen for the first time, deeper than the touch tolerance
    _, to_block = _distances_where(blocks, tip, top_edge, asked)
    assert _blocks_touch(blocks, tip, top_edge, to_block, asked, 1e-9)[0] == kept


def crack_neighbours():
    """Two fragments meeting along a crack line over 17 mm: each one's corner lies on the
    other's edge (an acute corner of the first, 60°), as in the repeated-fracture case."""

    p = np.array([0.78744, 0.71201])
    u = np.array([0.8377, 0.79809]) - p
    first = [p + u, (0.75537, 0.94229), (0.70523, 0.85545), p]
    second = [(0.85237, 0.57079), p + 0.17 * u, p - 0.991 * u, (0.81241, 0.49998)]
    raw = scene([block("first", first), block("second", second)])
    return build(dda.load_scene(raw))


def test_corners_on_each_others_edges_pair_with_those_edges():
    """The second fragment's corner is on the first's edge and behind the line of the
    first's other edge at that corner, beyond its end: it pairs with the edge it lies on
    (it used to pick the other, which the pipeline then refused: no contact at all, and
    the fragments sank into each other)."""

    model = crack_neighbours()
    blocks = model.blocks
    found = detect(blocks, np.array([[0, 1]]), model.contact.search_distance, 1.0)
    assert len(found.vertex) >= 1
    penetration, along, _ = edge_geometry(blocks, found.vertex, found.edge)
    np.testing.assert_allclose(penetration, 0.0, atol=1e-12)
    assert np.all((along >= 0.0) & (along <= 1.0))


@pytest.mark.parametrize("compiled", [True, False])
def test_a_corner_that_slid_past_the_other_hands_the_contact_over(monkeypatch, compiled):
    """Two blocks of a toppling stack (step 513 of the 20-block stack, offset 0.1 m): the
    upper block's bottom-right corner B1 slid right past the lower block's top-right
    corner A2 and lies 17 mm beyond it on the line of A's top edge; A2 lies on B's
    bottom edge. Both pairings are tied (both ~0 deep), and the last step's pairing was
    B1 on A's top edge. The pair is resolved with A2 on B's bottom edge, the edge it is
    on: keeping the last pairing (which the pipeline then refuses as beyond its edge)
    left the corner without a contact for a step; A2 entered B by 0.4 mm, was pushed
    out as a fresh deep contact, and such corners fed the stack 0.16 of its energy."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
    a = [(0.04435, 0.26332), (1.00925, 0.00075), (1.14055, 0.48322), (0.17564, 0.7458)]
    b = [(0.19288, 0.74284), (1.15734, 0.47864), (1.28945, 0.96088), (0.32499, 1.22509)]
    blocks = build(dda.load_scene(scene([block("a", a), block("b", b)]))).blocks
    search = 0.138  # the stack's search distance and vertex radius (its blocks move fast)
    a2, a_top = blocks.offsets[0] + 2, blocks.offsets[0] + 2  # A2, and A's edge A2 -> A3
    b1, b_bottom = blocks.offsets[1] + 1, blocks.offsets[1] + 0  # B1, and B's edge B0 -> B1
    last = contact_keys(blocks, np.array([b1]), np.array([a_top]))
    found = detect(blocks, np.array([[0, 1]]), search, search, 1.1e-3, last)
    right = blocks.vertices[found.vertex, 0] > 1.0  # the pair at the right-hand corners
    assert found.vertex[right].tolist() == [a2] and found.edge[right].tolist() == [b_bottom]
    penetration, along, _ = edge_geometry(blocks, found.vertex[right], found.edge[right])
    assert abs(penetration[0]) < 1e-4 and 0.0 <= along[0] <= 1.0


@pytest.mark.skipif(not dda.jit.numba_enabled(), reason="numba is not in use")
@pytest.mark.parametrize("seed", range(3))
def test_compiled_pairings_kept_equal_numpy(seed):
    """One row per vertex-edge pair, and of a vertex's opposed edges of one block only
    the shallower: the compiled pass against _first_of_each and _opposed_deeper, on
    random pairings (repeated, many opposed and behind both edges) of a jittered wall."""
    _, blocks = wall_blocks(4, 3, jitter=0.3, seed=seed)
    fans = narrow.VertexFans(blocks)
    rng = np.random.default_rng(seed)
    vertex = rng.integers(0, len(blocks.vertices), 2000)
    edge = rng.integers(0, len(blocks.vertices), 2000)
    edge[1000:] = blocks.offsets[blocks.vertex_owner[edge[1000:]]] + rng.integers(0, 4, 1000)
    vertex[1500:] = vertex[1000:1500]  # the same vertices with other edges of the blocks
    keep = narrow._first_of_each(vertex, edge)
    dropped = narrow._opposed_deeper(blocks, fans, vertex[keep], edge[keep])
    compiled = narrow._pairings_kernel(
        vertex, edge, blocks.vertices, fans.next.astype(np.int64), fans.reflex,
        blocks.vertex_owner.astype(np.int64), fans.outward, blocks.count,
    )  # fmt: skip
    assert dropped.sum() > 10
    np.testing.assert_array_equal(compiled, keep[~dropped])


def test_point_distances_compiled_equal_shapely(monkeypatch):
    """Distances to the boundary and to the block: the compiled loop against shapely, on a
    jittered wall and a concave U block, for points inside, outside, on edges and vertices."""

    u_shape = [(10, 0), (13, 0), (13, 3), (12, 3), (12, 1), (11, 1), (11, 3), (10, 3)]
    raw = scene([block("u", u_shape), block("box", rectangle(20, 0, 21, 1))])
    extra = build(dda.load_scene(raw)).blocks
    _, wall = wall_blocks(4, 4, jitter=1e-3)
    rng = np.random.default_rng(3)
    for blocks in (wall, extra):
        lo = blocks.vertices.min(axis=0) - 0.5
        hi = blocks.vertices.max(axis=0) + 0.5
        points = np.concatenate([lo + rng.random((300, 2)) * (hi - lo), blocks.vertices])
        rows = rng.integers(0, blocks.count, len(points))
        rows[300:] = blocks.vertex_owner  # every vertex against its own block: on the boundary
        compiled = pd.point_distances(blocks, points, rows)
        monkeypatch.setattr(pd, "_distances_kernel", None)
        reference = pd.point_distances(blocks, points, rows)
        monkeypatch.undo()
        np.testing.assert_allclose(compiled[0], reference[0], atol=1e-12)
        np.testing.assert_allclose(compiled[1], reference[1], atol=1e-12)
        assert np.any((reference[1] == 0.0) & (reference[0] > 1e-3))  # some points inside


def test_a_vertex_pair_takes_the_vertex_that_is_inside():
    """Two fragments of the repeated-fracture case (step 744): A's corner is 0.53 mm
    inside B, B's corner lies on A's edge. The pair is resolved with A's corner, not
    with B's (d = 0), which hid the overlap until the pairing turned and the 0.5 mm
    were pushed out in one step."""

    a = [(0.33982, 0.4952), (0.26576, 0.63764), (0.22053, 0.55961), (0.30402, 0.43905)]
    b = [(0.255, 0.61908), (0.34076, 0.75889), (0.28817, 0.85383), (0.2103, 0.69907)]
    raw = scene([block("a", a), block("b", [(x + 1.0, y) for x, y in b])])
    model = build(dda.load_scene(raw))
    blocks = model.blocks.copy()
    blocks.vertices[blocks.vertex_owner == 1, 0] -= 1.0  # into place: overlapping A
    found = detect(blocks, np.array([[0, 1]]), model.contact.search_distance, 1.0, 1e-5)
    inside = blocks.offsets[0] + 1  # A's corner (0.26576, 0.63764)
    assert list(found.vertex) == [inside]
    penetration, _, _ = edge_geometry(blocks, found.vertex, found.edge)
    assert penetration[0] == pytest.approx(5.3e-4, rel=0.05)


# --------------------------------- two pieces of a crack that ends on the parent's face

# a unit square broken along the crack from T = (0.4, 1) on its top face to (1, 0.4) on its
# right face: piece A below the crack, piece B (the top-right triangle) above it; the
# pieces' top edges lie along one line, and so do their right edges
PIECE_A = [(0.0, 0.0), (1.0, 0.0), (1.0, 0.4), (0.4, 1.0), (0.0, 1.0)]
PIECE_B = [(0.4, 1.0), (1.0, 0.4), (1.0, 1.0)]
SLID = np.array([2e-5, 7e-6])  # B moved by -SLID: into A, mostly along the top face
CRACK_DEPTH = SLID.sum() / np.sqrt(2.0)  # how far the crack faces cross
CRACK_LENGTH = 0.6 * np.sqrt(2.0)


def crack_pieces_scene(duration: float = 0.01) -> dda.Scene:
    """The two pieces on a fixed base, B pressed by 400 kN, B slid into A by SLID: its
    corner at T lies 7e-6 m below A's top edge and 1.9e-5 m behind A's crack face, A's
    corner at T outside B (above B's top edge) and behind B's crack face as deep (the
    auditor's rock column at step 5: the pieces of one fracture, 1.45e-5 and 7.1e-6 m).
    The scene loader refuses overlapping blocks: B is moved after loading."""
    raw = scene(
        [base(), block("a", PIECE_A), block("b", PIECE_B)],
        {"duration": duration, "time_step": 1e-3, "save_every": 1},
        {"tolerance": 1e-6, "penalty": 5e10},
    )
    raw["loads"] = [{"block": "b", "point": [0.8, 1.0], "force": [0.0, -4e5]}]
    loaded = dda.load_scene(raw)
    b = loaded.blocks[2]
    moved = dataclasses.replace(b, vertices=tuple(tuple(p - SLID) for p in np.array(b.vertices)))
    return dataclasses.replace(loaded, blocks=(*loaded.blocks[:2], moved))


@pytest.mark.parametrize("compiled", [True, False])
def test_the_crack_end_on_a_shared_face_keeps_a_contact(monkeypatch, compiled):
    """B's corner at T is inside A (behind A's top and crack lines), A's is not inside B:
    the vertex pair is resolved with B's corner on A's crack edge, 1.9e-5 m deep, and
    that corner is nearer A's top edge (7e-6 m), the edge along which B's own top edge
    lies. The pipeline used to refuse the pairing as nearer another edge: the crack's
    end at T had no contact (the auditor's pieces then overlapped by 1.5e-3 m²)."""
    if not compiled:
        for name in ("_detect_kernel", "_screen_kernel"):
            monkeypatch.setattr(narrow, name, None)
        for name in ("_refresh_kernel", "_sift_kernel"):
            monkeypatch.setattr(pipeline, name, None)
    model = build(crack_pieces_scene())
    blocks = model.blocks
    contacts = pipeline.refresh_contacts(blocks, ContactSet.empty(), model.contact)
    owner = blocks.vertex_owner
    between = (owner[contacts.vertex] != 0) & (owner[contacts.edge] != 0)
    points = blocks.vertices[contacts.vertex[between]]
    penetration, _, _ = edge_geometry(blocks, contacts.vertex[between], contacts.edge[between])
    at_t = np.linalg.norm(points - (0.4, 1.0), axis=1) < 1e-3
    assert at_t.sum() == 1  # one contact at the crack's end on the top face
    assert penetration[at_t][0] == pytest.approx(CRACK_DEPTH, rel=1e-6)


def test_pieces_of_a_crack_that_ends_on_a_shared_face_do_not_sink_into_each_other():
    """The pieces start overlapping by 1.6e-5 m² (the crack faces crossed by 1.9e-5 m);
    from the first step on they overlap by less than the contact tolerance times the
    crack's length (their vertices are within the tolerance of the other's edges). With
    no contact at T the load drove B 2.1e-4 m² into A in the first step."""
    result = dda.simulate(crack_pieces_scene())
    overlap = [
        shapely.Polygon(f.vertices[1]).intersection(shapely.Polygon(f.vertices[2])).area
        for f in result.frames
    ]
    assert overlap[0] == pytest.approx(CRACK_DEPTH * CRACK_LENGTH, rel=0.05)
    assert max(overlap[1:]) < 1e-6 * CRACK_LENGTH


@pytest.mark.parametrize("compiled", [True, False])
def test_a_corner_facing_an_edge_end_across_a_block_is_no_contact(monkeypatch, compiled):
    """3 x 1 wall, search distance 1.5 blocks: the top-right corner of the first block
    faces the top end of the third block's left edge, one block away. Projected within
    round-off of that end (1e-12 of the edge) it is no vertex-edge candidate (on a grid,
    round-off alone used to put thousands of such pairs in and out of the list each
    step); projected 1e-6 inside the edge it is one, as the search distance says."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
        monkeypatch.setattr(narrow, "_screen_kernel", None)
    model, blocks = wall_blocks(3, 1)
    first, third = 1, 3  # rows of the blocks at x = 2..3 and 4..5
    corner = blocks.offsets[first] + int(
        np.flatnonzero(
            np.all(
                blocks.vertices[blocks.offsets[first] : blocks.offsets[first + 1]] == [3.0, 2.0],
                axis=1,
            )
        )[0]
    )

    def pairs_with_the_corner(shift: float) -> int:
        moved = blocks.copy()
        rows = slice(moved.offsets[third], moved.offsets[third + 1])
        moved.vertices = moved.vertices.copy()
        moved.vertices[rows, 1] += shift
        moved.update_moments()
        found = detect(moved, candidate_pairs(moved, 1.5), 1.5, model.contact.vertex_radius)
        owner = moved.vertex_owner
        return int(np.sum((found.vertex == corner) & (owner[found.edge] == third)))

    assert pairs_with_the_corner(1e-12) == 0
    assert pairs_with_the_corner(1e-6) == 1


@pytest.mark.parametrize("compiled", [True, False])
def test_a_vertex_inside_a_sliver_is_in_contact_with_the_edge_it_entered(monkeypatch, compiled):
    """A needle-like block A pokes its tip into the tip of a sliver B (a 5.7° wedge),
    just behind B's bottom edge (1 mm) and 0.5 m in front of its top edge. Both edges
    pass the V-E tests, but their normals are 174° apart: two contacts would push the
    tip across the sliver in opposite directions, their forces cancelling however
    large the augmented Lagrangian made them (the tunnel case: 1e11 N, 8e7 J released).
    The vertex entered through the bottom edge: that is its one contact."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
        monkeypatch.setattr(narrow, "_screen_kernel", None)
    needle = [[5.0, 0.001], [-5.0, 0.3], [-5.0, -0.3]]
    sliver = [[0.0, 0.0], [10.0, 0.0], [10.0, 1.0]]
    far = [[0.0, 20.0], [1.0, 20.0], [1.0, 21.0]]
    model = build(dda.load_scene(scene([block("a", far), block("b", sliver)], {"steps": 1})))
    blocks = model.blocks.copy()
    blocks.vertices = np.concatenate([np.array(needle), np.array(sliver)])
    blocks.update_moments()
    c = model.contact
    found = detect(blocks, np.array([[0, 1]]), c.search_distance, c.vertex_radius)
    tip = found.vertex == 0
    assert sorted(found.edge[tip].tolist()) == [3]  # the bottom edge, (0, 0)-(10, 0)


@pytest.mark.parametrize("compiled", [True, False])
def test_a_corner_nested_in_a_reflex_corner_pairs_with_both_edges(monkeypatch, compiled):
    """A unit square in the inner corner of an L: its corner at the L's reflex corner is
    in contact with both of the corner's edges (the floor's and the wall's), the
    square's other corners with the face each lies on, and the L's corner with neither
    of the square's edges (a reflex vertex enters no edge)."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
        monkeypatch.setattr(narrow, "_screen_kernel", None)
    ell = [(-1.0, -1.0), (3.0, -1.0), (3.0, 0.0), (0.0, 0.0), (0.0, 3.0), (-1.0, 3.0)]
    raw = scene([block("L", ell, fixed=True), block("square", rectangle(0.0, 0.0, 1.0, 1.0))])
    model = build(dda.load_scene(raw))
    blocks = model.blocks
    c = model.contact
    found = detect(blocks, np.array([[0, 1]]), c.search_distance, c.vertex_radius)
    ell_at = blocks.offsets[0]
    corner = blocks.offsets[1]  # the square's (0, 0)
    pairs = {(int(v), int(e)) for v, e in zip(found.vertex, found.edge, strict=True)}
    floor, wall = ell_at + 2, ell_at + 3  # edges (3, 0)->(0, 0) and (0, 0)->(0, 3)
    assert {(corner, floor), (corner, wall)} <= pairs
    assert (corner + 1, floor) in pairs and (corner + 3, wall) in pairs
    assert len(pairs) == 4


# ------------------------------ faces overlapping by less than the vertex radius


def tilted_on_a_corner(theta: float = 0.005, steps: int = 200) -> dict:
    """A unit square B resting by its bottom-left corner on the top of a fixed unit square
    A, 0.2 m from A's top-right corner, its bottom face turned up by ``theta``: its
    weight, outside A, turns it down onto A's corner. The two corners (0.2 m apart) are
    within the vertex radius (g2 = 0.1: search distance 0.25 m), so they are one
    vertex-vertex pair, which stands for the face-to-face contact along the 0.2 m."""
    c, s = np.cos(theta), np.sin(theta)
    square = np.array(rectangle(0.0, 0.0, 1.0, 1.0)) @ np.array([[c, s], [-s, c]])
    return scene(
        [block("A", rectangle(0.0, 0.0, 1.0, 1.0), fixed=True),
         block("B", (square + [0.8, 1.0 + 1e-9]).tolist())],
        {"steps": steps, "time_step": 1e-3, "save_every": 5, "max_displacement_ratio": 0.1},
        {"method": "penalty", "penalty": 1e10},
    )  # fmt: skip


@pytest.mark.parametrize("compiled", [True, False])
def test_faces_overlapping_within_the_vertex_radius_are_held_at_both_ends(monkeypatch, compiled):
    """The vertex-vertex pair of B's corner and A's corner (above) gives both ends of the
    face-to-face contact: B's corner onto A's top edge and A's corner onto B's bottom
    edge. One pairing (A's corner, the one with the gap) left B's corner free to enter A
    (the tunnel's falling debris: a corner 1 mm into another block, 45 steps, no
    contact)."""
    if not compiled:
        monkeypatch.setattr(narrow, "_detect_kernel", None)
        monkeypatch.setattr(narrow, "_screen_kernel", None)
    model = build(dda.load_scene(tilted_on_a_corner()))
    blocks, c = model.blocks, model.contact
    found = detect(blocks, np.array([[0, 1]]), c.search_distance, c.vertex_radius)
    a_corner, b_corner = blocks.offsets[0] + 2, blocks.offsets[1]  # (1, 1) and (0.8, 1)
    a_top, b_bottom = blocks.offsets[0] + 2, blocks.offsets[1]  # edges leaving them
    pairs = {(int(v), int(e)) for v, e in zip(found.vertex, found.edge, strict=True)}
    assert pairs == {(a_corner, b_bottom), (b_corner, a_top)}


def test_a_block_turning_onto_a_corner_within_the_vertex_radius_does_not_enter_it():
    """B (above, penalty contact) turns down onto A's corner: the two blocks share no more
    area than their contacts' penetration makes (4e-9 m²; with one pairing B's corner
    sank 1.3e-4 m into A, 1.4e-5 m², nine times the deepest contact penetration), and no
    energy is made."""
    result = dda.simulate(dda.load_scene(tilted_on_a_corner()))
    worst = max(
        shapely.Polygon(f.vertices[0]).intersection(shapely.Polygon(f.vertices[1])).area
        for f in result.frames
    )
    summary = result.summary
    assert worst < 1e-7
    assert summary["deepest_overlap"] <= 2.0 * summary["max_penetration"]
    assert result.frames[-1].rotations[1] < -0.1  # it turned onto the corner
    excess, moved, _ = run_warnings.energy_excess(result.history, summary["initial_energy"])
    assert excess <= 1e-9 * moved


def flush_approach(front: float):
    """Fixed blocks A (x < 0) and C (x > 0), tops flush at y = 0, and B on A with its
    front corner at x = ``front``: (blocks, search distance, vertex radius, tolerance)."""
    raw = scene(
        [block("A", rectangle(-3, -1, 0, 0), fixed=True),
         block("C", rectangle(0, -1, 3, 0), fixed=True),
         block("B", rectangle(front - 1.0, 0.0, front, 1.0))],
    )  # fmt: skip
    model = build(dda.load_scene(raw))
    c = model.contact
    return model.blocks, c.search_distance, c.vertex_radius, c.law.tolerance


def approach_pairings() -> list[tuple[float, np.ndarray, np.ndarray, np.ndarray]]:
    """(front, vertex, edge, edge's blocks) of each detection as B's front corner comes up
    to the joint, 0.5 mm a step, each given the last one's keys and states: sliding for the
    pairings that touch (B slides on A at zero penetration), open for the others."""
    keys, last, out = None, None, []
    for front in np.arange(-0.02, 0.0101, 5e-4):
        blocks, search, radius, tolerance = flush_approach(front)
        pairs = np.array([[0, 2], [1, 2]])
        found = detect(blocks, pairs, search, radius, tolerance, keys, None, last)
        keys = contact_keys(blocks, found.vertex, found.edge)
        penetration, _, _ = edge_geometry(blocks, found.vertex, found.edge)
        touching = penetration >= -1e-12
        last = LastStep(found.vertex[touching], found.edge[touching], np.sort(keys[touching]))
        out.append((front, found.vertex, found.edge, blocks))
    return out


def test_a_corner_reaching_a_flush_joint_keeps_to_the_line_it_slid_along(monkeypatch):
    """B's front corner comes up to the joint of A and C: its pair with C's corner is
    paired along the flush line (normal ±y) from where those pairings are candidates
    (within the vertex-vertex slack) until it is past, never across it (normal ±x: C's
    side, covered by A, or B's front face), which the corner would hit as a wall. The
    numpy path finds the same pairings at every step."""
    compiled = approach_pairings()
    monkeypatch.setattr(narrow, "_detect_kernel", None)
    monkeypatch.setattr(narrow, "_screen_kernel", None)
    along_line = 0
    for (front, vertex, edge, blocks), (_, numpy_vertex, numpy_edge, _) in zip(
        compiled, approach_pairings(), strict=True
    ):
        np.testing.assert_array_equal(vertex, numpy_vertex)
        np.testing.assert_array_equal(edge, numpy_edge)
        owner = blocks.vertex_owner
        at_c = (owner[vertex] == 1) | (owner[edge] == 1)
        tangent = blocks.vertices[blocks.next_vertex[edge[at_c]]] - blocks.vertices[edge[at_c]]
        across = np.abs(tangent[:, 1]) > np.abs(tangent[:, 0])  # a vertical edge
        slack = 0.01 * flush_approach(front)[1]  # narrow.OUTSIDE_FRACTION of the search
        if front > -slack:
            assert not across.any(), f"paired across the line at front = {front:.4f}"
            along_line += 1
    assert along_line >= 20
