"""In-situ stress and boundary stresses (dda/scene/in_situ.py, dda/contact/preload.py,
dda/effects/boundary_stresses.py): a jointed rock mass starts as it stands in the ground.

Closed forms: a uniform field in a jointed assembly, held by a fixed ring or by boundary
stresses on free blocks, is in equilibrium with the contacts that carry it, so nothing
moves and every block keeps it; under gravity, a field whose vertical gradient is ρ g
(σyy = ρ g (y − H), σxx = K0 σyy) is in equilibrium with the blocks' weight.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import dda
from dda.effects.base import StepContext
from dda.effects.boundary_stresses import split_segment_forces
from dda.errors import SceneError
from dda.fracture.fragments import parent_rows
from dda.model import build
from dda.scene.edge_cover import covered_pieces, outer_pieces
from dda.scene.in_situ import StressField

RHO, G = 2600.0, 9.81
FIELD = (-2.0e6, -1.0e6, 0.3e6)  # sxx, syy, sxy: compression, with shear


def square(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def grid(columns, rows, dx=0.0, dy=0.0):
    return [
        {"name": f"b{i}_{j}", "material": "rock",
         "vertices": square(dx + i, dy + j, dx + i + 1, dy + j + 1)}
        for j in range(rows) for i in range(columns)
    ]  # fmt: skip


def ring(n, dx=0.0, dy=0.0):
    """Four fixed blocks around an n x n grid whose corner is at (dx, dy)."""
    x0, y0, x1, y1 = dx, dy, dx + n, dy + n
    return [
        {"name": "bottom", "material": "rock", "fixed": True,
         "vertices": square(x0 - 1, y0 - 1, x1 + 1, y0)},
        {"name": "top", "material": "rock", "fixed": True,
         "vertices": square(x0 - 1, y1, x1 + 1, y1 + 1)},
        {"name": "left", "material": "rock", "fixed": True,
         "vertices": square(x0 - 1, y0, x0, y1)},
        {"name": "right", "material": "rock", "fixed": True,
         "vertices": square(x1, y0, x1 + 1, y1)},
    ]  # fmt: skip


def scene(blocks, method="augmented-lagrangian", start="equilibrium", gravity=(0.0, 0.0),
          duration=0.2, **sections):  # fmt: skip
    return {
        "analysis": {"mode": "dynamic", "time_step": 1e-3, "duration": duration,
                     "gravity": list(gravity), "start": start, "save_every": 1000},
        "contact": {"method": method, "penalty": 1e11},
        "materials": {"rock": {"density": RHO, "young": 1e10, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": blocks,
        **sections,
    }  # fmt: skip


def uniform(held_by: str, dx: float = 0.0, dy: float = 0.0) -> list:
    blocks = grid(3, 3, dx, dy)
    if held_by == "ring":
        return blocks + ring(3, dx, dy)
    return blocks


@pytest.mark.parametrize("method", ["augmented-lagrangian", "penalty"])
@pytest.mark.parametrize("start", ["equilibrium", "unloaded"])
@pytest.mark.parametrize("held_by", ["ring", "boundary stresses"])
def test_a_uniform_field_in_a_jointed_assembly_stays_as_it_is(method, start, held_by):
    """3 x 3 unit blocks, σ = (−2, −1, 0.3) MPa: held by a fixed ring or by the same
    field's traction on their outer edges (free blocks, no fixed block at all), each block
    keeps σ to 1e-6 over 0.2 s and nothing moves beyond round-off."""
    sections = {"in_situ": {"stress": list(FIELD)}}
    if held_by == "boundary stresses":
        sections["boundary_stresses"] = [{"stress": list(FIELD), "box": [-1, -1, 4, 4]}]
    result = dda.simulate(dda.load_scene(scene(uniform(held_by), method, start, **sections)))
    stress = result.final.stresses[:9]
    assert np.abs(stress - FIELD).max() <= 1e-6 * 2.0e6
    assert np.abs(result.final.displacements[:9]).max() <= 1e-12
    assert result.summary["start"] == start


def test_the_field_is_the_same_far_from_the_origin():
    """The engine computes far from the origin in a local frame: a field that varies
    with y gives each block the stress of its height in the scene's frame (here
    σyy = −2 MPa + ρ g y under gravity, in equilibrium with the blocks' weight)."""
    field = {"stress": [-1.0e6, -2.0e6, 0.0], "gradient": [0.0, RHO * G, 0.0]}
    near_scene = scene(uniform("ring"), gravity=(0.0, -G), in_situ=field, duration=0.01)
    near = dda.simulate(dda.load_scene(near_scene))
    dy = 1.0e6
    moved = dict(field, stress=[-1.0e6, -2.0e6 - RHO * G * dy, 0.0])
    far_scene = scene(uniform("ring", dy=dy), gravity=(0.0, -G), in_situ=moved, duration=0.01)
    far = dda.simulate(dda.load_scene(far_scene))
    expected = -2.0e6 + RHO * G * (np.repeat(np.arange(3), 3) + 0.5)
    np.testing.assert_allclose(near.final.stresses[:9, 1], expected, rtol=1e-9)
    np.testing.assert_allclose(far.final.stresses[:9, 1], expected, rtol=1e-9)


