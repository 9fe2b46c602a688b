"""Awkward geometry: corners on corners, near-parallel edges, tiny edges, slivers."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from tests.helpers import rectangle
from tests.standing.checks import run_checked
from tests.standing.incline import largest_move
from tests.standing.scenes import base, block, diamond, placed, scene

H = np.sqrt(0.5)


@pytest.mark.parametrize("offset", [0.0, 1e-3], ids=["tip-on-tip", "tip-on-tip-offset"])
def test_corner_falls_onto_a_corner(offset):
    """A square on its corner dropped 1 cm onto the corner of a fixed one (vertex-vertex)."""
    blocks = [
        block("base", diamond(0.0, 0.0), fixed=True),
        block("b", diamond(offset, 2 * H + 0.01)),
    ]
    result = run_checked(scene(blocks, {"duration": 0.4}))
    # it lands on the tip and topples to one side: never below the fixed block's top
    assert result.final.centroids[1, 1] > H


@pytest.mark.parametrize("overlap", [0.0, 1e-6], ids=["corner", "corner-1e-6"])
def test_square_corner_lands_on_square_corner(overlap):
    """Bottom-left corner onto the top-right corner of a fixed block: it tips off the edge."""
    blocks = [
        block("base", rectangle(0, 0, 1, 1), fixed=True),
        block("b", rectangle(1 - overlap, 1.01, 2 - overlap, 2.01)),
    ]
    result = run_checked(scene(blocks, {"duration": 0.4}))
    assert result.final.centroids[1, 0] > 1.5  # it went off the right side


@pytest.mark.parametrize("tilt", [1e-3, 1e-5, 1e-7])
def test_near_parallel_edges_land_flat(tilt):
    """A block whose bottom is tilted by ``tilt`` rad lands on the flat base, flat.

    It may rock a little after landing (Shi's v1 = 2D/Δt − v0 rebounds from a
    rigid contact), but it neither tips nor sinks.
    """
    cube = rectangle(-0.5, -0.5, 0.5, 0.5)
    blocks = [base(), block("b", placed(cube, np.degrees(tilt), 0.5, 0.51))]
    result = run_checked(scene(blocks, {"duration": 0.2}))
    assert abs(result.final.rotations[1]) < 1e-2
    assert result.final.centroids[1, 1] > 0.49


@pytest.mark.parametrize("tilt", [1e-4, 1e-6])
def test_near_parallel_edges_slide(tilt):
    """The slope block of tests/helpers.py, tilted by ``tilt`` rad against the slope."""
    slope = placed(rectangle(0, -1, 10, 0), 30.0, 0.0, 0.0)
    slider = placed(placed(rectangle(4, 0, 5, 0.5), np.degrees(tilt), 0, 0), 30.0, 0, 0)
    blocks = [block("base", slope, fixed=True), block("b", slider)]
    result = run_checked(scene(blocks, {"duration": 0.5}, friction=20.0))
    moved = np.linalg.norm(result.final.displacements[1])
    # ½ g (sin 30 − cos 30 tan 20) t², less what the fall of tilt × 1 m costs on landing
    assert moved == pytest.approx(0.2266, rel=0.12)


def chamfered(y0: float, eps: float) -> list:
    """A unit square whose bottom-left corner is cut by an edge ``eps`` long."""
    return [(0, y0 + eps), (eps, y0), (1, y0), (1, y0 + 1), (0, y0 + 1)]


@pytest.mark.parametrize("drop", [0.0, 0.01], ids=["resting", "dropped"])
def test_edge_of_a_millionth_of_the_block(drop):
    result = run_checked(scene([base(), block("b", chamfered(drop, 1e-6))], {"duration": 0.2}))
    assert abs(result.final.displacements[1, 1] + drop) < 1e-4
    assert abs(result.final.rotations[1]) < 1e-6


def test_tiny_edge_corner_falls_first():
    """The 1e-6 edge is the first thing to touch: the block lands on it and topples."""
    cube = [(x - 0.5, y - 0.5) for x, y in chamfered(0.0, 1e-6)]
    result = run_checked(
        scene([base(), block("b", placed(cube, 30.0, 0.5, 0.8))], {"duration": 0.5})
    )
    assert result.final.centroids[1, 1] > 0.49  # on the base, not through it


@pytest.mark.parametrize("case", ["lying", "dropped", "tilted", "under-a-block", "standing"])
def test_sliver_of_aspect_ratio_thousand(case):
    sliver = rectangle(0, 0, 1, 0.001)
    blocks = {
        "lying": [base(), block("s", sliver)],
        "dropped": [base(), block("s", rectangle(0, 0.01, 1, 0.011))],
        "tilted": [base(), block("s", placed(rectangle(-0.5, -5e-4, 0.5, 5e-4), 20.0, 0.5, 0.3))],
        "under-a-block": [base(), block("s", sliver), block("b", rectangle(0, 0.001, 1, 1.001))],
        "standing": [base(), block("s", rectangle(0, 0, 0.001, 1))],
    }[case]
    result = run_checked(scene(blocks, {"duration": 0.3}))
    assert result.final.centroids[1, 1] > 0.0  # the sliver is on the base, not through it


# a fixed L whose inner (reflex) corner is at the origin: floor y ≤ 0, wall x ≤ 0
ELL = [(-1.0, -1.0), (3.0, -1.0), (3.0, 0.0), (0.0, 0.0), (0.0, 3.0), (-1.0, 3.0)]


@pytest.mark.parametrize("dt", [2e-3, 1e-4])
def test_a_block_nested_in_a_reflex_corner_stands(dt):
    """A unit square in the L's inner corner, pressed into both faces by gravity at
    (-0.8, -0.6) g, frictionless: its corner at the L's corner is paired with both of
    the corner's edges, so it stands where it is drawn (no motion beyond 1e-9 m, no
    energy made). Paired with one edge, the corner entered the other face within a
    step, the push-out threw it back, and the square turned 1.8e-3 rad in 0.3 s and
    gained 99 J (1.13 times the energy that moved)."""
    square = rectangle(0.0, 0.0, 1.0, 1.0)
    gravity = [-0.8 * 9.81, -0.6 * 9.81]
    raw = scene(
        [block("L", ELL, fixed=True), block("square", square)],
        {"gravity": gravity, "time_step": dt, "duration": 0.3 if dt > 1e-3 else 0.03},
        friction=0.0,
    )
    result = run_checked(raw)
    final = result.final
    moved = np.abs(final.vertices[final.block("square")] - np.array(square)).max()
    assert moved < 1e-9
    assert result.summary["warnings"] == []


# a fixed block with a V notch of 50° opening whose reflex tip is at the origin, and a
# 30° wedge whose tip hangs 1 µm above it
NOTCH_HALF_WIDTH = np.tan(np.radians(25.0))
V_NOTCH = [(-2.0, -2.0), (2.0, -2.0), (2.0, 1.0), (NOTCH_HALF_WIDTH, 1.0), (0.0, 0.0),
           (-NOTCH_HALF_WIDTH, 1.0), (-2.0, 1.0)]  # fmt: skip
WEDGE_HALF_WIDTH = 1.5 * np.tan(np.radians(15.0))
WEDGE = [(0.0, 1e-6), (WEDGE_HALF_WIDTH, 1.500001), (-WEDGE_HALF_WIDTH, 1.500001)]


@pytest.mark.parametrize("friction", [0.0, 30.0])
@pytest.mark.parametrize("dt", [2e-3, 1e-4])
def test_a_wedge_in_a_notch_narrower_than_90_degrees_stands(dt, friction):
    """The wedge settles onto the notch's tip: its tip is paired with both walls, which
    meet at the notch's reflex corner with normals more than 90° apart. The rule that
    drops the deeper of a vertex's two contacts with opposed edges (for slivers) took
    one of them away: the tip slid down the other wall's line into the rock (4.7 mm at
    Δt = 1e-4 s, no warning), or was thrown out with 3.6e4 J made (Δt = 2e-3 s); with
    30° friction the run stopped. Now the tip moves by its settlement (1 µm of gap and
    about 1 µm of contact and elastic settlement), no energy is made, at both Δt."""
    raw = scene(
        [block("V", V_NOTCH, fixed=True), block("wedge", WEDGE)],
        {"time_step": dt, "duration": 0.3 if dt > 1e-3 else 0.05},
        friction=friction,
    )
    result = run_checked(raw)
    tip = result.final.vertices[result.final.block("wedge")][0]
    assert abs(tip[0]) < 1e-9
    assert -3e-6 < tip[1] < 1e-6


def test_a_block_sliding_into_a_channels_inner_corner_meets_the_wall_flat():
    """A block slides frictionlessly along a U channel's floor (gravity tilted along it)
    into the inner corner at the far wall, faster than 1 % of the search distance a step
    (6 mm a step at Δt = 2e-3 s). Its leading corner is paired with the wall before it
    gets there: its face meets the wall flat and it bounces back without spinning
    (|ω| < 1e-9 rad/s), within the contact tolerance. The pairing was dropped while the
    corner was more than that from the wall (it lay on the floor, nearer another edge
    than the wall), and the corner crossed the wall by 2.9 mm, the block spinning off at
    3.1 rad/s."""
    channel = [(-2.0, -1.0), (2.0, -1.0), (2.0, 1.0), (1.0, 1.0), (1.0, 0.0), (-1.0, 0.0),
               (-1.0, 1.0), (-2.0, 1.0)]  # fmt: skip
    raw = scene(
        [block("U", channel, fixed=True), block("b", rectangle(-1.0, 0.0, 0.0, 0.8))],
        {"time_step": 2e-3, "duration": 0.66, "gravity": [4.905, -8.49546]},
        friction=0.0,
    )
    result = run_checked(raw)
    final = result.final
    assert abs(final.velocities[final.block("b"), 2]) < 1e-9
    assert final.velocities[final.block("b"), 0] < -0.5  # bounced back


@pytest.mark.parametrize("dt", [2e-3, 1e-4])
def test_a_block_sliding_under_a_thin_floor_meets_no_phantom_wall(dt):
    """An L whose floor is 1 cm thick (thinner than the vertex radius, 0.1 m) and a
    block sliding frictionlessly 1 mm under that floor, on fixed ground, towards the
    line of the L's inner wall: its corner, 5 cm from that line, is behind the floor's
    top line only by extension (it is outside the L), so it is no corner nested in the
    L's reflex corner and gets no pairing with the wall. It slides on at the closed form
    vx = −g t / 2 (1e-9), without spinning, at Δt = 2e-3 and 1e-4 s. Paired with the
    wall, it hit the wall's line through the floor at 0.13 s and slowed to −0.98 m/s,
    spinning at 0.17 rad/s."""
    floor = 0.01
    ell = [(-1.0, -floor), (3.0, -floor), (3.0, 0.0), (0.0, 0.0), (0.0, 3.0), (-1.0, 3.0)]
    top = -floor - 1e-3
    raw = scene(
        [
            block("L", ell, fixed=True),
            block("ground", rectangle(-4.0, top - 2.0, 4.0, top - 1.0), fixed=True),
            block("A", rectangle(0.05, top - 1.0, 1.05, top)),
        ],
        {"gravity": [-0.5 * 9.81, -9.81], "duration": 0.3, "time_step": dt},
        friction=0.0,
    )
    result = run_checked(raw)
    vx, _, omega = result.final.velocities[result.final.block("A")]
    assert vx == pytest.approx(-0.5 * 9.81 * 0.3, rel=1e-9)
    assert abs(omega) < 1e-12


@pytest.mark.parametrize("dt", [1e-3, 1e-4])
@pytest.mark.parametrize("kink", [None, 2.0], ids=["flat", "kink-2"])
def test_a_bonded_block_over_a_kink_holds_and_slides_as_on_a_flat_base(kink, dt):
    """A unit square bonded to a fixed base (c = T = 1e4 Pa, φ = 0) under a horizontal
    pull of gravity: 5e3 N holds it where it stands (within 1e-6 m) and 6e3 N slides it,
    on a flat base and on one bent up by 2° under its corner, at both Δt. Over the kink
    its corner is two contacts, which carried the bottom edge's bonded length twice: it
    held up to 9e3 N."""
    import math

    if kink is None:
        base = [(-3, -1), (3, -1), (3, 0), (-3, 0)]
    else:
        base = [(-3, -1), (3, -1), (3, 0), (0, 0), (-3, 3 * math.tan(math.radians(kink)))]
    moved = {}
    for force in (5e3, 6e3):
        raw = scene(
            [block("base", base, fixed=True), block("b", rectangle(0, 0, 1, 1))],
            {"gravity": [force / 2500.0, -9.81], "duration": 0.05, "time_step": dt},
        )
        raw["joints"] = {"default": {"friction_angle": 0.0, "cohesion": 1e4,
                                     "tensile_strength": 1e4}}  # fmt: skip
        result = run_checked(raw)
        moved[force] = abs(result.final.displacements[result.final.block("b"), 0])
    assert moved[5e3] < 1e-6
    assert moved[6e3] > 1e-3


def bridge(time_step: float, push: float, duration: float, mode: str = "dynamic") -> dict:
    """A 0.9 x 1 m block B bridging two fixed blocks 0.5 m apart, resting 0.2 m on each
    (g2 = 0.1: vertex radius 0.225 m, so at each support B's corner over the support's
    top and the support's corner under B's bottom are one vertex-vertex pair, which
    stands for the face-to-face contact: both ends paired), pushed sideways at its
    centroid by ``push`` × tan φ W (φ = 30°)."""
    raw = scene(
        [block("A", rectangle(0, 0, 1, 1), fixed=True),
         block("C", rectangle(1.5, 0, 2.5, 1), fixed=True),
         block("B", rectangle(0.8, 1.0, 1.7, 2.0))],
        {"time_step": time_step, "duration": duration, "max_displacement_ratio": 0.1,
         "mode": mode},
    )  # fmt: skip
    weight = raw["materials"]["rock"]["density"] * 9.81 * 0.9
    force = push * weight * np.tan(np.radians(30.0))
    raw["loads"] = [{"block": "B", "point": [1.25, 1.5], "force": [force, 0.0]}]
    return raw


@pytest.mark.parametrize("dt", [1e-3, pytest.param(1e-4, marks=pytest.mark.slow)])
def test_a_block_held_at_both_ends_of_its_faces_stands_inside_its_friction(dt):
    """B pushed at 0.5 of its friction moves less than twice its static settlement
    (1.8e-6 m) + 1 µm, on four contacts (both ends of both faces)."""
    result = run_checked(bridge(dt, 0.5, 0.3))
    static = dda.simulate(dda.load_scene(bridge(1e-3, 0.5, 0.3, "static")))
    assert len(result.frames[-1].contacts.points) == 4
    assert largest_move(result) <= 2.0 * largest_move(static) + 1e-6


@pytest.mark.parametrize("dt", [1e-3, 2.5e-4, pytest.param(1e-4, marks=pytest.mark.slow)])
def test_a_block_held_at_both_ends_of_its_faces_slides_as_the_closed_form(dt):
    """B pushed at 1.5 of its friction slides ½ (0.5 tan φ g) t² (0.0566 m in 0.2 s,
    the left overlap growing past the vertex radius on the way): −1.5e-7, −6.1e-8,
    −2.9e-8 relative at Δt = 1e-3, 2.5e-4, 1e-4 s (falling as Δt shrinks), within 1e-6;
    the energy never above E0 + W (checked by run_checked)."""
    result = run_checked(bridge(dt, 1.5, 0.2))
    expected = 0.5 * (0.5 * np.tan(np.radians(30.0)) * 9.81) * 0.2**2
    slid = result.final.displacements[2, 0]
    assert slid == pytest.approx(expected, rel=1e-6)
