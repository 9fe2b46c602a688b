"""Tests of the scene loader and its validation (dda/scene/format.py)."""

from __future__ import annotations

import copy
import dataclasses
import math
import sys
import tomllib
import types
import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dda import simulate
from dda.errors import SceneError
from dda.scene import Block, Joint, Scene, load_scene

FULL_SCENE = """
title = "Sliding block"

[analysis]
mode = "dynamic"
time_step = 0.001
duration = 1.0
gravity = [0.0, -9.81]
plane = "stress"
rotation = "exact"
max_displacement_ratio = 0.01
save_every = 10
accuracy = "balanced"

[contact]
method = "augmented-lagrangian"
penalty = 1.0e9
tolerance = 1.0e-4
max_iterations = 50

[materials.rock]
density = 2700.0
young = 5.0e9
poisson = 0.25
cohesion = 8.55e6
friction_angle = 39.1
tensile_strength = 4.1e6

[materials.soft]
density = 2000.0
young = 1.0e8
poisson = 0.3

[joints.default]
friction_angle = 30.0
cohesion = 0.0
tensile_strength = 0.0

[joints.smooth]
friction_angle = 5.0

[joints.crack]
friction_angle = 35.0

[fracture]
joint = "crack"

[[blocks]]
name = "slider"
material = "rock"
vertices = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.0, 0.5]]
fixed = false
fixed_points = [[0.5, 0.25]]
velocity = [0.0, 0.0, 0.0]
stress = [0.0, 0.0, 0.0]
edge_joints = ["smooth", "", "", ""]

[[blocks]]
name = "base"
material = "soft"
vertices = [[-2.0, -1.0], [3.0, -1.0], [3.0, 0.0], [-2.0, 0.0]]
fixed = true

[[loads]]
block = "slider"
point = [0.5, 0.5]
force = [2500.0, -1000.0]
history = [[0.0, 1.0], [10.0, 1.0]]

[[interfaces]]
blocks = ["slider", "base"]
joint = "smooth"
"""

NAN = float("nan")
INF = float("inf")
DELETE = object()


def full() -> dict:
    """A fresh raw dict of the valid full scene."""
    return tomllib.loads(FULL_SCENE)


def square(x: float, y: float, size: float = 1.0) -> list[list[float]]:
    return [[x, y], [x + size, y], [x + size, y + size], [x, y + size]]


def edited(path: tuple, value: object) -> dict:
    """The full scene with the entry at ``path`` replaced (or deleted)."""
    raw = full()
    node = raw
    for part in path[:-1]:
        node = node.setdefault(part, {}) if isinstance(part, str) else node[part]
    if path[0] == "blocks" and path[-1] == "vertices":
        node.pop("edge_joints", None)  # they would not match a new vertex count
        node.pop("fixed_points", None)
    if value is DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return raw


def refused(raw: object) -> SceneError:
    with pytest.raises(SceneError) as info:
        load_scene(raw)
    return info.value


# --------------------------------------------------------------------------- the valid scene


def test_full_scene_loads_identically_from_path_text_and_dict(tmp_path):
    path = tmp_path / "case.toml"
    path.write_text(FULL_SCENE)
    from_path = load_scene(path)
    from_str_path = load_scene(str(path))
    from_text = load_scene(FULL_SCENE)
    from_dict = load_scene(full())
    assert from_path.source == str(path) == from_str_path.source
    assert from_text.source == "<text>"
    assert from_dict.source == "<dict>"
    same = [dataclasses.replace(s, source="x") for s in (from_path, from_str_path, from_text)]
    assert all(s == dataclasses.replace(from_dict, source="x") for s in same)


def test_full_scene_values():
    scene = load_scene(FULL_SCENE)
    assert isinstance(scene, Scene)
    assert scene.title == "Sliding block"
    assert scene.analysis.gravity == (0.0, -9.81)
    assert scene.analysis.accuracy == "balanced"
    assert scene.contact.penalty == 1.0e9
    assert scene.materials["rock"].breakable
    assert not scene.materials["soft"].breakable
    assert scene.joints["default"].friction_angle == 30.0
    assert scene.block_names == ("slider", "base")
    slider = scene.blocks[0]
    assert slider.vertices == ((0.0, 0.0), (1.0, 0.0), (1.0, 0.5), (0.0, 0.5))
    assert slider.edge_joints == ("smooth", None, None, None)
    assert slider.fixed_points == ((0.5, 0.25),)
    assert scene.blocks[1].fixed
    assert scene.loads[0].history == ((0.0, 1.0), (10.0, 1.0))
    assert scene.interfaces[0].blocks == ("slider", "base")
    assert scene.fracture.joint == "crack"
    assert dict(scene.groups) == {}