def column(held_by: str, k0: float = 0.5, start: str = "equilibrium") -> dict:
    """Two columns of ten unit blocks on a fixed base under gravity, σyy = ρ g (y − 10),
    σxx = K0 σyy, between fixed walls or loaded on their outer edges by the same field."""
    height = 10.0
    blocks = grid(2, 10) + [
        {"name": "base", "material": "rock", "fixed": True, "vertices": square(-1, -1, 3, 0)}
    ]
    syy, dsyy = -RHO * G * height, RHO * G
    field = {"stress": [k0 * syy, syy, 0.0], "gradient": [k0 * dsyy, dsyy, 0.0]}
    sections = {"in_situ": field}
    if held_by == "walls":
        blocks += [
            {"name": "left", "material": "rock", "fixed": True,
             "vertices": square(-1, 0, 0, height)},
            {"name": "right", "material": "rock", "fixed": True,
             "vertices": square(2, 0, 3, height)},
        ]  # fmt: skip
    else:
        sections["boundary_stresses"] = [dict(field, box=[-0.5, -0.5, 2.5, height + 0.5])]
    return scene(blocks, start=start, gravity=(0.0, -G), **sections)


@pytest.mark.parametrize("held_by", ["walls", "boundary stresses"])
@pytest.mark.parametrize("start", ["equilibrium", "unloaded"])
def test_a_jointed_column_stands_in_its_gravity_field(held_by, start):
    """The centroid stresses stay the field's, σyy = ρ g (y − H) and σxx = K0 σyy, within
    2 % (to round-off here: the contacts carry the field's own tractions), and the
    column does not settle."""
    result = dda.simulate(dda.load_scene(column(held_by, start=start)))
    y = np.repeat(np.arange(10) + 0.5, 2)
    syy = RHO * G * (y - 10.0)
    stress = result.final.stresses[:20]
    assert np.abs(stress[:, 1] - syy).max() <= 0.02 * np.abs(syy).max()
    assert np.abs(stress[:, 0] - 0.5 * syy).max() <= 0.02 * 0.5 * np.abs(syy).max()
    assert np.abs(result.final.displacements[:20]).max() <= 1e-9


def lone_block(**sections) -> dict:
    """One free unit block, no contacts, stiff and damped: its stress follows the
    traction on its edges."""
    out = scene([{"name": "b", "material": "rock", "vertices": square(0, 0, 1, 1)}],
                duration=0.4, **sections)  # fmt: skip
    out["materials"]["rock"]["damping"] = 0.5
    return out


def test_a_stage_takes_boundary_stresses_away_and_the_block_relaxes():
    """σ0 held by its traction until t = 0.1 s: exact until then; after the stage the
    block expands and its stress decays towards zero; energy never above E0 + W."""
    field = {"stress": list(FIELD)}
    raw = lone_block(
        in_situ=field,
        boundary_stresses=[dict(field, box=[-1, -1, 2, 2], name="far field")],
        stages=[{"time": 0.1, "remove_boundary_stresses": ["far field"]}],
    )
    raw["analysis"]["save_every"] = 1
    result = dda.simulate(dda.load_scene(raw))
    before = [f for f in result.frames if f.time <= 0.1 + 1e-9]
    assert all(np.abs(f.stresses[0] - FIELD).max() <= 1e-6 * 2e6 for f in before)
    assert np.abs(result.final.stresses[0]).max() <= 0.05 * 2.0e6
    history = result.history
    e0 = result.summary["initial_energy"]
    excess = history["total_energy"] - e0 - history["external_work"]
    assert np.all(excess <= 1e-9 * e0), excess.max()


def test_a_stage_applies_a_boundary_stress_and_the_block_takes_it_on():
    """An unstressed block loaded from t = 0.1 s by a uniform traction: nothing before,
    the field's stress (within 5 %) once it has rung down; the loads' work accounted."""
    applied = {"stress": list(FIELD), "box": [-1, -1, 2, 2]}
    raw = lone_block(stages=[{"time": 0.1, "boundary_stresses": [applied]}])
    raw["analysis"]["save_every"] = 1
    result = dda.simulate(dda.load_scene(raw))
    before = [f for f in result.frames if f.time <= 0.1 + 1e-9]
    assert all(np.abs(f.stresses[0]).max() == 0.0 for f in before)
    assert np.abs(result.final.stresses[0] - FIELD).max() <= 0.05 * 2.0e6
    history = result.history
    e0 = result.summary["initial_energy"]
    excess = history["total_energy"] - e0 - history["external_work"]
    assert np.all(excess <= 1e-9 * max(history["external_work"].max(), 1.0)), excess.max()
    assert "boundary_stresses" in result.summary["active_effects"]


