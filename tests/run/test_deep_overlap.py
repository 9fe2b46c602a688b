"""Blocks that overlap deeper than their contacts: measured at the saved frames, said in
the summary (``deepest_overlap``) and, where no contact holds them, in a warning."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

import dda
import dda.run.simulation as simulation
from dda.contact.contact_set import ContactSet
from dda.model import build
from dda.run.deep_overlap import Overlap, deepest_overlap, overlap_warning
from tests.helpers import rectangle
from tests.standing.scenes import base, block, scene


def test_the_depth_of_a_strip_two_blocks_share_is_its_width():
    """Two unit squares drawn 1 mm apart and moved 3 mm into each other share a strip
    3 mm × 1 m: its depth 2 A / P is 3 mm (to the strip's ends, 0.3 %)."""
    raw = scene([block("a", rectangle(0.0, 0.0, 1.0, 1.0)), block("b", rectangle(1.001, 0, 2, 1))])
    blocks = build(dda.load_scene(raw)).blocks.copy()
    blocks.vertices[blocks.vertex_owner == 1, 0] -= 0.004
    blocks.update_moments()
    found = deepest_overlap(blocks, 0.5)
    assert (found.first, found.second, found.time) == ("a", "b", 0.5)
    assert found.area == pytest.approx(0.003, rel=1e-9)
    assert found.depth == pytest.approx(0.003, rel=4e-3)


def test_blocks_that_touch_share_nothing():
    raw = scene([base(), block("a", rectangle(0.0, 0.0, 1.0, 1.0))])
    assert deepest_overlap(build(dda.load_scene(raw)).blocks, 0.0) is None


@pytest.mark.parametrize(
    ("depth", "penetration", "warned"),
    [(1e-3, 1e-4, False), (0.05, 1e-4, True), (0.05, 0.03, False)],
)
def test_an_overlap_is_said_where_no_contact_accounts_for_it(depth, penetration, warned):
    """Said when deeper than 1 % of the smallest free block's size (1 m here) and than
    twice the deepest contact penetration."""
    overlap = Overlap(depth, 0.01, "a", "b", 0.25)
    text = overlap_warning(overlap, penetration, 1.0, ("m", "s"))
    assert (text is not None) == warned
    if warned:
        assert "'a' and 'b'" in text and "t = 0.25 s" in text


def test_a_run_that_misses_a_contact_says_so(monkeypatch):
    """A block falling onto its base with every contact withheld sinks into it: the run
    ends with the warning naming both blocks, and its summary's deepest overlap."""
    monkeypatch.setattr(
        simulation, "refresh_contacts", lambda blocks, *args, **kwargs: ContactSet.empty()
    )
    raw = scene([base(), block("a", rectangle(0.0, 0.01, 1.0, 1.01))],
                {"steps": 60, "save_every": 10, "start": "unloaded"})  # fmt: skip
    result = dda.simulate(dda.load_scene(raw))
    summary = result.summary
    assert summary["deepest_overlap"] > 0.05
    assert any("'base' and 'a'" in text for text in summary["warnings"])


def test_blocks_that_share_an_edge_one_ulp_apart_share_no_area():
    """Two blocks of a model at rest share an edge whose end differs by one ulp (y =
    0.7313042213900082 and ...83): GEOS 3.14's intersection returned the whole of one
    (3.77 m², "about 0.836 m deep", a warning on a model that had not moved)."""
    from dda.scene.overlap import sharing_area

    a = [
        [9.43166760662, -2.1312624610300044],
        [8.38977854062, 0.7313042213900082],
        [5.3119301951199995, -1.0456923494099994],
        [6.353819261119999, -3.9082590318299975],
    ]
    b = [[10.0, 1.6609660144200007], [8.38977854062, 0.7313042213900083],
         [9.43166760662, -2.1312624610300044], [10.0, -1.803135600719996]]  # fmt: skip
    vertices = np.array(a + b)
    offsets = np.array([0, 4, 8])
    polygons = np.array([shapely.Polygon(a), shapely.Polygon(b)])
    areas = shapely.area(polygons)
    left, right, shared = sharing_area(polygons, vertices, offsets, areas, 1e-9)
    assert len(left) == 0
    # and a real overlap is still measured: b moved 0.1 into a
    moved = np.array(b) - [0.1, 0.0]
    polygons = np.array([shapely.Polygon(a), shapely.Polygon(moved)])
    vertices = np.array(a + moved.tolist())
    left, right, shared = sharing_area(polygons, vertices, offsets, areas, 1e-9)
    assert len(left) == 1
    assert shapely.area(shared[0]) == pytest.approx(
        shapely.intersection(polygons[0], polygons[1]).area, rel=1e-9
    )