def test_scene_is_immutable():
    scene = load_scene(full())
    with pytest.raises(TypeError):
        scene.materials["new"] = scene.materials["rock"]  # type: ignore[index]
    with pytest.raises(TypeError):
        scene.joints["new"] = Joint("new")  # type: ignore[index]
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.blocks[0].name = "other"  # type: ignore[misc]
    assert isinstance(scene.blocks, tuple)
    assert isinstance(scene.blocks[0].vertices, tuple)
    assert all(isinstance(p, tuple) for p in scene.blocks[0].vertices)


def test_loading_does_not_change_the_input_dict():
    raw = full()
    raw["blocks"][0]["vertices"].reverse()
    before = copy.deepcopy(raw)
    load_scene(raw)
    assert raw == before


def test_defaults_and_default_joint():
    raw = full()
    del raw["joints"]["default"]
    del raw["analysis"]
    del raw["contact"]
    scene = load_scene(raw)
    assert scene.joints["default"] == Joint("default")
    assert scene.analysis.duration == 1.0
    assert scene.analysis.steps is None
    assert scene.analysis.mode == "dynamic"
    assert scene.analysis.accuracy is None
    assert scene.contact.method == "augmented-lagrangian"


def test_steps_instead_of_duration():
    raw = edited(("analysis", "duration"), DELETE)
    raw["analysis"]["steps"] = 1000
    scene = load_scene(raw)
    assert scene.analysis.steps == 1000
    assert scene.analysis.duration is None


def test_integers_are_accepted_as_numbers():
    raw = edited(("materials", "rock", "density"), 2700)
    raw["blocks"][1]["vertices"] = [[-2, -1], [3, -1], [3, 0], [-2, 0]]
    scene = load_scene(raw)
    assert scene.materials["rock"].density == 2700.0
    assert isinstance(scene.blocks[1].vertices[0][0], float)


def test_numpy_values_in_a_dict_are_accepted():
    import numpy as np

    raw = full()
    raw["blocks"][1]["vertices"] = np.array([[-2.0, -1.0], [3.0, -1.0], [3.0, 0.0], [-2.0, 0.0]])
    raw["analysis"]["gravity"] = np.array([0.0, -9.81])
    raw["analysis"]["save_every"] = np.int64(5)
    scene = load_scene(raw)
    assert scene.blocks[1].vertices[1] == (3.0, -1.0)
    assert type(scene.blocks[1].vertices[1][0]) is float
    assert scene.analysis.gravity == (0.0, -9.81)
    assert type(scene.analysis.save_every) is int


# --------------------------------------------------------------------------- bad inputs