def test_outer_and_covered_pieces_of_three_blocks_on_a_base():
    base = np.array(square(0, 0, 3, 1), float)
    tops = [np.array(square(i, 1, i + 1, 2), float) for i in range(3)]
    outer = outer_pieces([base, *tops])
    assert sorted(np.round(outer.length, 12)) == [1, 1, 1, 1, 1, 1, 1, 3]
    assert outer.length.sum() == pytest.approx(10.0)  # the outline
    covered = covered_pieces([base, *tops])
    assert covered.length.sum() == pytest.approx(2 * (3.0 + 2.0))  # each joint, both sides


def test_segment_forces_do_the_work_of_a_linear_traction():
    """∫ t(s) φ(s) ds for φ = 1 and s (linear displacement) against the two end forces."""
    field = StressField((1.0, 2.0, 0.5), (0.3, -0.7, 0.2))
    start, end = np.array([[0.0, 0.0]]), np.array([[0.0, 2.0]])
    normal = np.array([[-1.0, 0.0]])
    fa, fb = field.segment_forces(start, end, normal)
    s = np.linspace(0.0, 2.0, 20001)
    points = np.column_stack([np.zeros_like(s), s])
    t = field.traction(points, np.repeat(normal, len(s), axis=0))
    for weight in (np.ones_like(s), s):
        exact = np.trapezoid(t * weight[:, None], s, axis=0)
        np.testing.assert_allclose(fa[0] * weight[0] + fb[0] * weight[-1], exact, rtol=1e-8)


def test_the_parts_of_a_split_edge_carry_its_traction_as_the_field_does():
    """An edge cut at ξ = 0.3 and 0.8: each part's end forces are the field's own on that
    part (its traction linear along the edge), so they sum to the edge's force and moment."""
    field = StressField((1.0, 2.0, 0.5), (0.3, -0.7, 0.2))
    start, end, normal = np.array([[0.0, 0.0]]), np.array([[0.0, 2.0]]), np.array([[-1.0, 0.0]])
    fa, fb = field.segment_forces(start, end, normal)
    cuts = np.array([0.0, 0.3, 0.8, 1.0])
    a, b = cuts[:-1, None], cuts[1:, None]
    part_a, part_b = split_segment_forces(fa, fb, a, b)
    points = start + cuts[:, None] * (end - start)
    own_a, own_b = field.segment_forces(points[:-1], points[1:], np.repeat(normal, 3, axis=0))
    np.testing.assert_allclose(part_a, own_a, rtol=1e-12)
    np.testing.assert_allclose(part_b, own_b, rtol=1e-12)


def breaking_block_under_a_boundary_stress():
    """A 2 × 2 m breakable block on a fixed base, pressed on its top edge alone by 4 MPa."""
    raw = scene(
        [{"name": "base", "material": "rock", "fixed": True, "vertices": square(-2, -1, 2, 0)},
         {"name": "rock", "material": "rock", "vertices": square(-1, 0, 1, 2)}],
        boundary_stresses=[{"stress": [0.0, -4.0e6, 0.0], "box": [-1.5, 1.9, 1.5, 2.1]}],
    )  # fmt: skip
    raw["materials"]["rock"].update(cohesion=1.0e6, friction_angle=30.0, tensile_strength=0.5e6)
    raw["fracture"] = {}
    return dda.load_scene(raw)


def test_a_block_that_breaks_gives_each_piece_its_share_of_the_boundary_stress():
    """The top edge is cut where the cracks meet it: each piece is pushed by 4 MPa over its
    own part of it (the top cone 1.155 m, the side wedges 0.42 m each; before, the side
    wedges took the edge's two end forces, 4 MN each, and the cone none)."""
    model = build(breaking_block_under_a_boundary_stress())
    blocks = model.blocks.copy()
    blocks.stress[1] = [0.0, -4.0e6, 0.0]
    ctx = StepContext(dt=1e-4, time=1e-4, step=1, static=False)
    new, events = model.fracture.after_step(blocks, ctx)
    assert [(e.mode, len(e.children)) for e in events] == [("shear", 4)]
    loads = next(e for e in model.effects if e.name == "boundary_stresses")
    loads.on_blocks_replaced(blocks, new, parent_rows(blocks, new))
    forces = loads.forces(new, ctx)
    for k in range(new.count):
        ring = new.polygon(k)
        top = ring[np.isclose(ring[:, 1], 2.0, atol=1e-9), 0]
        share = top.max() - top.min() if len(top) > 1 else 0.0
        assert forces[k, 1] == pytest.approx(-4.0e6 * share, rel=1e-9, abs=1e-3)
        assert forces[k, 0] == pytest.approx(0.0, abs=1e-3)
    assert forces[:, 1].sum() == pytest.approx(-8.0e6, rel=1e-12)


