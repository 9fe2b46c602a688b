"""The rows of a fracture case (verify.comparison.breaks): crack directions measured from
the pieces, the criterion's planes, and an onset on one side only."""

from __future__ import annotations

import numpy as np
import pytest

from verify.comparison.breaks import crack_directions, onset_rows
from verify.comparison.compare import Row, max_errors
from verify.fem.fracture import Strength, crack_planes

ROCK = Strength(cohesion=1e6, friction_angle=30.0, tensile_strength=0.5e6)  # C0 3.4641 MPa


def test_crack_directions_are_the_edges_two_pieces_share():
    # a 2 x 2 square cut through its centre along x and along the diagonal y = x
    pieces = [
        np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1]], float),  # below y=1, right of y=x
        np.array([[0, 0], [1, 1], [0, 1]], float),
        np.array([[1, 1], [2, 1], [2, 2]], float),
        np.array([[0, 1], [1, 1], [2, 2], [0, 2]], float),
    ]
    assert crack_directions(pieces) == pytest.approx([0.0, 45.0], abs=1e-12)


def test_outer_edges_are_not_cracks():
    halves = [np.array([[0, 0], [1, 0], [1, 2], [0, 2]], float),
              np.array([[1, 0], [2, 0], [2, 2], [1, 2]], float)]  # fmt: skip
    assert crack_directions(halves) == pytest.approx([90.0])


def test_crack_planes_of_the_criterion():
    c0 = ROCK.uniaxial
    # uniaxial compression along y beyond C0: shear planes at 90 +- (45 - 15)
    assert crack_planes(np.array([0.0, -1.01 * c0, 0.0]), ROCK) == pytest.approx([60.0, 120.0])
    # tension along x beyond T0: one plane along sigma1 (y)
    assert crack_planes(np.array([0.51e6, 0.0, 0.0]), ROCK) == pytest.approx([90.0])
    # the same uniaxial state turned by 30 deg: the planes turn with it
    turn = np.radians(30.0)
    c, s = np.cos(turn), np.sin(turn)
    rotation = np.array([[c, -s], [s, c]])
    tensor = rotation @ np.diag([0.0, -1.01 * c0]) @ rotation.T
    stress = np.array([tensor[0, 0], tensor[1, 1], tensor[0, 1]])
    assert crack_planes(stress, ROCK) == pytest.approx([90.0, 150.0])
    # inside the criterion: no plane
    assert crack_planes(np.array([0.0, -0.99 * c0, 0.0]), ROCK) == []


def test_an_onset_on_one_side_only_fails_and_none_on_both_agrees(monkeypatch):
    import verify.comparison.breaks as breaks

    scene = type("S", (), {"blocks": [type("B", (), {"name": n})() for n in ("a", "b", "c")]})()
    onset = type("O", (), {"factors": {0: 0.5, 1: float("nan"), 2: float("nan")}})()
    monkeypatch.setattr(breaks, "broken_factors", lambda result, scene: {"b": 0.4})
    expectation = type("E", (), {"offsets": {}})()
    rows = onset_rows(None, scene, onset, expectation)
    by_item = {row.item: row for row in rows}
    assert set(by_item) == {"a", "b"}  # c breaks on neither side: left out
    assert by_item["a"].error == np.inf and by_item["b"].error == np.inf
    assert max_errors(rows) == {"onset": np.inf}


def test_a_row_without_a_number_is_left_out_of_the_worst_error():
    rows = [Row("stress", "a", "sxx", 1.0, 1.1, 1.0), Row("stress", "b", "sxx", np.nan, 1.0, 1.0)]
    assert max_errors(rows) == {"stress": pytest.approx(0.1)}