BAD = [
    # top level
    (("titel",), "x", "titel"),
    (("title",), 3, "title"),
    (("analysis",), 5, "analysis"),
    # analysis
    (("analysis", "time_stepp"), 0.1, "analysis.time_stepp"),
    (("analysis", "mode"), "dynamc", "analysis.mode"),
    (("analysis", "mode"), 1, "analysis.mode"),
    (("analysis", "plane"), "plane", "analysis.plane"),
    (("analysis", "rotation"), "exactly", "analysis.rotation"),
    (("analysis", "accuracy"), "fastest", "analysis.accuracy"),
    (("analysis", "time_step"), 0.0, "analysis.time_step"),
    (("analysis", "time_step"), -1e-3, "analysis.time_step"),
    (("analysis", "time_step"), NAN, "analysis.time_step"),
    (("analysis", "time_step"), INF, "analysis.time_step"),
    (("analysis", "time_step"), "0.001", "analysis.time_step"),
    (("analysis", "time_step"), True, "analysis.time_step"),
    (("analysis", "duration"), 0.0, "analysis.duration"),
    (("analysis", "steps"), 100, "analysis.steps"),  # both duration and steps
    (("analysis", "gravity"), [0.0], "analysis.gravity"),
    (("analysis", "gravity"), "down", "analysis.gravity"),
    (("analysis", "gravity"), [0.0, NAN], "analysis.gravity[1]"),
    (("analysis", "gravity"), [False, -9.81], "analysis.gravity[0]"),
    (("analysis", "max_displacement_ratio"), 0.0, "analysis.max_displacement_ratio"),
    (("analysis", "max_displacement_ratio"), 1.0, "analysis.max_displacement_ratio"),
    (("analysis", "newmark_gamma"), 0.4, "analysis.newmark_gamma"),
    (("analysis", "newmark_gamma"), 1.1, "analysis.newmark_gamma"),
    (("analysis", "save_every"), 0, "analysis.save_every"),
    (("analysis", "max_steps"), 0, "analysis.max_steps"),
    (("analysis", "max_steps"), 1e7, "analysis.max_steps"),
    (("analysis", "checkpoint_every"), -5, "analysis.checkpoint_every"),
    (("analysis", "save_every"), 2.0, "analysis.save_every"),
    (("analysis", "save_every"), True, "analysis.save_every"),
    (("analysis", "fixed_point_penalty"), 0.0, "analysis.fixed_point_penalty"),
    # contact
    (("contact", "penlty"), 1.0, "contact.penlty"),
    (("contact", "method"), "lagrange", "contact.method"),
    (("contact", "penalty"), 0.0, "contact.penalty"),
    (("contact", "tolerance"), -1.0, "contact.tolerance"),
    (("contact", "max_iterations"), 0, "contact.max_iterations"),
    (("contact", "state_band"), 1e-9, "contact.state_band"),  # retired key
    (("contact", "max_iterations"), 1.5, "contact.max_iterations"),
    (("contact", "shear_ratio"), 0.0, "contact.shear_ratio"),
    # materials
    (("materials",), [], "materials"),
    (("materials", "rock"), 3, "materials.rock"),
    (("materials", "rock", "frictionangle"), 30.0, "materials.rock.frictionangle"),
    (("materials", "rock", "density"), 0.0, "materials.rock.density"),
    (("materials", "rock", "density"), DELETE, "materials.rock.density"),
    (("materials", "rock", "young"), -1.0, "materials.rock.young"),
    (("materials", "rock", "young"), "5e9", "materials.rock.young"),
    (("materials", "rock", "poisson"), 0.5, "materials.rock.poisson"),
    (("materials", "rock", "poisson"), -1.0, "materials.rock.poisson"),
    (("materials", "rock", "poisson"), NAN, "materials.rock.poisson"),
    (("materials", "rock", "cohesion"), -1.0, "materials.rock.cohesion"),
    (("materials", "rock", "friction_angle"), 90.0, "materials.rock.friction_angle"),
    (("materials", "rock", "friction_angle"), -1.0, "materials.rock.friction_angle"),
    (("materials", "rock", "tensile_strength"), -1.0, "materials.rock.tensile_strength"),
    (("materials", "rock", "tensile_strength"), DELETE, "materials.rock.tensile_strength"),
    (("materials", "rock", "cohesion"), DELETE, "materials.rock.cohesion"),
    (("materials", "soft", "cohesion"), 1.0, "materials.soft.friction_angle"),
    # joints
    (("joints", "crack", "cohesoin"), 1.0, "joints.crack.cohesoin"),
    (("joints", "crack", "friction_angle"), 90.0, "joints.crack.friction_angle"),
    (("joints", "crack", "cohesion"), -1.0, "joints.crack.cohesion"),
    (("joints", "crack", "tensile_strength"), INF, "joints.crack.tensile_strength"),
    # blocks
    (("blocks",), [], "blocks"),
    (("blocks",), {"slider": {}}, "blocks"),
    (("blocks", 0, "fixedpoints"), [], "blocks[0].fixedpoints"),
    (("blocks", 0, "name"), DELETE, "blocks[0].name"),
    (("blocks", 0, "name"), "", "blocks[0].name"),
    (("blocks", 0, "name"), "a/b", "blocks[0].name"),
    (("blocks", 0, "name"), 3, "blocks[0].name"),
    (("blocks", 1, "name"), "slider", "blocks[1].name"),
    (("blocks", 0, "material"), "granite", "blocks[0].material"),
    (("blocks", 0, "material"), DELETE, "blocks[0].material"),
    (("blocks", 0, "vertices"), DELETE, "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0.0, 0.0], [1.0, 0.0]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [0, 0]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 1], [1, 0], [0, 1]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [0.5, 0], [1, 0]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [1, 0], [1, 1]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [1, 1e-13]], "blocks[0].vertices"),
    (("blocks", 0, "vertices"), [[0, 0], [1, "a"], [1, 1]], "blocks[0].vertices[1][1]"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [NAN, 1]], "blocks[0].vertices[2][0]"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [1, 1, 1]], "blocks[0].vertices[2]"),
    (("blocks", 0, "vertices"), [[0, 0], [1, 0], [True, 1]], "blocks[0].vertices[2][0]"),
    (("blocks", 0, "vertices"), "square", "blocks[0].vertices"),
    (("blocks", 0, "fixed"), "yes", "blocks[0].fixed"),
    (("blocks", 0, "fixed"), 1, "blocks[0].fixed"),
    (("blocks", 0, "fixed_points"), [[5.0, 5.0]], "blocks[0].fixed_points[0]"),
    (("blocks", 0, "fixed_points"), [[0.5, 0.25], [0.5, 0.6]], "blocks[0].fixed_points[1]"),
    (("blocks", 0, "fixed_points"), [[0.5]], "blocks[0].fixed_points[0]"),
    (("blocks", 0, "velocity"), [0.0, 0.0], "blocks[0].velocity"),
    (("blocks", 0, "stress"), [0.0, 0.0, INF], "blocks[0].stress[2]"),
    (("blocks", 0, "edge_joints"), ["", ""], "blocks[0].edge_joints"),
    (("blocks", 0, "edge_joints"), ["", "rough", "", ""], "blocks[0].edge_joints[1]"),
    (("blocks", 0, "edge_joints"), [1, "", "", ""], "blocks[0].edge_joints[0]"),
    (("blocks", 0, "vertices"), [[0, -0.5], [1, -0.5], [1, 0.5], [0, 0.5]], "blocks[1].vertices"),
    # loads
    (("loads", 0, "blok"), "slider", "loads[0].blok"),
    (("loads", 0, "block"), "slidr", "loads[0].block"),
    (("loads", 0, "block"), DELETE, "loads[0].block"),
    (("loads", 0, "force"), DELETE, "loads[0].force"),
    (("loads", 0, "point"), [1.0], "loads[0].point"),
    (("loads", 0, "force"), ["a", 1.0], "loads[0].force[0]"),
    (("loads", 0, "history"), [[0.0, 1.0], [0.0, 2.0]], "loads[0].history[1]"),
    (("loads", 0, "history"), [[1.0, 1.0], [0.5, 2.0]], "loads[0].history[1]"),
    (("loads", 0, "history"), [], "loads[0].history"),
    (("loads", 0, "history"), [[0.0, 1.0, 2.0]], "loads[0].history[0]"),
    (("loads",), {"block": "slider"}, "loads"),
    (("loads", 0, "point"), [0.5, 48.5], "loads[0].point"),  # 48 units outside the block
    (("loads", 0, "block"), "base", "loads[0].block"),  # a fixed block
    (("blocks", 1, "velocity"), [0.1, 0.0, 0.0], "blocks[1].velocity"),  # a fixed block
    (("blocks", 0, "fixed"), True, "blocks"),  # every block fixed
    (
        ("blocks", 0, "vertices"),
        [[math.cos(k / 163), math.sin(k / 163)] for k in range(1024)],
        "blocks[0].vertices",
    ),  # fmt: skip
    # interfaces
    (("interfaces", 0, "blocks"), ["slider"], "interfaces[0].blocks"),
    (("interfaces", 0, "blocks"), ["slider", "slider"], "interfaces[0].blocks"),
    (("interfaces", 0, "blocks"), ["slider", "nope"], "interfaces[0].blocks[1]"),
    (("interfaces", 0, "blocks"), "slider", "interfaces[0].blocks"),
    (("interfaces", 0, "joint"), "nope", "interfaces[0].joint"),
    (("interfaces", 0, "joint"), DELETE, "interfaces[0].joint"),
    (("interfaces", 0, "joints"), "smooth", "interfaces[0].joints"),
    (("interfaces", 1), {"blocks": ["base", "slider"], "joint": "crack"}, "interfaces[1].blocks"),
    # fracture
    (("fracture", "joint"), "nope", "fracture.joint"),
    (("fracture", "min_area"), 0.0, "fracture.min_area"),
    (("fracture", "minarea"), 1.0, "fracture.minarea"),
    # groups
    (("groups",), {"g": ["slider", "nope"]}, "groups.g[1]"),
    (("groups",), {"g": "slider"}, "groups.g"),
    (("groups",), ["slider"], "groups"),
    # an empty group: [seismic] blocks, a stage or [fos] naming it did nothing, silently
    (("groups",), {"g": []}, "groups.g"),
]