def test_pieces_of_a_block_broken_in_its_field_stay_in_it():
    """A weak block in an in-situ field held by the same boundary stress breaks at once;
    each piece keeps the field (σxx −10 MPa, σyy −5 MPa) within 1 % (before the edges
    were split at the cracks, the side pieces lost all their σxx)."""
    field = [-10.0e6, -5.0e6, 0.0]
    raw = scene([{"name": "w", "material": "rock", "vertices": square(0, 0, 1, 1)}],
                in_situ={"stress": field},
                boundary_stresses=[{"stress": field, "box": [-0.1, -0.1, 1.1, 1.1]}])  # fmt: skip
    raw["materials"]["rock"].update(cohesion=1.0e6, friction_angle=10.0, tensile_strength=0.5e6)
    raw["joints"] = {"default": {"friction_angle": 40.0}}
    raw["fracture"] = {"min_area": 0.2}
    raw["analysis"].update(time_step=1e-4, steps=12)
    raw["analysis"].pop("duration", None)
    result = dda.simulate(dda.load_scene(raw))
    assert [(e.mode, len(e.children)) for e in result.fracture_events] == [("shear", 4)]
    np.testing.assert_allclose(result.final.stresses[:, :2], [field[:2]] * 4, rtol=1e-2)


def refused(raw, key, words):
    with pytest.raises(SceneError) as caught:
        dda.load_scene(raw)
    assert caught.value.key == key, str(caught.value)
    assert words in str(caught.value)


@pytest.mark.parametrize(
    "section, key, words",
    [
        ({"in_situ": {"stress": [1.0, 2.0]}}, "in_situ.stress", "expected 3 numbers, got 2"),
        ({"in_situ": {"stress": [1.0, math.nan, 0.0]}}, "in_situ.stress[1]", "finite"),
        (
            {"in_situ": {"stress": [-1.0, -1.0, 0.0], "gradient": [0, math.inf, 0]}},
            "in_situ.gradient[1]",
            "finite",
        ),  # fmt: skip
        ({"in_situ": {"gradient": [0, 1, 0]}}, "in_situ.stress", "is required"),
        ({"in_situ": {"stress": [0, 0, 0], "strees": 1}}, "in_situ.strees", "unknown key"),
        (
            {"boundary_stresses": [{"stress": [-1.0, -1.0, 0.0], "box": [0, 0, 1]}]},
            "boundary_stresses[0].box",
            "expected 4 numbers, got 3",
        ),  # fmt: skip
        (
            {"boundary_stresses": [{"stress": [-1.0, -1.0, 0.0], "box": [2, 0, 1, 1]}]},
            "boundary_stresses[0].box",
            "xmax > xmin",
        ),  # fmt: skip
        (
            {"boundary_stresses": [{"stress": [-1.0, -1.0, 0.0]}]},
            "boundary_stresses[0].box",
            "is required",
        ),  # fmt: skip
        (
            {"boundary_stresses": [{"stress": [-1.0, -1.0, 0.0], "box": [1.2, 1.2, 1.8, 1.8]}]},
            "boundary_stresses[0].box",
            "holds the midpoint of no outer edge",
        ),  # fmt: skip
        (  # the ring's outer edge below: a fixed block's, which takes no boundary stress
            {"boundary_stresses": [{"stress": [-1.0, -1.0, 0.0], "box": [-2, -2, 5, -0.5]}]},
            "boundary_stresses[0].box",
            "of the free blocks there at that time (a fixed block takes no boundary stress;",
        ),  # fmt: skip
        (
            {
                "boundary_stresses": [
                    {"stress": [-1.0, -1.0, 0.0], "box": [-2, -2, 5, 5], "name": " "}
                ]
            },
            "boundary_stresses[0].name",
            "is blank",
        ),  # fmt: skip
        (
            {"stages": [{"time": 0.05, "remove_boundary_stresses": ["far"]}]},
            "stages[0].remove_boundary_stresses",
            "'far' is no boundary stress",
        ),  # fmt: skip
        (  # was refused as "'far' is no boundary stress in force", which it is
            {
                "boundary_stresses": [
                    {"stress": [-1.0, -1.0, 0.0], "box": [-2, -2, 5, 5], "name": "far"}
                ],
                "stages": [{"time": 0.05, "remove_boundary_stresses": ["far", "far"]}],
            },
            "stages[0].remove_boundary_stresses",
            "lists 'far' twice",
        ),  # fmt: skip
        ({"boundary_stresses": []}, "boundary_stresses", "is empty"),  # as a stage's is
        (  # was accepted: the run "finished" with nan energies
            {"in_situ": {"stress": [-1.0e308, -1.0e308, 0.0]}},
            "in_situ.stress",
            "as large as the Young's modulus 1e+10 of its material 'rock'",
        ),  # fmt: skip
        (  # said "gives 2e+10": the sign lost
            {"in_situ": {"stress": [-2.0e10, -1.0e6, 0.0]}},
            "in_situ.stress",
            "gives -2e+10 at",
        ),  # fmt: skip
        (
            {"in_situ": {"stress": [-1.0e6, -1.0e6, 0.0], "gradient": [0.0, 1.0e308, 0.0]}},
            "in_situ.gradient",
            "a strain of 1 or more",
        ),  # fmt: skip
    ],
)
def test_bad_fields_are_refused_with_their_key(section, key, words):
    refused(scene(uniform("ring"), duration=0.1, **section), key, words)


