"""A block crossing the flush joint of two base blocks (their faces one line) slides on
as over one face: the corner that reaches the joint keeps to the line it slid along
(:mod:`dda.contact.line_continuation`). Without that rule the corner meets the far
block's side (covered by the near block) as a wall: a frictionless block at 0.5 m/s
comes back at 0.15 m/s, one pushed at 1.5 times its friction slides 21 % (Δt = 1e-3 s)
and 45 % (2.5e-4 s) short of ½ a t², and the slope's block 54 % short.

Each run is checked by ``run_checked``: energy never above E₀ + W, AL penetration within
the tolerance, finite values, areas."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from tests.helpers import G, rectangle
from tests.standing.checks import run_checked
from tests.standing.incline import largest_move
from tests.standing.scenes import block, placed, scene

FRICTION = 30.0  # degrees


def flush_joint(
    time_step: float,
    duration: float,
    front: float,
    speed: float = 0.0,
    push: float = 0.0,
    friction: float = FRICTION,
    slope: float = 0.0,
    mode: str = "dynamic",
) -> dict:
    """A 1 m block B resting on fixed block A (x < 0) whose top is flush with fixed
    block C's (x > 0), its front corner at x = ``front``, moving at ``speed`` along the
    face and pushed along it at its centroid by ``push`` × tan φ × its weight; the whole
    turned by ``slope`` degrees (downhill to the right)."""

    def turned(points):
        return placed(points, -slope, 0.0, 0.0)

    along = np.array([np.cos(np.radians(slope)), -np.sin(np.radians(slope))])
    raw = scene(
        [block("A", turned(rectangle(-3, -1, 0, 0)), fixed=True),
         block("C", turned(rectangle(0, -1, 3, 0)), fixed=True),
         block("B", turned(rectangle(front - 1.0, 0.0, front, 1.0)),
               velocity=[*(speed * along), 0.0])],
        {"time_step": time_step, "duration": duration, "max_displacement_ratio": 0.1,
         "mode": mode},
        friction=friction,
    )  # fmt: skip
    if push:
        weight = raw["materials"]["rock"]["density"] * G
        force = push * weight * np.tan(np.radians(friction)) * along
        centroid = placed([[front - 0.5, 0.5]], -slope, 0.0, 0.0)[0]
        raw["loads"] = [{"block": "B", "point": centroid, "force": force.tolist()}]
    return raw


def slid(result: dda.Result, slope: float = 0.0) -> float:
    """B's centroid displacement along the face."""
    along = np.array([np.cos(np.radians(slope)), -np.sin(np.radians(slope))])
    return float(result.final.displacements[2] @ along)


@pytest.mark.parametrize(
    "dt",
    [1e-3, 2.5e-4, pytest.param(1e-4, marks=pytest.mark.slow),
     pytest.param(5e-5, marks=pytest.mark.slow)],
)  # fmt: skip
def test_a_frictionless_block_crosses_the_joint_at_its_speed(dt):
    """At 0.5 m/s its front corner reaches the joint at 0.4 s; at 0.6 s it is 0.3 m on,
    at 0.5 m/s (0.15 m/s backwards without the rule): 1.9e-8 relative (its speed 1.3e-7) at
    every Δt from 1e-3 to 5e-5 s. The joint's corners under B's face rock it by 1e-7 rad;
    with a contact tolerance of 1e-9 instead of 1e-5, 2e-10 (1e-9)."""
    result = run_checked(flush_joint(dt, 0.6, -0.2, speed=0.5, friction=0.0))
    assert slid(result) == pytest.approx(0.3, rel=1e-7)
    assert result.final.velocities[2, 0] == pytest.approx(0.5, rel=1e-6)


@pytest.mark.parametrize(
    ("dt", "within"),
    [
        (1e-3, 5e-5),
        (5e-4, 1e-5),
        (2.5e-4, 1e-5),
        pytest.param(1e-4, 1e-5, marks=pytest.mark.slow),
        pytest.param(5e-5, 1e-5, marks=pytest.mark.slow),
    ],  # fmt: skip
)
def test_a_block_pushed_across_the_joint_slides_as_the_closed_form(dt, within):
    """Pushed at 1.5 times its friction from rest 5 cm before the joint, B slides
    ½ (0.5 tan φ g) t² (0.127 m in 0.3 s, across the joint at 0.19 s): −1.3e-5 relative
    at Δt = 1e-3 s, −2.0e-6, 6.1e-7, −1.0e-6 and −2.2e-6 at 5e-4, 2.5e-4, 1e-4 and 5e-5 s. Below
    5e-4 s what is left comes from the joint's two corners under B's face, which open
    and close by a nanometre as B rocks on them, not from Δt (a block that does not
    reach the joint slides to 1e-10)."""
    result = run_checked(flush_joint(dt, 0.3, -0.05, push=1.5))
    expected = 0.5 * (0.5 * np.tan(np.radians(FRICTION)) * G) * 0.3**2
    assert slid(result) == pytest.approx(expected, rel=within)