def _case_id(case: tuple) -> str:
    path, value, _ = case
    shown = "<deleted>" if value is DELETE else repr(value)[:30]
    return ".".join(map(str, path)) + "=" + shown


@pytest.mark.parametrize(("path", "value", "key"), BAD, ids=[_case_id(c) for c in BAD])
def test_bad_input_is_refused_with_its_key(path, value, key):
    if path == ("interfaces", 1):
        raw = full()
        raw["interfaces"].append(value)
    else:
        raw = edited(path, value)
    error = refused(raw)
    assert error.key == key
    assert error.source == "<dict>"
    assert key in str(error)
    assert str(error).startswith(f"scene dict: {key}: ")


@pytest.mark.parametrize(
    ("path", "value", "hint"),
    [
        (("materials", "rock", "frictionangle"), 30.0, "did you mean 'friction_angle'?"),
        (("titel",), "x", "did you mean 'title'?"),
        (("analysis", "time_stepp"), 0.1, "did you mean 'time_step'?"),
        (("analysis", "mode"), "dynamc", "did you mean 'dynamic'?"),
        (("contact", "penlty"), 1.0, "did you mean 'penalty'?"),
        (("blocks", 0, "fixedpoints"), [], "did you mean 'fixed_points'?"),
        (("loads", 0, "block"), "slidr", "did you mean 'slider'?"),
        (("blocks", 0, "material"), "rocks", "did you mean 'rock'?"),
        (("joints", "crack", "cohesoin"), 1.0, "did you mean 'cohesion'?"),
        (("regoins",), [], "did you mean 'regions'?"),
    ],
)
def test_near_miss_is_suggested(path, value, hint):
    assert hint in str(refused(edited(path, value)))