def test_a_boundary_stress_as_large_as_young_s_modulus_is_refused():
    far = {"stress": [-2.0e10, 0.0, 0.0], "box": [-2, -2, 5, 5]}
    raw = scene(uniform("boundary stresses"), duration=0.1, boundary_stresses=[far])
    refused(raw, "boundary_stresses[0].stress", "no stress rock stands in")


def test_in_situ_tension_across_a_joint_without_tensile_strength_is_refused():
    """σxx = +1 kPa across the vertical joints of the grid, which carry no tension."""
    raw = scene(uniform("ring"), in_situ={"stress": [1.0e3, -1.0e6, 0.0]})
    refused(raw, "in_situ.stress", "puts a tension of 1000 across joint 'default'")
    raw["joints"]["default"]["tensile_strength"] = 2.0e3  # a joint that carries it
    assert dda.load_scene(raw).in_situ.stress == (1.0e3, -1.0e6, 0.0)


def test_a_boundary_stress_that_pulls_the_mass_apart_is_said():
    """An audit: a 3 x 3 jointed mass (T = 0) under a boundary stress of +1 MPa in x and
    no [in_situ] ran silently, its outer columns leaving at 7.7 m/s (the same field as
    [in_situ] is refused). A joint that carries the tension is no cause."""
    box = {"stress": [1.0e6, -1.0e6, 0.0], "box": [-0.5, -0.5, 3.5, 3.5]}
    warnings = dda.load_scene(scene(grid(3, 3), boundary_stresses=[box])).load_warnings
    (said,) = [w for w in warnings if "pulls" in w]
    assert said.startswith(
        "boundary_stresses[0]: its field would put a tension of 1e+06 across joint "
        "'default' (tensile_strength 0) between blocks"
    )
    raw = scene(grid(3, 3), boundary_stresses=[box])
    raw["joints"]["default"]["tensile_strength"] = 2.0e6
    assert not [w for w in dda.load_scene(raw).load_warnings if "pulls" in w]


def test_tension_from_the_gradient_names_the_gradient():
    """A depth gradient of the wrong sign (stress 0, σyy = +ρ g y above y = 0: the
    overburden's sign flipped) is refused under in_situ.gradient, with the sign
    convention, not under in_situ.stress, which is 0; a pure-gradient field's tension is
    judged against the field's size, not against the size of ``stress`` alone."""
    field = {"stress": [0.0, 0.0, 0.0], "gradient": [0.0, RHO * G, 0.0]}
    raw = scene(uniform("ring"), in_situ=field)
    refused(raw, "in_situ.gradient", "a compressive field that grows with depth has a positive")
    field["gradient"] = [0.0, -RHO * G, 0.0]  # compressive above y = 0: accepted
    assert dda.load_scene(scene(uniform("ring"), in_situ=field)).in_situ is not None


def test_a_field_the_start_cannot_keep_is_said_not_relaxed_silently(caplog):
    """Free blocks in a field with nothing to hold it (no ring, no boundary stress): the
    equilibrium start relaxes it (the blocks stay, their stress goes); the run says so
    (a warning at once, and among the summary's warnings, which `dda run` prints at its
    end), where a held field is kept and not said."""
    field = {"stress": [-2.0e6, -1.0e6, 0.3e6]}
    free = dda.simulate(scene(uniform("nothing"), duration=0.002, in_situ=field))
    assert free.summary["start_in_situ_relaxed"]
    assert free.summary["start_in_situ_change"] > 0.5
    assert "changed the in-situ stress of block" in caplog.text  # at once
    assert any("changed the in-situ stress" in text for text in free.summary["warnings"])
    caplog.clear()
    held = dda.simulate(scene(uniform("ring"), duration=0.002, in_situ=field))
    assert not held.summary["start_in_situ_relaxed"]
    assert held.summary["start_in_situ_change"] < 1e-6
    assert "changed the in-situ stress" not in caplog.text


def test_a_start_that_does_not_settle_keeps_the_field_as_the_unloaded_start_does(monkeypatch):
    """Where the equilibrium start falls back to the unloaded start, the contacts found
    at t = 0 still carry the in-situ field, as those of ``start = "unloaded"`` do: the
    held assembly keeps σ to 1e-6 (it relaxed by 7 % into unloaded contact springs)."""
    import dda.run.simulation as simulation
    from dda.run.equilibrium_start import INTERIOR_POINT, Unsettled

    monkeypatch.setattr(simulation, "settle", lambda *args: Unsettled(0, INTERIOR_POINT))
    sections = {"in_situ": {"stress": list(FIELD)}}
    result = dda.simulate(dda.load_scene(scene(uniform("ring"), **sections)))
    assert result.summary["start"] == simulation.UNSETTLED_START
    assert np.abs(result.final.stresses[:9] - FIELD).max() <= 1e-6 * 2.0e6