def test_a_block_sliding_down_a_slope_across_a_joint_slides_as_the_closed_form():
    """The flush pair turned to 35° (φ = 30°): B, released 5 cm above the joint, slides
    ½ g (sin θ − cos θ tan φ) t² across it (0.123 m in 0.5 s; it crosses at 0.32 s):
    −1.0e-5 relative at Δt = 5e-4 s (54 % short without the rule)."""
    result = run_checked(flush_joint(5e-4, 0.5, -0.05, slope=35.0))
    theta, phi = np.radians(35.0), np.radians(FRICTION)
    expected = 0.5 * G * (np.sin(theta) - np.cos(theta) * np.tan(phi)) * 0.5**2
    assert slid(result, 35.0) == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize(
    "dt",
    [1e-3, pytest.param(1e-4, marks=pytest.mark.slow), pytest.param(5e-5, marks=pytest.mark.slow)],
)
@pytest.mark.parametrize("front", [0.0, -0.005], ids=["at-the-joint", "within-the-slack"])
def test_a_block_with_its_corner_at_the_joint_stands_inside_its_friction(dt, front):
    """B's front corner on the joint or 5 mm before it (within the vertex-vertex slack),
    pushed towards C at 0.5 of its friction: it moves less than twice its static
    settlement + 1 µm."""
    result = run_checked(flush_joint(dt, 0.3, front, push=0.5))
    static = dda.simulate(dda.load_scene(flush_joint(1e-3, 0.3, front, push=0.5, mode="static")))
    assert largest_move(result) <= 2.0 * largest_move(static) + 1e-6


@pytest.mark.parametrize(
    ("dt", "within"),
    [(1e-3, 1e-4), (5e-4, 1e-5), (2.5e-4, 1e-5), pytest.param(1e-4, 1e-5, marks=pytest.mark.slow)],
)
def test_a_block_starting_at_rest_within_the_slack_slides_across_the_joint(dt, within):
    """Released from rest with its front corner 5 mm before the joint (the vertex-vertex
    slack is 7.5 mm), pushed at 1.5 times its friction: its corner has slid along no
    face yet, but the base block's corner under it slides along its bottom face, whose
    line the far block's face continues. It slides ½ (0.5 tan φ g) t² (0.127 m in 0.3 s):
    4.5e-5 relative at Δt = 1e-3 s, −3.7e-7, −3.7e-6 and −7.3e-7 at 5e-4, 2.5e-4 and 1e-4 s
    (6.9 mm in all, a wall at the joint, when only the lines a corner slid along
    counted). The 300 steps at Δt = 1e-3 s run the numpy path, the shorter steps the
    kernels."""
    result = run_checked(flush_joint(dt, 0.3, -0.005, push=1.5))
    expected = 0.5 * (0.5 * np.tan(np.radians(FRICTION)) * G) * 0.3**2
    assert slid(result) == pytest.approx(expected, rel=within)


def test_a_block_starting_at_rest_within_the_slack_slides_across_the_joint_leftwards():
    """The mirror image: B on C, its corner 5 mm right of the joint, pushed left at 1.5
    times its friction onto A: −0.127441 m against −0.127435 m of ½ a t² (4.5e-5; 6.9 mm
    when only the faces a corner slid along counted)."""
    raw = flush_joint(1e-3, 0.3, 1.005, push=1.5)
    raw["loads"][0]["force"][0] *= -1.0
    result = run_checked(raw)
    expected = -0.5 * (0.5 * np.tan(np.radians(FRICTION)) * G) * 0.3**2
    assert slid(result) == pytest.approx(expected, rel=1e-4)


def test_a_block_sliding_towards_a_wall_standing_at_the_joint_stops_at_it():
    """A fixed wall W stands on C with its face on the joint's line: B, its corner 5 mm
    before the joint and pushed at 1.5 times its friction, stops against W after 5 mm
    (its corner passes over A's corner at the joint, but W's face is no line it slides
    along): 5.001 mm, W's face the contact tolerance away."""
    raw = flush_joint(1e-3, 0.3, -0.005, push=1.5)
    raw["blocks"].append(block("W", rectangle(0, 0, 1, 1), fixed=True))
    result = run_checked(raw)
    assert slid(result) == pytest.approx(0.005, abs=1e-5)


def test_a_block_starting_at_rest_at_the_joint_slides_across_it():
    """Released from rest with its front corner on the joint, pushed at 1.5 times its
    friction: ½ (0.5 tan φ g) t² = 0.127 m in 0.3 s. Every pairing of the corner's node
    ties and no line has carried it yet; the corner's motion over the coming step (the
    push) decides the tie for the face it slides along (it met the far block as a wall
    and did not move while ties went by the order of the vertices)."""
    result = dda.simulate(dda.load_scene(flush_joint(1e-3, 0.3, 0.0, push=1.5)))
    expected = 0.5 * (0.5 * np.tan(np.radians(FRICTION)) * G) * 0.3**2
    assert slid(result) == pytest.approx(expected, rel=1e-3)