def test_missing_strength_key_is_named():
    error = refused(edited(("materials", "rock", "tensile_strength"), DELETE))
    assert "cohesion, friction_angle" in error.reason


def test_both_duration_and_steps_message():
    error = refused(edited(("analysis", "steps"), 100))
    assert "not both" in error.reason


def test_overlap_names_both_blocks():
    raw = edited(("blocks", 0, "vertices"), [[0, -0.5], [1, -0.5], [1, 0.5], [0, 0.5]])
    error = refused(raw)
    assert "'slider'" in error.reason
    assert "blocks[0]" in error.reason


# --------------------------------------------------------------------------- sources


def test_missing_file_by_path(tmp_path):
    path = tmp_path / "absent.toml"
    error = refused(path)
    assert (error.source, error.key) == (str(path), "<file>")


def test_missing_file_by_string():
    error = refused("no/such/case.toml")
    assert (error.source, error.key) == ("no/such/case.toml", "<file>")


def test_toml_syntax_error_in_text():
    error = refused('title = "x"\n[analysis\n')
    assert (error.source, error.key) == ("<text>", "<toml>")


def test_toml_syntax_error_in_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("title = \n")
    error = refused(path)
    assert (error.source, error.key) == (str(path), "<toml>")


@pytest.mark.parametrize(
    "text, key",
    [
        ("[analysis]\nduration = 1.0\nduration = 2.0\n", "analysis.duration"),
        ('title = "a"\ntitle = "b"\n', "title"),
        ('[[materials]]\nname = "rock"\nname = "rock2"\n', "materials.name"),
    ],
)
def test_a_key_given_twice_is_named(text, key):
    """tomllib names only the line of a key given twice: the error names the key."""
    error = refused(text)
    assert (error.source, error.key) == ("<text>", key)
    assert "given twice" in str(error) and "(at line " in str(error)


def test_error_in_file_names_the_file(tmp_path):
    path = tmp_path / "case.toml"
    path.write_text(FULL_SCENE.replace("poisson = 0.25", "poisson = 0.6"))
    error = refused(path)
    assert error.key == "materials.rock.poisson"
    assert str(error).startswith(f"{path}: materials.rock.poisson: ")


def test_toml_nan_is_refused():
    error = refused(FULL_SCENE.replace("young = 5.0e9", "young = nan"))
    assert (error.source, error.key) == ("<text>", "materials.rock.young")


# --------------------------------------------------------------------------- geometry