def arch(held_by: str) -> list:
    """A 3 x 3 square of two free blocks whose joint bends at three vertices (a shallow
    arch, as a polygonal opening's outline does), both blocks' vertices on it, in the
    fixed ring."""
    line = [[0.0, 1.5], [0.75, 1.65], [1.5, 1.7], [2.25, 1.65], [3.0, 1.5]]
    lower = [[0.0, 0.0], [3.0, 0.0], *line[::-1]]
    upper = [*line, [3.0, 3.0], [0.0, 3.0]]
    blocks = [
        {"name": "lower", "material": "rock", "vertices": lower},
        {"name": "upper", "material": "rock", "vertices": upper[::-1]},
    ]
    return blocks + (ring(3) if held_by == "ring" else [])


@pytest.mark.parametrize("start", ["equilibrium", "unloaded"])
def test_a_joint_that_bends_at_vertices_carries_the_field(start):
    """Each vertex of the bent joint is one contact (a vertex-vertex pair), which takes the
    end forces of the joint's pieces on both sides of it: the field is carried, and the
    blocks keep σ to 1e-6 with nothing moving beyond round-off, from the unloaded start
    too (one contact took one piece's share and the joint's first piece none: the blocks
    were thrown apart at t = 0)."""
    sections = {"in_situ": {"stress": list(FIELD)}}
    result = dda.simulate(dda.load_scene(scene(arch("ring"), start=start, **sections)))
    assert np.abs(result.final.stresses[:2] - FIELD).max() <= 1e-6 * 2.0e6
    assert np.abs(result.final.displacements[:2]).max() <= 1e-12


@pytest.mark.parametrize("start", ["equilibrium", "unloaded"])
def test_a_corner_nested_in_a_reflex_corner_carries_the_field(start):
    """A 2 x 2 square in a fixed ring, cut into an L and the unit square in its inner
    corner: the square's corner at the L's reflex corner is two contacts, one per edge
    there, and each takes the end forces of the pieces along its own edge. Both blocks
    keep σ to 1e-6, nothing moves beyond round-off, with a friction angle of 20°
    (|T|/N = 0.15 and 0.3 on the two contacts, below tan 20° = 0.36). With one contact
    there, it took both edges' forces and the other edge's normal force became shear
    along its own (|T|/N = 0.41): it slipped."""
    ell = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
    blocks = [
        {"name": "ell", "material": "rock", "vertices": ell},
        {"name": "square", "material": "rock", "vertices": square(1, 1, 2, 2)},
    ]
    sections = {"in_situ": {"stress": list(FIELD)}, "joints": {"default": {"friction_angle": 20.0}}}
    result = dda.simulate(dda.load_scene(scene(blocks + ring(2), start=start, **sections)))
    assert np.abs(result.final.stresses[:2] - FIELD).max() <= 1e-6 * 2.0e6
    assert np.abs(result.final.displacements[:2]).max() <= 1e-12


def test_a_field_whose_shear_the_joints_cannot_hold_is_said():
    """σ = (−2, −1, 0.3) MPa in a fixed ring: the bedding joints (horizontal) carry
    τ = 0.3 MPa under σn = 1 MPa, beyond tan 10° = 0.176 of friction (1.70 times), and the
    mass slips from t = 0: the run says which joint and by how much (it said nothing).
    At 30° it holds, and nothing is said."""
    sections = {"in_situ": {"stress": list(FIELD)}}
    weak = scene(uniform("ring"), duration=0.01, **sections)
    weak["joints"]["default"]["friction_angle"] = 10.0
    text = " ".join(dda.simulate(dda.load_scene(weak)).summary["warnings"])
    assert "the in-situ field's shear is beyond the strength of joint 'default'" in text
    ratio = 0.3 / math.tan(math.radians(10.0))
    assert f"up to {ratio:.3g} times it" in text
    strong = scene(uniform("ring"), duration=0.01, **sections)
    assert dda.simulate(dda.load_scene(strong)).summary["warnings"] == []
    far = scene(uniform("ring", 5e5, 4e6), duration=0.01, **sections)  # in its own place
    far["joints"]["default"]["friction_angle"] = 10.0
    text = " ".join(dda.simulate(dda.load_scene(far)).summary["warnings"])
    assert "(at (500000, 4e+06) m)" in text
    bare = scene(uniform("ring"), duration=0.01, in_situ={"stress": [-2e6, 0.0, 3e5]})
    text = " ".join(dda.simulate(dda.load_scene(bare)).summary["warnings"])
    assert "where it holds none" in text  # no normal force on the bedding, no cohesion


