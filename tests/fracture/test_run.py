"""The fracture effect in the engine: breaking blocks, the new BlockSet, whole runs."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import shapely

import dda
from dda.effects.base import StepContext
from dda.fracture.criterion import strength_numbers
from dda.model import build
from dda.run.run_warnings import energy_excess

CASE = Path(__file__).resolve().parents[2] / "cases" / "paper_uniaxial_fracture.toml"
S0, PHI, T0 = 1.78e5, 39.1, 0.85e5  # the paper's rock, psf and degrees
N_PHI, C0, SIGMA1C = strength_numbers(S0, math.radians(PHI), T0)
HALF_ANGLE = 45.0 - PHI / 2  # shear planes to sigma1, degrees (25.45)
ROCK = {"density": 4.0405, "young": 1.0e8, "poisson": 0.25}
STRONG = {**ROCK, "cohesion": S0, "friction_angle": PHI, "tensile_strength": T0}


def rect(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def assert_valid_blocks(frame: dda.Frame) -> None:
    assert np.all(np.isfinite(frame.centroids)) and np.all(np.isfinite(frame.stresses))
    for ring in frame.vertices:
        assert np.all(np.isfinite(ring))
        polygon = shapely.Polygon(ring)
        assert polygon.is_valid and polygon.area > 0.0
        x, y = ring[:, 0], ring[:, 1]
        assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0.0  # CCW


def edge_angles(ring: np.ndarray) -> np.ndarray:
    """Direction of every edge, degrees in [0, 180)."""
    e = np.roll(ring, -1, axis=0) - ring
    return np.degrees(np.arctan2(e[:, 1], e[:, 0])) % 180.0


def crack_angles_from_vertical(rings: list[np.ndarray], axis_tol: float = 5.0) -> np.ndarray:
    """Angles (deg, signed, from the y axis) of the edges that are not near x or y (cracks)."""
    angles = np.concatenate([edge_angles(r) for r in rings])
    from_vertical = (angles - 90.0 + 90.0) % 180.0 - 90.0
    axis_aligned = (np.abs(from_vertical) < axis_tol) | (
        np.abs(np.abs(from_vertical) - 90) < axis_tol
    )
    return from_vertical[~axis_aligned]


# ------------------------------------------------------ the effect on its own


def effect_scene(edge_joints=None) -> dict:
    """Three free blocks far apart: 'a' and 'b' breakable, 'c' not."""
    a = {"name": "a", "material": "rock", "vertices": rect(0, 0, 1.6, 4.0)}
    if edge_joints:
        a["edge_joints"] = edge_joints
    return {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 1},
        "materials": {"rock": STRONG, "plain": ROCK},
        "joints": {"crack": {"friction_angle": 30.0}, "rough": {"friction_angle": 40.0}},
        "fracture": {"joint": "crack"},
        "blocks": [
            a,
            {"name": "b", "material": "rock", "vertices": rect(10, 0, 11.6, 4.0)},
            {"name": "c", "material": "plain", "vertices": rect(20, 0, 21.6, 4.0)},
        ],
    }


def effect_and_blocks(raw: dict):
    model = build(dda.load_scene(raw))
    return model.fracture, model.blocks.copy(), list(model.scene.joints)


CTX = StepContext(dt=0.01, time=0.5, step=7, static=True)


def test_only_failing_breakable_blocks_break_in_shear_into_four():
    effect, blocks, joints = effect_and_blocks(effect_scene())
    blocks.stress[:] = [[0.0, -1.02 * C0, 0.0], [0.0, -0.98 * C0, 0.0], [0.0, -10 * C0, 0.0]]
    new, events = effect.after_step(blocks, CTX)
    assert [(e.step, e.time, e.parent, e.mode) for e in events] == [(7, 0.5, "a", "shear")]
    assert events[0].children == ("a/1", "a/2", "a/3", "a/4")
    assert new.names == ["b", "c", "a/1", "a/2", "a/3", "a/4"]
    assert new.ids.tolist() == [1, 2, 3, 4, 5, 6]
    assert new.area[2:].sum() == pytest.approx(1.6 * 4.0, rel=1e-12)
    np.testing.assert_array_equal(new.stress[2:], np.tile(blocks.stress[0], (4, 1)))
    np.testing.assert_array_equal(new.material[2:], [0, 0, 0, 0])
    assert not new.fixed.any()
    # the two planes through the centroid at ±(45° − φ/2) to sigma1 (the y axis)
    rings = [new.polygon(k) for k in range(2, 6)]
    cracks = crack_angles_from_vertical(rings)
    np.testing.assert_allclose(np.sort(np.unique(np.round(cracks, 9))), [-HALF_ANGLE, HALF_ANGLE])


def test_crack_edges_get_the_crack_joint_and_old_edges_keep_theirs():
    effect, blocks, joints = effect_and_blocks(effect_scene(["rough", "", "rough", ""]))
    blocks.stress[0] = [0.0, -1.02 * C0, 0.0]
    new, _ = effect.after_step(blocks, CTX)
    crack, rough = joints.index("crack"), joints.index("rough")
    for k in range(2, 6):
        ring = new.polygon(k)
        joint = new.edge_joint[new.offsets[k] : new.offsets[k + 1]]
        angles = edge_angles(ring)
        horizontal = np.isclose(angles % 180, 0.0, atol=1e-6) | np.isclose(angles, 180.0)
        vertical = np.isclose(angles, 90.0, atol=1e-6)
        assert np.all(joint[horizontal] == rough)  # bottom and top edges of 'a'
        assert np.all(joint[vertical] == -1)  # its sides: the default joint
        assert np.all(joint[~horizontal & ~vertical] == crack)


def test_pieces_keep_the_parent_motion():
    effect, blocks, _ = effect_and_blocks(effect_scene())
    blocks.stress[0] = [0.0, -1.02 * C0, 0.0]
    blocks.velocity[0] = [1.0, -2.0, 0.3, 1e-3, -2e-3, 5e-4]
    blocks.rotation[0] = 0.2
    new, _ = effect.after_step(blocks, CTX)
    mass = new.area[2:]
    momentum = (mass[:, None] * new.velocity[2:, :2]).sum(axis=0)
    np.testing.assert_allclose(momentum, blocks.area[0] * blocks.velocity[0, :2], rtol=1e-12)
    np.testing.assert_array_equal(new.velocity[2:, 2:], np.tile(blocks.velocity[0, 2:], (4, 1)))
    np.testing.assert_array_equal(new.rotation[2:], 0.2)


def test_one_split_per_step_and_ids_never_reused():
    effect, blocks, _ = effect_and_blocks(effect_scene())
    blocks.stress[0] = [0.0, -1.02 * C0, 0.0]
    first, _ = effect.after_step(blocks, CTX)
    assert first.count == 6  # the children are judged at the next step only
    second, events = effect.after_step(first, StepContext(0.01, 0.51, 8, True))
    assert {e.parent for e in events} == {"a/1", "a/2", "a/3", "a/4"}  # inherited stress
    assert all(len(set(e.children)) == len(e.children) for e in events)
    assert len(set(second.ids.tolist())) == second.count
    assert second.ids[2:].min() > first.ids.max()
    assert second.area[2:].sum() == pytest.approx(1.6 * 4.0, rel=1e-12)
    assert all(name.count("/") == 2 for name in second.names[2:])


def test_tension_splits_across_the_pull():
    effect, blocks, joints = effect_and_blocks(effect_scene())
    blocks.stress[:2] = [[1.02 * T0, 0.0, 0.0], [0.98 * T0, 0.0, 0.0]]
    new, events = effect.after_step(blocks, CTX)
    assert [(e.parent, e.mode, len(e.children)) for e in events] == [("a", "tension", 2)]
    crack = joints.index("crack")
    for k in (2, 3):
        ring = new.polygon(k)
        is_crack = new.edge_joint[new.offsets[k] : new.offsets[k + 1]] == crack
        assert is_crack.sum() == 1
        start, end = ring[is_crack][0], np.roll(ring, -1, axis=0)[is_crack][0]
        np.testing.assert_allclose([start[0], end[0]], [0.8, 0.8])  # along y through the centroid
        assert abs(start[1] - end[1]) == pytest.approx(4.0)


def compressed_beside_a_fixed_block(min_area: float):
    """(blocks, blocks after the effect's step, events): the effect scene's 'a' fixed, both
    blocks at 2 C0 in compression, ``min_area`` the smallest piece."""
    raw = effect_scene()
    raw["blocks"][0]["fixed"] = True
    raw["fracture"]["min_area"] = min_area
    effect, blocks, _ = effect_and_blocks(raw)
    blocks.stress[:2] = [0.0, -2.0 * C0, 0.0]
    return blocks, *effect.after_step(blocks, CTX)


def test_fixed_blocks_and_too_small_blocks_stay_whole():
    """'b' (6.4 ft²) is smaller than two pieces of min_area = 3.3: not even cut."""
    blocks, new, events = compressed_beside_a_fixed_block(3.3)
    assert events == [] and new is blocks


def test_a_block_whose_four_shear_pieces_are_too_small_breaks_along_one_plane():
    """'b' (6.4 ft²) at min_area = 2.0: its four shear pieces (1.4 to 1.8) are below it
    and merged back into the whole block, which stayed beyond its strength (an audit);
    it breaks along one shear plane alone, into two pieces of 3.2."""
    _, new, events = compressed_beside_a_fixed_block(2.0)
    (event,) = events
    assert event.mode == "shear" and len(event.children) == 2
    pieces = [new.names.index(name) for name in event.children]
    assert new.area[pieces] == pytest.approx([3.2, 3.2], rel=1e-9)


# ------------------------------------------------------ runs through the engine


def platen_scene(ratio: float, steps: int = 8) -> dict:
    """Rock 1.6 x 4 between frictionless platens, static, mean stress ratio x C0."""
    force = ratio * C0 * 1.6 / 2
    return {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": steps, "save_every": 1},
        "materials": {"rock": STRONG, "platen": ROCK},
        "joints": {"crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack"},
        "blocks": [
            {
                "name": "bottom",
                "material": "platen",
                "fixed": True,
                "vertices": rect(-1, 0, 1, 1.4),
            },
            {"name": "rock", "material": "rock", "vertices": rect(-0.8, 1.4, 0.8, 5.4)},
            {"name": "top", "material": "platen", "vertices": rect(-1, 5.4, 1, 6.8)},
        ],
        "loads": [
            {"block": "top", "point": [-0.4, 6.8], "force": [0.0, -force]},
            {"block": "top", "point": [0.4, 6.8], "force": [0.0, -force]},
        ],
    }


def test_uniaxial_compression_through_platens_breaks_in_shear_above_c0():
    result = dda.simulate(platen_scene(1.02))
    first = result.fracture_events[0]
    assert (first.parent, first.mode, len(first.children)) == ("rock", "shear", 4)
    frame = next(f for f in result.frames if f.step == first.step)
    rings = [frame.vertices[frame.block(name)] for name in first.children]
    cracks = crack_angles_from_vertical(rings)
    assert len(cracks) >= 4
    assert np.all(np.abs(np.abs(cracks) - HALF_ANGLE) < 0.5)
    for f in result.frames:
        assert_valid_blocks(f)


def test_uniaxial_compression_below_c0_does_not_break():
    result = dda.simulate(platen_scene(0.98))
    assert result.fracture_events == []
    rock = result.final.block("rock")
    # the mean stress settled at 2 % below C0 (less 0.18 %: the rock got wider)
    assert result.final.stresses[rock, 1] == pytest.approx(-0.98 * C0, rel=3e-3)


def free_block_scene(time_step: float, duration: float, min_area: float = 1e-3) -> dict:
    """The rock 1.6 x 4 alone, given syy = -1.2 C0 and released on unloaded springs (the
    equilibrium start lets a free block's stress go before step 1): its cascade against
    the time step and min_area, here a fraction of the block's area (1e-3: the default;
    docs/fracture.md)."""
    return {
        "analysis": {"time_step": time_step, "duration": duration, "start": "unloaded"},
        "materials": {"rock": STRONG},
        "fracture": {"min_area": min_area * 1.6 * 4.0},
        "blocks": [{"name": "a", "material": "rock", "vertices": rect(0, 0, 1.6, 4.0),
                    "stress": [0.0, -1.2 * C0, 0.0]}],
    }  # fmt: skip


def test_a_free_block_beyond_c0_breaks_one_generation_a_step():
    """1 -> 4 -> 16 in two steps: the pieces inherit the stress that broke their parent."""
    result = dda.simulate(free_block_scene(2e-5, 4e-5), keep_frames=False)
    assert (result.final.step, len(result.final.names)) == (2, 16)


def test_a_loaded_block_that_breaks_in_shear_gives_its_load_to_one_of_its_pieces():
    """The load point moves to the piece that holds it, though the pieces differ in shape."""
    force = 1.05 * C0 * 1.6
    scene = {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 3, "save_every": 1},
        "materials": {"rock": STRONG},
        "joints": {"crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack"},
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True, "vertices": rect(-1, -1, 2.6, 0)},
            {"name": "rock", "material": "rock", "vertices": rect(0, 0, 1.6, 4.0)},
        ],
        "loads": [{"block": "rock", "point": [0.8, 4.0], "force": [0.0, -force]}],
    }
    result = dda.simulate(scene)
    first = result.fracture_events[0]
    assert (first.parent, first.mode, len(first.children)) == ("rock", "shear", 4)
    frame = next(f for f in result.frames if f.step == first.step)
    assert len({len(frame.vertices[frame.block(name)]) for name in first.children}) > 1
    for f in result.frames:
        assert_valid_blocks(f)


def test_the_pieces_of_a_single_block_touch_each_other():
    """A scene of one breakable block (a specimen on a pin, pressed on top) has contacts:
    its pieces push on each other instead of passing through (without them the loaded top
    cone sank 0.028 m² into each side wedge in 60 steps, with no word)."""
    scene = {
        "analysis": {"mode": "dynamic", "time_step": 1e-4, "steps": 60, "save_every": 1},
        "materials": {"rock": {**ROCK, "young": 1e10, "density": 2600.0, "cohesion": 1e6,
                               "friction_angle": 30.0, "tensile_strength": 0.5e6}},
        "fracture": {"min_area": 0.3},
        "blocks": [{"name": "specimen", "material": "rock", "vertices": rect(0, 0, 1, 2),
                    "fixed_points": [[0.5, 0.0]]}],
        "loads": [{"block": "specimen", "point": [0.5, 2.0], "force": [0.0, -8e6],
                   "history": [[0.0, 0.0], [0.002, 1.0]]}],
    }  # fmt: skip
    result = dda.simulate(scene)
    assert [(e.parent, e.mode) for e in result.fracture_events][:1] == [("specimen", "shear")]
    assert any(name.startswith("contact") for name in result.summary["active_effects"])
    pieces = [shapely.Polygon(ring) for ring in result.final.vertices]
    assert len(pieces) >= 2
    overlap = max(a.intersection(b).area for i, a in enumerate(pieces) for b in pieces[i + 1 :])
    assert overlap < 1e-4  # m², against the pieces' 0.43 m²: the contacts' give only


@pytest.mark.parametrize(
    "dt, far",
    [(1e-4, True), (1e-4, False),
     pytest.param(3e-5, False, marks=pytest.mark.slow),
     pytest.param(1e-5, False, marks=pytest.mark.slow),
     (1e-5, True)],
)  # fmt: skip
def test_rock_crushed_between_platens_makes_no_energy(dt, far):
    """A rock column pressed by a free platen breaks in shear, and its pieces' corners
    slip between pieces that part at the crack junction into other pieces, found there
    already overlapping (a top cone's apex 0.46 mm into the bottom cone): those overlaps
    go by position, not by their springs, and the push drives no piece into a third
    (at Δt = 1e-5 s one pushed into its neighbour left 665 J, 6.4 % of what moved). The
    blocks' energy stays within E0 + W at every step, at Δt = 1e-4, 3e-5 and 1e-5 s, with
    and without a far block falling freely, which sets the model's size and with it the
    contact tolerance, 0.75 mm (without the push-out: up to 2.4 kJ, 24 % of what moved,
    with it; 119, 16 and 223 J without it)."""
    platen = {"density": 2600.0, "young": 1e10, "poisson": 0.25}
    rock = {**platen, "cohesion": 1e6, "friction_angle": 30.0, "tensile_strength": 0.5e6}
    scene = {
        "analysis": {"mode": "dynamic", "time_step": dt, "duration": 0.004,
                     "gravity": [0.0, -9.81]},
        "materials": {"rock": rock, "platen": platen},
        "joints": {"default": {"friction_angle": 0.0}},
        "fracture": {"min_area": 0.1},
        "blocks": [
            {"name": "bottom", "material": "platen", "fixed": True,
             "vertices": rect(-1.5, -1.0, 1.5, 0.0)},
            {"name": "rock", "material": "rock", "vertices": rect(-0.5, 0.0, 0.5, 2.0)},
            {"name": "top", "material": "platen", "vertices": rect(-1.0, 2.0, 1.0, 2.5)},
        ],
        "loads": [{"block": "top", "point": [0.0, 2.5], "force": [0.0, -4e6],
                   "history": [[0.0, 0.0], [0.002, 1.0]]}],
    }  # fmt: skip
    if far:
        scene["blocks"].append({"name": "far", "material": "platen",
                                "vertices": rect(5.0, 0.0, 6.0, 1.0)})  # fmt: skip
    result = dda.simulate(scene, keep_frames=False)
    assert len(result.fracture_events) >= 3  # the column breaks, and its pieces again
    excess, moved, _ = energy_excess(result.history, result.summary["initial_energy"], False)
    assert moved > 5e3  # J
    assert excess <= 1e-5 * moved
    assert not any("created energy" in w for w in result.summary["warnings"])


def bar_scene(ratio: float) -> dict:
    """A free 4 x 1 bar pulled at both ends by ratio x T0 (static)."""
    force = ratio * T0 * 1.0
    return {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 3, "save_every": 1},
        "materials": {"rock": STRONG},
        "joints": {"crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack"},
        "blocks": [{"name": "bar", "material": "rock", "vertices": rect(0, 0, 4, 1)}],
        "loads": [
            {"block": "bar", "point": [4.0, 0.5], "force": [force, 0.0]},
            {"block": "bar", "point": [0.0, 0.5], "force": [-force, 0.0]},
        ],
    }


def test_bar_pulled_beyond_t0_splits_in_two_across_the_pull():
    result = dda.simulate(bar_scene(1.02))
    assert [(e.parent, e.mode, len(e.children)) for e in result.fracture_events] == [
        ("bar", "tension", 2)
    ]
    frame = next(f for f in result.frames if f.step == result.fracture_events[0].step)
    left, right = sorted(frame.vertices, key=lambda r: r[:, 0].mean())
    assert shapely.Polygon(left).area == pytest.approx(2.0, rel=1e-2)
    cut = left[np.isclose(left[:, 0], left[:, 0].max(), atol=1e-3)]
    assert len(cut) == 2  # the new face of the left half is one straight edge ...
    angle = math.degrees(math.atan2(*np.abs(np.diff(cut, axis=0))[0]))
    assert angle < 0.5  # ... across the pull (along y) within 0.5°
    for f in result.frames:
        assert_valid_blocks(f)


def test_bar_pulled_below_t0_stays_whole():
    result = dda.simulate(bar_scene(0.98))
    assert result.fracture_events == []
    assert result.final.stresses[0, 0] == pytest.approx(0.98 * T0, rel=1e-2)


# ------------------------------------------------------ the paper's Fig. 3


def fig3(load_factor: float = 1.0, steps: int | None = None) -> dict:
    raw = tomllib.loads(CASE.read_text())
    for load in raw["loads"]:
        load["force"] = [f * load_factor for f in load["force"]]
    if steps is not None:
        raw["analysis"]["steps"] = steps
    return raw


def test_paper_fig3_runs_to_the_end_with_valid_blocks():
    """The paper's numbers: 120 steps (~3 s). The rock does not reach the criterion.

    The nominal stress is 2 x 157.5 klb / 1.6 ft = 1.97e5 psf = 0.26 C0; the
    suddenly applied load overshoots to about twice that (0.50 C0 at step
    ~20) and platen friction adds confinement, so (22) and (23) are never met.
    """
    result = dda.simulate(fig3())
    assert result.summary["status"] == "finished" and result.final.step == 120
    for f in result.frames:
        assert_valid_blocks(f)
    peak = max(-f.stresses[f.block("rock"), 1] for f in result.frames)
    assert 0.4 * C0 < peak < 0.6 * C0
    assert result.fracture_events == []


@pytest.mark.slow
def test_paper_fig3_on_frictionless_platens_with_three_times_the_load_breaks_in_shear():
    """Without platen friction the rock is in uniaxial compression (sigma3 = 0).

    Three times the paper's loads give a static 3 x 0.26 C0 = 0.79 C0; applied
    suddenly, the rock overshoots towards twice that, so it must reach C0 on
    the way up and break there in shear (eq. 22 with sigma3 = 0), along the two
    planes at 45 - phi/2 = 25.45 deg to the load, and the pieces run on.

    With the paper's 30 deg platen friction the rock stays whole at 3x:
    docs/fracture.md gives the confinement and why it is left without a test.
    """
    raw = fig3(3.0)
    raw["joints"]["default"]["friction_angle"] = 0.0
    result = dda.simulate(raw)
    first = result.fracture_events[0]
    assert first.parent == "rock" and first.mode == "shear"
    before = next(f for f in result.frames if f.step == first.step - 1)
    sxx, syy, _ = before.stresses[before.block("rock")]
    assert abs(sxx) < 0.05 * C0  # no confinement
    assert 0.85 * C0 < -syy < C0  # intact just below C0, on the way up
    broken = next(f for f in result.frames if f.step == first.step)
    rings = [broken.vertices[broken.block(name)] for name in first.children]
    cracks = np.unique(np.round(crack_angles_from_vertical(rings), 6))
    np.testing.assert_allclose(cracks, [-HALF_ANGLE, HALF_ANGLE], atol=1.0)
    assert result.summary["status"] == "finished" and result.final.step == 120
    for f in result.frames:
        assert_valid_blocks(f)


# ------------------------------------------- a fracture leaves other contacts be


def far_break_scene(breakable: bool) -> dict:
    """Block S on a fixed base, bonded (c = T = 5e4 Pa, φ = φr = 30°, no residual
    cohesion): a pulse of 1e5 N breaks the bond, S slides and stops; from 0.15 s a pull
    of 3e4 N, above the residual bound (14.2 kN) and below the peak (64.2 kN), slides
    it. Block B, 10 m away in free fall, is pulled apart and breaks in tension at
    about 0.1 s (``breakable``; else it stays whole)."""
    bar = {"density": 2500.0, "young": 1e9, "poisson": 0.25, "damping": 0.0}
    strong = {"cohesion": 1e6, "friction_angle": 30.0, "tensile_strength": 1e5}
    return {
        "analysis": {
            "time_step": 1e-3,
            "duration": 0.25,
            "save_every": 250,
            "gravity": [0.0, -9.81],
        },
        "materials": {"rock": bar, "brk": {**bar, **(strong if breakable else {})}},
        "joints": {
            "default": {"friction_angle": 30.0},
            "bond": {
                "friction_angle": 30.0,
                "cohesion": 5e4,
                "tensile_strength": 5e4,
                "residual_friction_angle": 30.0,
            },
            "crack": {"friction_angle": 30.0},
        },  # fmt: skip
        "fracture": {"joint": "crack"},
        "interfaces": [{"blocks": ["base", "S"], "joint": "bond"}],
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True, "vertices": rect(-5, -1, 20, 0)},
            {"name": "S", "material": "rock", "vertices": rect(0, 0, 1, 1)},
            {"name": "B", "material": "brk", "vertices": rect(10, 50, 14, 51)},
        ],  # fmt: skip
        "loads": [
            {
                "block": "S",
                "point": [0.5, 0.05],
                "force": [1.0, 0.0],
                "history": [[0, 1e5], [0.01, 1e5], [0.0101, 0], [0.15, 0], [0.1501, 3e4], [1, 3e4]],
            },
            {"block": "B", "point": [14, 50.5], "force": [4e5, 0], "history": [[0, 0], [0.2, 1]]},
            {"block": "B", "point": [10, 50.5], "force": [-4e5, 0], "history": [[0, 0], [0.2, 1]]},
        ],  # fmt: skip
    }


def test_a_fracture_elsewhere_leaves_a_failed_joint_failed():
    """S's bond has failed before B breaks, 10 m away: under the pull S slides on its
    residual friction, v = (3e4 N − tan 30° m g) / m × 0.1 s = 0.633 m/s at 0.25 s, as it
    does where B does not break (to 1 %: B's pieces cut the run's time step, 808 steps
    against 250). Every contact of the model was rebuilt after a fracture, bonded
    again: S stood still under the pull until B's pieces broke again."""
    expected = (3e4 - math.tan(math.radians(30.0)) * 2500.0 * 9.81) / 2500.0 * 0.0999
    for breakable in (True, False):
        result = dda.simulate(dda.load_scene(far_break_scene(breakable)))
        assert bool(result.fracture_events) == breakable
        if breakable:
            assert result.fracture_events[0].time < 0.15
        final = result.final
        assert final.velocities[final.block("S"), 0] == pytest.approx(expected, rel=0.01)


def test_a_fracture_elsewhere_leaves_the_in_situ_field_carried():
    """A 3 x 3 grid in a fixed U, in its gravity field (K0 = 0.5: σyy = ρ g y, σxx =
    σyy / 2, y ≤ 0), stands as it is; block B, 20 m away above the ground, is pulled
    apart and breaks. The grid keeps its field to 1e-9 and does not move (1e-12 m).
    Every contact was rebuilt after a fracture, its in-situ forces lost: the grid sank
    2.4 µm and its middle block lost 4.6 % of σyy."""
    rho, g = 2500.0, 9.81
    rock = {"density": rho, "young": 1e9, "poisson": 0.25, "damping": 0.0}
    strong = {"cohesion": 1e6, "friction_angle": 30.0, "tensile_strength": 1e5}
    fixed = [rect(-1, -4, 0, 0), rect(3, -4, 4, 0), rect(0, -4, 3, -3)]
    blocks = [{"name": f"u{k}", "material": "rock", "fixed": True, "vertices": v}
              for k, v in enumerate(fixed)]  # fmt: skip
    blocks += [{"name": f"g{i}{j}", "material": "rock",
                "vertices": rect(i, j - 3, i + 1, j - 2)}
               for i in range(3) for j in range(3)]  # fmt: skip
    blocks.append({"name": "B", "material": "brk", "vertices": rect(20, 0.2, 24, 1.2)})
    raw = {
        "analysis": {"time_step": 1e-3, "duration": 0.1, "gravity": [0.0, -g]},
        "in_situ": {"stress": [0.0, 0.0, 0.0], "gradient": [rho * g / 2, rho * g, 0.0]},
        "materials": {"rock": rock, "brk": {**rock, **strong}},
        "joints": {"default": {"friction_angle": 30.0}, "crack": {"friction_angle": 30.0}},
        "fracture": {"joint": "crack"},
        "blocks": blocks,
        "loads": [
            {"block": "B", "point": [24, 0.7], "force": [4e5, 0], "history": [[0, 0], [0.2, 1]]},
            {"block": "B", "point": [20, 0.7], "force": [-4e5, 0], "history": [[0, 0], [0.2, 1]]},
        ],  # fmt: skip
    }
    result = dda.simulate(dda.load_scene(raw))
    assert result.fracture_events
    first, final = result.frames[0], result.final
    grid = [final.block(f"g{i}{j}") for i in range(3) for j in range(3)]
    at_start = [first.block(f"g{i}{j}") for i in range(3) for j in range(3)]
    y = first.centroids[at_start, 1]
    field = np.column_stack([rho * g * y / 2, rho * g * y, 0.0 * y])
    np.testing.assert_allclose(final.stresses[grid], field, atol=1e-9 * rho * g * 3)
    assert np.abs(final.displacements[grid]).max() <= 1e-12


def test_a_stage_that_weakens_the_rock_breaks_it_at_the_stage_time():
    """The rock carries 0.98 C0 between platens and stands; a stage at 0.05 s divides
    its strength by 1.1 (``intact``): it breaks in shear at the step that ends at the
    stage time, 0.05 s (the stages apply before the criterion is judged); it broke at
    0.058 s (step 9), when the criterion was judged before the stages."""
    raw = platen_scene(0.98, steps=8)
    raw["stages"] = [{"time": 0.05, "strength_factor": 1.1, "intact": True}]
    result = dda.simulate(dda.load_scene(raw))
    first = result.fracture_events[0]
    assert (first.parent, first.mode) == ("rock", "shear")
    assert first.time == pytest.approx(0.05, abs=1e-12)