def test_clockwise_input_is_stored_counter_clockwise():
    raw = full()
    raw["blocks"][0]["vertices"] = [[0.0, 0.0], [0.0, 0.5], [1.0, 0.5], [1.0, 0.0]]
    raw["blocks"][0]["edge_joints"] = ["smooth", "crack", "", ""]
    block = load_scene(raw).blocks[0]
    assert block.vertices == ((1.0, 0.0), (1.0, 0.5), (0.0, 0.5), (0.0, 0.0))
    assert _signed_area(block.vertices) > 0
    # the left edge (0,0)-(0,0.5) keeps "smooth", the top edge keeps "crack"
    assert _edge_joint(block, (0.0, 0.0), (0.0, 0.5)) == "smooth"
    assert _edge_joint(block, (0.0, 0.5), (1.0, 0.5)) == "crack"
    assert _edge_joint(block, (1.0, 0.5), (1.0, 0.0)) is None


def _signed_area(vertices) -> float:
    n = len(vertices)
    return 0.5 * sum(
        vertices[k][0] * vertices[(k + 1) % n][1] - vertices[(k + 1) % n][0] * vertices[k][1]
        for k in range(n)
    )


def _edge_joint(block: Block, a, b):
    n = len(block.vertices)
    for k in range(n):
        if {block.vertices[k], block.vertices[(k + 1) % n]} == {a, b}:
            return block.edge_joints[k]
    raise AssertionError("no such edge")


def test_repeated_closing_vertex_is_dropped():
    raw = edited(("blocks", 0, "vertices"), [[0, 0], [1, 0], [1, 0.5], [0, 0.5], [0, 0]])
    assert load_scene(raw).blocks[0].vertices == ((0, 0), (1, 0), (1, 0.5), (0, 0.5))


def test_concave_block_is_accepted():
    raw = edited(("blocks", 0, "vertices"), [[0, 0], [1, 0], [1, 0.5], [0.5, 0.2], [0, 0.5]])
    raw["blocks"][0]["edge_joints"] = ["", "", "", "", ""]
    raw["blocks"][0]["fixed_points"] = [[0.0, 0.0]]  # a vertex lies on the block
    raw["loads"][0]["point"] = [0.25, 0.1]  # under the notch
    assert len(load_scene(raw).blocks[0].vertices) == 5


@pytest.mark.parametrize(
    "other",
    [
        square(1.0, 0.0),  # shares an edge
        square(1.0, 1.0),  # shares a corner
        square(0.5, 1.0),  # shares half an edge
        [[1.0, 0.0], [2.0, 0.5], [1.0, 1.0]],  # vertex on the middle of an edge... of a triangle
    ],
)
def test_touching_blocks_are_accepted(other):
    raw = {
        "materials": {"rock": {"density": 1.0, "young": 1.0, "poisson": 0.2}},
        "blocks": [
            {"name": "a", "material": "rock", "vertices": square(0.0, 0.0)},
            {"name": "b", "material": "rock", "vertices": other},
        ],
    }
    assert len(load_scene(raw).blocks) == 2


@pytest.mark.parametrize(
    "other",
    [
        square(0.5, 0.5),  # partial overlap
        square(0.25, 0.25, 0.5),  # inside
        square(-1.0, -1.0, 3.0),  # around
        square(0.0, 0.0),  # identical
    ],
)
def test_overlapping_blocks_are_refused(other):
    raw = {
        "materials": {"rock": {"density": 1.0, "young": 1.0, "poisson": 0.2}},
        "blocks": [
            {"name": "a", "material": "rock", "vertices": square(0.0, 0.0)},
            {"name": "b", "material": "rock", "vertices": other},
        ],
    }
    error = refused(raw)
    assert error.key == "blocks[1].vertices"
    assert "overlaps" in error.reason


def test_overlap_below_tolerance_is_accepted():
    raw = {
        "materials": {"rock": {"density": 1.0, "young": 1.0, "poisson": 0.2}},
        "blocks": [
            {"name": "a", "material": "rock", "vertices": square(0.0, 0.0)},
            {"name": "b", "material": "rock", "vertices": square(1.0 - 1e-12, 0.0)},
        ],
    }
    assert len(load_scene(raw).blocks) == 2