def test_a_static_run_says_it_relaxed_a_field_its_boundary_does_not_hold():
    """Static, nothing to hold the field (no ring, no boundary stress): the steps relax it
    (the check was the equilibrium start's, which a static run has not: nothing was said);
    held by the ring it is kept and nothing is said."""
    field = {"stress": [-2.0e6, -1.0e6, 0.3e6]}
    free = scene(uniform("nothing"), duration=0.02, in_situ=field)
    free["analysis"]["mode"] = "static"
    relaxed = dda.simulate(free)
    assert relaxed.summary["start_in_situ_change"] > 0.5
    assert any(
        "the static steps changed the in-situ stress" in w for w in relaxed.summary["warnings"]
    )
    ring = scene(uniform("ring"), duration=0.02, in_situ=field)
    ring["analysis"]["mode"] = "static"
    held = dda.simulate(ring)
    assert held.summary["start_in_situ_change"] < 1e-6
    assert not any("changed the in-situ stress" in w for w in held.summary["warnings"])


@pytest.mark.parametrize(("mode", "start"), [("static", "unloaded"), ("dynamic", "unloaded")])
def test_the_energy_account_starts_with_the_springs_that_carry_the_field(mode, start):
    """An audit: a run whose contacts carry the in-situ field from t = 0 without the
    equilibrium start (static, or the unloaded start) counted their springs' energy from
    step 1 but not in E0: 5 J "created" (5 %) by a block that does not move. Two 1 m
    blocks, σyy = −1 MPa held by a boundary stress: two contacts of 5e5 N on 5e10 N/m
    springs hold N² / 2p = 2.5 J each."""
    from dda.run.run_warnings import energy_excess

    scene = {
        "analysis": {"time_step": 1e-3, "steps": 5, "mode": mode, "start": start},
        "materials": {"rock": {"density": 2600.0, "young": 5e9, "poisson": 0.25}},
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True,
             "vertices": [[0, -1], [1, -1], [1, 0], [0, 0]]},
            {"name": "top", "material": "rock", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]},
        ],
        "in_situ": {"stress": [0.0, -1e6, 0.0]},
        "boundary_stresses": [{"stress": [0.0, -1e6, 0.0], "box": [-0.1, 0.9, 1.1, 1.1]}],
    }  # fmt: skip
    result = dda.simulate(dda.load_scene(scene))
    initial = result.summary["initial_energy"]
    assert initial == pytest.approx(100.0 + 5.0, rel=1e-9)  # σ² / 2E of the block, springs
    assert abs(energy_excess(result.history, initial)[0]) <= 1e-9 * initial


def test_outer_pieces_end_at_the_corners_of_the_blocks_that_cover_the_rest():
    """A 3 m base with a 1 m block on its middle: the base's top is outer on [0, 1] and
    [2, 3], to the corner (they ended 3e-9 m short, the grown polygons' margin, and a far
    field's forces on the outline summed to 0.012 N of 3 MN instead of round-off)."""
    base, top = np.array(square(0, 0, 3, 1), float), np.array(square(1, 1, 2, 2), float)
    pieces = outer_pieces([base, top])
    on_top = (pieces.block == 0) & (pieces.start[:, 1] == 1.0) & (pieces.end[:, 1] == 1.0)
    ends = np.sort(np.column_stack([pieces.start[on_top, 0], pieces.end[on_top, 0]]), axis=1)
    assert ends[np.argsort(ends[:, 0])] == pytest.approx(
        np.array([[0.0, 1.0], [2.0, 3.0]]), abs=1e-14
    )
    field = StressField((-1.0e6, -2.0e6, 0.2e6))
    f_start, f_end = field.segment_forces(pieces.start, pieces.end, pieces.normal)
    assert np.abs((f_start + f_end).sum(axis=0)).max() <= 1e-15 * 3.0e6 * len(f_start)


def test_a_blocks_own_stress_the_start_relaxes_is_said_and_one_beyond_e_refused(caplog):
    """An audit: a free block given `stress = [-2e6, 0, 0]` started at 0 (the equilibrium
    start relaxes what nothing holds, the block keeping its shape), unsaid, where the same
    field as `[in_situ]` is said; and −1e12 Pa on a block of E = 5e9 ran. Now the first is
    said (at once and among the warnings; not by the unloaded start, which releases it as
    a motion), the second refused as the field is."""

    def alone(stress, start="equilibrium"):
        return {
            "analysis": {"time_step": 1e-3, "duration": 0.002, "start": start},
            "materials": {"rock": {"density": 2700.0, "young": 5e9, "poisson": 0.25}},
            "blocks": [{"name": "c", "material": "rock", "stress": stress,
                        "vertices": [[3, 0], [5, 0], [5, 1], [3, 1]]}],
        }  # fmt: skip

    relaxed = dda.simulate(alone([-2e6, 0.0, 0.0]))
    assert abs(relaxed.frames[0].stresses[0][0]) < 1.0
    assert "changed the initial stress of block 'c'" in caplog.text
    assert any("initial stress of block 'c'" in w for w in relaxed.summary["warnings"])
    released = dda.simulate(alone([-2e6, 0.0, 0.0], "unloaded"))
    assert released.frames[0].stresses[0][0] == -2e6
    assert not any("initial stress" in w for w in released.summary["warnings"])
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(alone([-1e12, 0.0, 0.0]))
    assert caught.value.key == "blocks[0].stress"
    assert "as large as the Young's modulus" in str(caught.value)