def test_grid_of_ten_thousand_blocks_validates():
    n = 100
    blocks = [
        {"name": f"b{i}_{j}", "material": "rock", "vertices": square(float(i), float(j))}
        for i in range(n)
        for j in range(n)
    ]
    # every other block given clockwise
    for block in blocks[::2]:
        block["vertices"].reverse()
    raw = {"materials": {"rock": {"density": 1.0, "young": 1.0, "poisson": 0.2}}, "blocks": blocks}
    scene = load_scene(raw)
    assert len(scene.blocks) == n * n
    assert all(_signed_area(b.vertices) == pytest.approx(1.0) for b in scene.blocks)


def test_grid_with_one_overlap_is_refused():
    blocks = [
        {"name": f"b{i}_{j}", "material": "rock", "vertices": square(float(i), float(j))}
        for i in range(30)
        for j in range(30)
    ]
    blocks[500]["vertices"] = [[x + 0.1, y] for x, y in blocks[500]["vertices"]]
    raw = {"materials": {"rock": {"density": 1.0, "young": 1.0, "poisson": 0.2}}, "blocks": blocks}
    assert "overlaps" in refused(raw).reason


# --------------------------------------------------------------------------- rock mass, groups


def test_groups_are_stored():
    raw = full()
    raw["groups"] = {"moving": ["slider"], "all": ["slider", "base"]}
    scene = load_scene(raw)
    assert scene.groups["all"] == ("slider", "base")
    with pytest.raises(TypeError):
        scene.groups["x"] = ()  # type: ignore[index]


def test_rock_mass_keys_are_expanded(monkeypatch):
    calls = []

    def expand_rock_mass(raw, source, progress=None):
        calls.append(source)
        out = {k: v for k, v in raw.items() if k not in ("regions", "joint_sets", "fix")}
        out["blocks"] = [{"name": "r1", "material": "soft", "vertices": square(0.0, 0.0)}]
        out["groups"] = {"region": ["r1"]}
        return out

    module = types.ModuleType("dda.scene.rockmass")
    module.expand_rock_mass = expand_rock_mass
    monkeypatch.setitem(sys.modules, "dda.scene.rockmass", module)
    raw = full()
    for key in ("loads", "interfaces", "blocks"):
        del raw[key]
    raw["regions"] = [{"material": "soft"}]
    raw["joint_sets"] = []
    raw["fix"] = []  # a key of the rock-mass module, consumed by it
    scene = load_scene(raw)
    assert calls == ["<dict>"]
    assert scene.block_names == ("r1",)
    assert scene.groups["region"] == ("r1",)


def test_rock_mass_scene_without_the_module(monkeypatch):
    monkeypatch.setitem(sys.modules, "dda.scene.rockmass", None)
    error = refused(edited(("joint_lines",), []))
    assert error.key == "regions"
    assert "dda.scene.rockmass" in error.reason


def test_rock_mass_typo_after_expansion_is_refused(monkeypatch):
    module = types.ModuleType("dda.scene.rockmass")
    module.expand_rock_mass = lambda raw, source, progress=None: {
        k: v for k, v in raw.items() if k != "regions"
    }
    monkeypatch.setitem(sys.modules, "dda.scene.rockmass", module)
    raw = full()
    raw["regions"] = []
    raw["titel"] = "x"
    error = refused(raw)
    assert error.key == "titel"
    assert "did you mean 'title'?" in error.reason


def test_rock_mass_only_key_in_a_plain_scene_is_refused():
    assert refused(edited(("fix",), [])).key == "fix"


ROCK_MASS_SCENE = """
[materials.rock]
density = 2700.0
young = 5e9
poisson = 0.25

[joints.bedding]
friction_angle = 30.0

[[regions]]
polygon = [[0, 0], [10, 0], [10, 5], [0, 5]]
material = "rock"

[[joint_sets]]
joint = "bedding"
dip = 0.0
spacing = 1.0
"""


def test_rock_mass_scene_with_the_real_module():
    pytest.importorskip("dda.scene.rockmass")
    scene = load_scene(ROCK_MASS_SCENE)
    assert len(scene.blocks) > 1
    assert all(_signed_area(b.vertices) > 0 for b in scene.blocks)
    assert sum(_signed_area(b.vertices) for b in scene.blocks) == pytest.approx(50.0)


def test_plain_scene_never_imports_rock_mass(monkeypatch):
    monkeypatch.setitem(sys.modules, "dda.scene.rockmass", None)
    assert load_scene(full()).block_names == ("slider", "base")


# --------------------------------------------------------------------------- robustness

_JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.lists(st.floats(allow_nan=True), max_size=4),
    st.lists(st.lists(st.floats(-10, 10), max_size=3), max_size=5),
    st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
)


def _leaves(node, path=()):
    """Paths of every table entry and list element of a raw scene."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in items:
        yield (*path, key)
        if isinstance(value, dict | list):
            yield from _leaves(value, (*path, key))


_PATHS = list(_leaves(full()))


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(_PATHS), _JUNK)
def test_junk_anywhere_is_accepted_or_refused_with_scene_error(path, junk):
    raw = full()
    node = raw
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = junk
    try:
        scene = load_scene(raw)
    except SceneError as error:
        assert error.key
        assert error.source == "<dict>"
    else:
        assert all(math.isfinite(x) for b in scene.blocks for p in b.vertices for x in p)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e14])
def test_slivers_are_refused_at_any_scale(scale):
    """Area against 1e-12 of the squared diagonal, whatever the length unit."""
    sliver = [[0.0, 0.0], [scale, 0.0], [scale, 1e-13 * scale], [0.0, 1e-13 * scale]]
    error = refused(edited(("blocks", 0, "vertices"), sliver))
    assert error.key == "blocks[0].vertices" and "too small" in str(error)


@pytest.mark.parametrize(
    "path, value",
    [
        (("blocks", 1, "vertices", 0), [0.0, 2.7e299]),
        (("blocks", 1, "vertices", 0), [1.34e154, 1.34e154]),
        (("blocks", 0, "fixed_points", 0), [-1e16, 0.25]),
        (("loads", 0, "point"), [0.5, 1e300]),
    ],
)
def test_huge_coordinates_are_refused_without_overflow(path, value):
    """Positions beyond ±1e15 are refused by name, before any geometry squares them
    (1e154 squared overflowed in the checks: RuntimeWarnings and infinite sizes)."""
    raw = full()
    node = raw
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        error = refused(raw)
    assert "beyond ±1e+15" in str(error)
    assert error.key.startswith(f"{path[0]}[{path[1]}].{path[2]}")


def test_units_name_the_unit_of_each_quantity():
    """[units] labels pictures and tables; SI by default, stress derived from force/length."""
    default = load_scene(full()).units
    assert (default.length, default.stress, default.velocity) == ("m", "Pa", "m/s")
    raw = {**full(), "units": {"length": "ft", "force": "lb"}}
    assert load_scene(raw).units.stress == "lb/ft²"
    with pytest.raises(SceneError, match="units.lenght"):
        load_scene({**full(), "units": {"lenght": "ft"}})
    with pytest.raises(SceneError, match="units.force"):
        load_scene({**full(), "units": {"force": " "}})


@pytest.mark.parametrize(
    "vertices, reason",
    [
        ([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]], "its vertices lie on one line (no area)"),
        ([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]], "not a simple polygon (Self-"),
    ],
)
def test_a_block_of_collinear_vertices_is_named_so_and_a_bow_tie_self_intersecting(
    vertices, reason
):
    error = refused(edited(("blocks", 0, "vertices"), vertices))
    assert error.key == "blocks[0].vertices" and reason in str(error)


IDLE_BASE = {
    "analysis": {"mode": "static", "steps": 3},
    "materials": {"r": {"density": 2000.0, "young": 1e9, "poisson": 0.2}},
    "blocks": [
        {"name": "a", "material": "r", "fixed": True,
         "vertices": [[0, -1], [2, -1], [2, 0], [0, 0]]},
        {"name": "b", "material": "r", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]},
    ],
}  # fmt: skip


@pytest.mark.parametrize(
    ("change", "said"),
    [
        (lambda s: s["analysis"].update(newmark_gamma=0.6), "analysis.newmark_gamma: a static"),
        (lambda s: s["blocks"][1].update(velocity=[1.0, 0.0, 0.0]), "blocks[1].velocity: a static"),
    ],
)
def test_keys_that_do_nothing_in_the_scene_are_said(change, said):
    """They were accepted without a word: a static analysis's Newmark γ and initial
    velocities."""
    raw = copy.deepcopy(IDLE_BASE)
    change(raw)
    scene = load_scene(raw)
    assert len(scene.load_warnings) == 1 and scene.load_warnings[0].startswith(said)
    result = simulate(scene)
    assert result.summary["warnings"][0].startswith(said)
    assert load_scene(copy.deepcopy(IDLE_BASE)).load_warnings == ()