def opening_scene(box: list, **extra) -> dict:
    """A 12 m square of rock cut by two joint sets, a 2 m circular opening drawn at its
    centre ([[excavations]]), a fixed base, and a far field as a boundary stress over
    ``box``."""
    field = {"stress": [-3.0e6, -2.0e6, 0.0]}
    return {
        "analysis": {"duration": 0.002},
        "materials": {"rock": {"density": 2600.0, "young": 2.0e10, "poisson": 0.25}},
        "joints": {"default": {"friction_angle": 40.0}},
        "in_situ": field,
        "boundary_stresses": [{**field, "box": box, **extra}],
        "regions": [{"polygon": [[-6, -6], [6, -6], [6, 6], [-6, 6]]}],
        "excavations": [{"center": [0.0, 0.0], "radius": 2.0}],
        "joint_sets": [{"dip": 20.0, "spacing": 3.0, "offset": 0.3},
                       {"dip": 110.0, "spacing": 3.0, "offset": 0.7}],
        "blocks": [{"name": "base", "material": "rock", "fixed": True,
                    "vertices": [[-6, -8], [6, -8], [6, -6], [-6, -6]]}],
    }  # fmt: skip


def test_a_far_field_over_a_drawn_opening_leaves_its_walls_out_unless_asked():
    """An audit: a boundary-stress box over a whole section with an opening drawn in it
    pressed the far field onto the opening's walls, which then held it: the opening did
    nothing (the wall's radial stress the field's, 2e-13 m of motion). A far field loads
    the model's outline; the walls of an opening (a hole in the blocks' union) only with
    `openings = true` (a support pressure). A box over the opening alone then loads
    nothing, and is refused saying so."""
    from dda.effects.boundary_stresses import boundary_stress_loads

    def loaded_radii(scene):
        loads = boundary_stress_loads(scene, np.array([b.fixed for b in scene.blocks]), False)
        return np.hypot(*loads.points.positions.T)

    far = dda.load_scene(opening_scene([-7, -7, 7, 7]))
    assert loaded_radii(far).min() > 5.9  # on the outline (|x| or |y| = 6) only
    pressed = dda.load_scene(opening_scene([-7, -7, 7, 7], openings=True))
    walls = loaded_radii(pressed)
    assert np.any(np.abs(walls - 2.0) < 0.2) and walls.max() > 5.9
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(opening_scene([-2.5, -2.5, 2.5, 2.5]))
    assert caught.value.key == "boundary_stresses[0].box"
    assert "the walls of an opening only with openings = true" in str(caught.value)
    support = dda.load_scene(opening_scene([-2.5, -2.5, 2.5, 2.5], openings=True))
    assert np.all(np.abs(loaded_radii(support) - 2.0) < 0.2)
    # the field then changes round the opening as the start finds its stress, said so
    said = " ".join(dda.simulate(far, keep_frames=False).summary["warnings"])
    assert "not in equilibrium with the walls of the opening(s) drawn in the mass" in said


def test_a_field_pushing_on_free_outer_edges_nothing_loads_is_said_as_the_scene_loads():
    """An audit: a 55-block section in an 11.5 MPa field without boundary stresses: the
    start did not settle (1,505 Newton iterations), the run started unloaded and set the
    field loose as motion (1.8 m/s), the only warning blaming friction. The scene says, as
    it loads, where the field pushes on outer edges of free blocks that nothing loads;
    with the boundary stresses over those edges, or a drawn opening's walls alone
    unloaded, it says nothing."""
    unheld = opening_scene([-7, -7, 7, 7])
    del unheld["boundary_stresses"]
    said = " ".join(dda.load_scene(unheld).load_warnings)
    assert "in_situ: the field pushes on" in said and "that no [[boundary_stresses]] loads" in said
    held = dda.load_scene(opening_scene([-7, -7, 7, 7]))
    assert not [w for w in held.load_warnings if "the field pushes on" in w]


def test_a_static_run_s_first_frame_shows_the_forces_its_contacts_carry():
    """An audit: a static run in its in-situ field wrote frame 0 with every contact's
    normal force 0 while every block held the field (the contacts carried it as their
    multipliers); the dynamic run's equilibrium start showed them. Both show them now,
    equal to the next frame's where nothing moves."""
    for mode in ("static", "dynamic"):
        raw = scene(uniform("ring"), in_situ={"stress": [-1.0e6, -2.0e6, 0.0]}, duration=0.002)
        raw["analysis"].update(mode=mode, save_every=1)
        first, second = dda.simulate(dda.load_scene(raw)).frames[:2]
        assert len(first.contacts) == len(second.contacts) > 0
        np.testing.assert_allclose(
            first.contacts.normal_force, second.contacts.normal_force, rtol=1e-9, atol=1e-3
        )
        assert first.contacts.normal_force.max() == pytest.approx(1.0e6)
