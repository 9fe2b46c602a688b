"""Verification harness: meshing, FEM with contact, comparison with the DDA, images, CLI.

The quick cases run in the default test run; the others are marked slow.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import shapely

import dda
from verify.comparison.expect import load_expectation
from verify.fem import fields
from verify.fem.contact import penalty_of
from verify.fem.geometry import insert_points_on_edges
from verify.fem.interfaces import find_interfaces
from verify.fem.mesh import mesh_blocks
from verify.fem.statics import FemOptions, solve_fem
from verify.harness.cases import discover, run_case
from verify.studies.convergence import convergence_study, observed_rates

RHO, G, E, NU = 2700.0, 9.81, 5.0e9, 0.25


def rectangle(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def rotate(points, degrees):
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    return [[c * x - s * y, s * x + c * y] for x, y in points]


def stack_scene(heights=(1.0, 1.0), friction=0.0, angle=0.0, plane="stress", contact=None):
    """Blocks of width 1 stacked on a fixed base, the whole scene rotated by ``angle``."""
    blocks = [
        {
            "name": "base",
            "material": "rock",
            "fixed": True,
            "vertices": rotate(rectangle(-1, -0.5, 2, 0), angle),
        }
    ]
    y = 0.0
    for k, h in enumerate(heights):
        blocks.append(
            {
                "name": f"b{k}",
                "material": "rock",
                "vertices": rotate(rectangle(0, y, 1, y + h), angle),
            }
        )
        y += h
    g = rotate([[0.0, -G]], angle)[0]
    return dda.load_scene(
        {
            "analysis": {"mode": "static", "gravity": g, "plane": plane},
            "contact": contact or {"method": "penalty"},
            "materials": {"rock": {"density": RHO, "young": E, "poisson": NU}},
            "joints": {"default": {"friction_angle": friction}},
            "blocks": blocks,
        }
    )


def l_scene():
    return dda.load_scene(
        {
            "analysis": {"mode": "static", "gravity": [0.0, -G]},
            "materials": {"rock": {"density": RHO, "young": E, "poisson": NU}},
            "blocks": [
                {
                    "name": "base",
                    "material": "rock",
                    "fixed": True,
                    "vertices": rectangle(-0.5, -0.5, 2.5, 0),
                },
                {
                    "name": "ell",
                    "material": "rock",
                    "vertices": [[0, 0], [2, 0], [2, 0.5], [0.5, 0.5], [0.5, 2], [0, 2]],
                },
            ],
        }
    )


# --- meshing -----------------------------------------------------------------


def test_mesh_covers_each_block_exactly_with_separate_nodes():
    scene = l_scene()
    bm = mesh_blocks(scene, size=0.1)
    assert bm.blocks == (1,)  # fixed blocks are not meshed
    p = bm.mesh.p[:, bm.mesh.t]
    area = 0.5 * np.abs(
        (p[0, 1] - p[0, 0]) * (p[1, 2] - p[1, 0]) - (p[0, 2] - p[0, 0]) * (p[1, 1] - p[1, 0])
    )
    assert area.sum() == pytest.approx(shapely.Polygon(scene.blocks[1].vertices).area, rel=1e-12)
    edges = np.concatenate([np.linalg.norm(p[:, i] - p[:, (i + 1) % 3], axis=0) for i in range(3)])
    assert edges.max() <= 0.1 + 1e-12
    # the mesh boundary is the polygon: its length equals the perimeter
    facets = bm.mesh.boundary_facets()
    ends = bm.mesh.p[:, bm.mesh.facets[:, facets]]
    perimeter = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=0).sum()
    assert perimeter == pytest.approx(shapely.Polygon(scene.blocks[1].vertices).length)


def test_mesh_quality_and_tags_for_a_stack():
    bm = mesh_blocks(stack_scene((1.0, 0.1, 0.5)), size=0.05)
    assert set(np.unique(bm.element_block)) == {1, 2, 3}
    p = bm.mesh.p[:, bm.mesh.t]
    sides = [np.linalg.norm(p[:, i] - p[:, (i + 1) % 3], axis=0) for i in range(3)]
    area = 0.5 * np.abs(
        (p[0, 1] - p[0, 0]) * (p[1, 2] - p[1, 0]) - (p[0, 2] - p[0, 0]) * (p[1, 1] - p[1, 0])
    )
    quality = 4 * np.sqrt(3) * area / sum(s**2 for s in sides)
    assert quality.min() > 0.3  # the thin block does not start from needles
    # each node belongs to one block: blocks meeting at y = 1 have distinct nodes
    on_joint = np.flatnonzero(np.isclose(bm.mesh.p[1], 1.0))
    assert set(bm.node_block[on_joint]) == {1, 2}


def test_t_junction_vertices_are_inserted():
    square = np.array(rectangle(0, 0, 2, 1), dtype=float)
    out = insert_points_on_edges(square, np.array([[1.0, 0.0], [0.0, 0.0], [5.0, 5.0]]), 1e-9)
    assert out.tolist() == [[0, 0], [1, 0], [2, 0], [2, 1], [0, 1]]


def test_interfaces_found_with_their_contact_count_and_joint():
    interfaces = find_interfaces(stack_scene((1.0, 1.0, 1.0), friction=30.0))
    assert [i.pair for i in interfaces] == [(0, 1), (1, 2), (2, 3)]
    assert all(i.contacts == 2 and i.joint.friction_angle == 30.0 for i in interfaces)
    assert interfaces[0].length == pytest.approx(1.0)


# --- FEM with contact, against closed forms (no DDA needed) ---------------------


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("angle", [0.0, 30.0])
def test_fem_stack_block_averages_and_interface_forces(order, angle):
    scene = stack_scene((1.0, 0.5), angle=angle)
    solution = solve_fem(scene, options=FemOptions(order=order, size=0.25))
    stress = fields.block_average_stress(solution)
    # rotate back to the stack's frame: syy' = n.sigma.n with n the stack's axis
    a = np.radians(angle)
    n = np.array([-np.sin(a), np.cos(a)])
    for block, expected in ((2, -RHO * G * 0.25), (1, -RHO * G * (0.5 + 0.5))):
        sxx, syy, sxy = stress[block]
        sigma = np.array([[sxx, sxy], [sxy, syy]])
        assert n @ sigma @ n == pytest.approx(expected, rel=1e-9)
    forces = fields.interface_forces(solution)
    weight = RHO * G * 1.5
    assert forces[0]["normal_force"] == pytest.approx(weight, rel=1e-9)
    assert forces[1]["normal_force"] == pytest.approx(RHO * G * 0.5, rel=1e-9)
    # equal interface stiffness: mean penetration N / (n_c p) with n_c = 2
    assert forces[0]["penetration"] == pytest.approx(weight / (2 * penalty_of(scene)), rel=1e-4)


def test_fem_self_weight_field_is_linear_in_height():
    scene = stack_scene((2.0,))
    solution = solve_fem(scene, options=FemOptions(size=0.125))
    sigma = fields.stress_field(solution)  # (3, M, 3) at element corners
    y = solution.block_mesh.mesh.p[1, solution.block_mesh.mesh.t.T]
    interior = (y > 0.5).all(axis=1)  # away from the base, where the springs act
    expected = -RHO * G * (2.0 - y[interior])
    assert np.abs(sigma[1][interior] - expected).max() < 0.02 * RHO * G * 2.0


def test_active_set_opens_the_unloaded_part_without_tension():
    scene = dda.load_scene(
        {
            "analysis": {"mode": "static"},
            "materials": {"rock": {"density": RHO, "young": E, "poisson": NU}},
            "blocks": [
                {
                    "name": "base",
                    "material": "rock",
                    "fixed": True,
                    "vertices": rectangle(-1.5, -0.5, 1.5, 0),
                },
                {"name": "block", "material": "rock", "vertices": rectangle(-1, 0, 1, 1)},
            ],
            "loads": [{"block": "block", "point": [0.8, 1.0], "force": [0.0, -1e5]}],
        }
    )
    solution = solve_fem(scene, options=FemOptions(size=0.125))
    gaps = solution.contact.gaps(solution.u)
    assert solution.iterations > 1
    assert 0.2 < solution.active.mean() < 0.8
    assert (gaps[solution.active] < 0).all() and (gaps[~solution.active] >= 0).all()
    force = fields.interface_forces(solution)[0]
    assert force["normal_force"] == pytest.approx(1e5, rel=1e-7)  # stabiliser: 1e-8
    assert fields.block_average_stress(solution)[1, 1] == pytest.approx(-1e5 / 2.0, rel=1e-9)


def test_plane_strain_changes_displacement_not_averages():
    stress_run = solve_fem(stack_scene((1.0,)), options=FemOptions(size=0.25))
    strain_run = solve_fem(stack_scene((1.0,), plane="strain"), options=FemOptions(size=0.25))
    s1, s2 = (fields.block_average_stress(r)[1] for r in (stress_run, strain_run))
    assert s1[1] == pytest.approx(s2[1], rel=1e-9)
    u1, u2 = (fields.block_mean_displacement(r)[1, 1] for r in (stress_run, strain_run))
    assert abs(u2) < abs(u1)  # plane strain is stiffer


def test_projected_stress_has_the_block_average():
    solution = solve_fem(l_scene(), options=FemOptions(size=0.2))
    sigma = fields.stress_field(solution)[1]  # P1 per element: mean of corner values
    p = solution.block_mesh.mesh.p[:, solution.block_mesh.mesh.t]
    area = 0.5 * np.abs(
        (p[0, 1] - p[0, 0]) * (p[1, 2] - p[1, 0]) - (p[0, 2] - p[0, 0]) * (p[1, 1] - p[1, 0])
    )
    projected = (sigma.mean(axis=1) * area).sum() / area.sum()
    assert projected == pytest.approx(fields.block_average_stress(solution)[1, 1], rel=1e-9)


def test_convergence_rates_against_the_closed_form():
    points = convergence_study()
    rates = observed_rates(points)
    assert rates["displacement"] > 1.7  # P1: 2 expected
    assert rates["stress"] > 0.85  # P1: 1 expected
    p2 = [p for p in points if p.order == 2][0]
    assert p2.displacement_error < 1e-10 and p2.stress_error < 1e-10


def incline_scene(theta, phi, spring=None, cohesion=0.0, tensile=0.0, gravity=G):
    """A 2 x 1 block on a base tilted by ``theta`` (gravity vertical), optionally held
    at its centroid by a fixed point of stiffness ``spring``."""
    slider = {
        "name": "slider",
        "material": "rock",
        "vertices": rotate(rectangle(-1, 0, 1, 1), theta),
    }
    analysis = {"mode": "static", "gravity": [0.0, -gravity]}
    if spring is not None:
        slider["fixed_points"] = rotate([[0.0, 0.5]], theta)
        analysis["fixed_point_penalty"] = spring
    joint = {"friction_angle": phi, "cohesion": cohesion, "tensile_strength": tensile}
    return dda.load_scene(
        {
            "analysis": analysis,
            "contact": {"method": "penalty"},
            "materials": {"rock": {"density": RHO, "young": E, "poisson": NU}},
            "joints": {"default": joint},
            "blocks": [
                {
                    "name": "base",
                    "material": "rock",
                    "fixed": True,
                    "vertices": rotate(rectangle(-2, -1, 2, 0), theta),
                },
                slider,
            ],
        }
    )


def along_slope(vector, theta):
    a = np.radians(theta)
    return np.array([np.cos(a), np.sin(a)]) @ vector, np.array([-np.sin(a), np.cos(a)]) @ vector


@pytest.mark.parametrize(("theta", "phi"), [(30.0, 25.0), (20.0, 30.0)])
def test_fem_coulomb_friction_finds_stick_and_slip_itself(theta, phi):
    weight, mu, spring = RHO * G * 2.0, np.tan(np.radians(phi)), 1e6
    solution = solve_fem(incline_scene(theta, phi, spring), FemOptions(size=0.25))
    force = fields.interface_forces(solution)[0]
    shear, normal = along_slope(force["force"], theta)
    assert normal == pytest.approx(weight * np.cos(np.radians(theta)), rel=1e-4)
    slide = along_slope(fields.block_mean_displacement(solution)[1], theta)[0]
    if theta > phi:  # slips: friction at its limit, the spring holds the rest
        assert force["slip_fraction"] == 1.0
        assert shear == pytest.approx(mu * normal, rel=1e-9)
        expected = -(weight * np.sin(np.radians(theta)) - mu * normal) / spring
        assert slide == pytest.approx(expected, rel=1e-3)
    else:  # sticks (but for the continuum's edge), the base carries the whole slope load
        assert force["slip_fraction"] < 0.05
        assert shear == pytest.approx(weight * np.sin(np.radians(theta)), rel=1e-3)
        assert abs(slide) < 1e-5


def test_fem_cohesion_and_tensile_strength_hold_until_exceeded():
    weight, theta, options = RHO * G * 2.0, 30.0, FemOptions(size=0.25)
    pull = weight * np.sin(np.radians(theta))  # down the slope, no friction

    def base_force(scene):
        return fields.interface_forces(solve_fem(scene, options))[0]

    # the shear traction of an elastic block on springs peaks at the base's ends: the
    # joint holds with 1.5 x the mean (at 1.1 x its ends give way and the rest follows)
    assert base_force(incline_scene(theta, 0.0, 1e6, cohesion=1.5 * pull / 2))["slip_fraction"] == 0
    broken = base_force(incline_scene(theta, 0.0, 1e6, cohesion=0.9 * pull / 2))
    assert broken["slip_fraction"] == 1.0
    assert along_slope(broken["force"], theta)[0] == pytest.approx(0.0, abs=1e-6)
    # gravity upside down: the block hangs from its joint while T L exceeds its weight
    # (with cohesion too: a joint in tension has no friction, any shear would break it)
    bond = 1.5 * weight / 2
    hung = base_force(incline_scene(0.0, 30.0, cohesion=bond, tensile=bond, gravity=-G))
    assert hung["closed_fraction"] == 1.0
    assert hung["normal_force"] == pytest.approx(-weight, rel=1e-6)
    bond = 0.9 * weight / 2
    fallen = base_force(incline_scene(0.0, 30.0, 1e6, cohesion=bond, tensile=bond, gravity=-G))
    assert fallen["closed_fraction"] == 0.0


def test_fem_augmented_lagrangian_closes_to_the_tolerance():
    contact = {"method": "augmented-lagrangian", "tolerance": 1e-10}
    solution = solve_fem(stack_scene((2.0,), contact=contact), FemOptions(size=0.25))
    gaps = solution.contact.gaps(solution.u)[solution.active]
    assert -gaps.min() <= 1e-10
    assert fields.interface_forces(solution)[0]["normal_force"] == pytest.approx(
        RHO * G * 2, rel=1e-9
    )


def test_fem_dynamics_is_the_engines_integrator():
    """Free fall is exact; a stiff block on two springs follows the scheme's recurrence."""
    from verify.fem.dynamics import integrate

    dt, steps, k, v0 = 0.004, 60, 1e6, (0.3, 0.1)
    raw = {
        "analysis": {"mode": "dynamic", "gravity": [0.0, -G], "time_step": dt, "steps": steps},
        "materials": {"rock": {"density": RHO, "young": 1e3 * E, "poisson": NU}},
        "blocks": [
            {
                "name": "b",
                "material": "rock",
                "vertices": rectangle(0, 0, 1, 1),
                "velocity": [*v0, 0.0],
            }
        ],
    }
    falling = integrate(dda.load_scene(raw), FemOptions(size=0.5))
    t = falling.times
    assert falling.displacements[:, 0, 0] == pytest.approx(v0[0] * t, rel=1e-6, abs=1e-12)
    expected = v0[1] * t - G * t**2 / 2
    assert falling.displacements[:, 0, 1] == pytest.approx(expected, rel=1e-6, abs=1e-12)
    raw["analysis"]["fixed_point_penalty"] = k
    raw["blocks"][0].update(velocity=[0.0, 0.0, 0.0], fixed_points=[[0.0, 0.5], [1.0, 0.5]])
    hanging = integrate(dda.load_scene(raw), FemOptions(size=0.5))
    m, u, v, recurrence = RHO * 1.0, 0.0, 0.0, [0.0]
    for _ in range(steps):  # (2k + 2m/dt^2) D = -m g - 2k u + (2m/dt) v; v <- 2D/dt - v
        d = (-m * G - 2 * k * u + 2 * m / dt * v) / (2 * k + 2 * m / dt**2)
        u, v = u + d, 2 * d / dt - v
        recurrence.append(u)
    amplitude = m * G / (2 * k)
    assert np.abs(hanging.displacements[:, 0, 1] - recurrence).max() < 1e-4 * amplitude


def test_fracture_criterion_has_the_papers_numbers():
    from verify.fem.fracture import Strength, fails

    rock = Strength(1.78e5, 39.1, 0.85e5)  # psf, the paper's rock
    assert rock.slope == pytest.approx(4.415296, rel=1e-6)
    assert rock.uniaxial == pytest.approx(7.480488e5, rel=1e-6)
    assert -rock.uniaxial + rock.tensile_strength * rock.slope == pytest.approx(
        -3.727486e5, rel=1e-6
    )
    assert fails(np.array([0.0, -1.001 * rock.uniaxial, 0.0]), rock)
    assert not fails(np.array([0.0, -0.999 * rock.uniaxial, 0.0]), rock)
    assert fails(np.array([1.001 * rock.tensile_strength, 0.0, 0.0]), rock)
    assert not fails(np.array([0.999 * rock.tensile_strength, 0.0, 0.0]), rock)


def test_block_strain_from_vertices_is_free_of_rotation():
    from verify.comparison.dda_side import block_strain

    square = np.array(rectangle(0, 0, 1, 1), dtype=float)
    strain = np.array([[1e-3, 2e-4], [2e-4, -5e-4]])  # exx, exy / exy, eyy
    a = np.radians(40.0)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    moved = (square - 0.5) @ (turn @ (np.eye(2) + strain)).T + [3.0, -2.0]
    assert block_strain(square, moved) == pytest.approx([1e-3, -5e-4, 4e-4], abs=1e-15)


# --- cases ---------------------------------------------------------------------

DISPLACEMENT_CHECKS = {"strain", "centroid", "vertex", "history", "onset", "motion"}
STRESS_CHECKS = {"stress", "closed_form", "stress_history"}


def test_every_case_is_a_valid_scene_with_reasoned_expectations():
    cases = discover()
    names = {c.name for c in cases}
    assert {"self_weight", "column", "incline_slip", "incline_stick", "released"} <= names
    assert {"fracture_onset", "column_al"} <= names
    for case in cases:
        scene = dda.load_scene(case.scene_path)
        expectation = load_expectation(case.expect_path)
        dynamic = expectation.kind in ("dynamic", "motion")
        assert scene.analysis.mode == ("dynamic" if dynamic else "static")
        assert expectation.summary and expectation.checks
        # every case checks displacements (or what is measured from them) and stresses,
        # or its notes say why no displacement can be compared (nothing moves in either)
        moved = DISPLACEMENT_CHECKS & set(expectation.checks)
        assert moved or "centroid" in expectation.notes, case.name
        assert STRESS_CHECKS & set(expectation.checks), case.name
        for check in expectation.checks.values():
            assert len(check.why) > 20, (case.name, check.quantity)
            if check.tolerance > 0.01:
                assert any(ch.isdigit() for ch in check.why), (case.name, check.quantity)


QUICK = [c.name for c in discover(quick=True)]
SLOW = [c.name for c in discover() if c.name not in QUICK]


@pytest.fixture(scope="module")
def quick_results():
    return {name: run_case(discover(names=[name])[0]) for name in QUICK}


@pytest.mark.parametrize("name", QUICK)
def test_quick_case_agrees_within_its_tolerances(quick_results, name):
    result = quick_results[name]
    failed = [(v.quantity, v.error, v.tolerance) for v in result.verdicts if not v.passed]
    assert not failed
    if result.expectation.kind == "static":
        assert result.dda.settled < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_slow_case_agrees_within_its_tolerances(name):
    result = run_case(discover(names=[name])[0])
    assert result.passed, [(v.quantity, v.error, v.tolerance) for v in result.verdicts]


def test_predicted_offsets_are_signed(quick_results):
    """Turning a predicted offset round fails the case: the check is on the signed difference."""
    result = quick_results["self_weight"]
    row = next(r for r in result.rows if r.key == "centroid.block.uy")
    assert row.offset > 0 and row.error < 1e-3
    flipped = dataclasses.replace(row, offset=-row.offset)
    assert flipped.error > 0.3


def test_verify_uses_only_the_engines_public_api():
    """verify imports dda, its scene and its result types: nothing else of the engine."""
    import ast
    from pathlib import Path

    import verify

    allowed = {"dda", "dda.scene", "dda.result", "dda.cases"}  # dda.cases: the shipped files
    for path in Path(verify.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("dda"):
                assert node.module in allowed, (path.name, node.module)
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("dda"):
                        assert alias.name in allowed, (path.name, alias.name)


def test_fem_side_reads_nothing_from_the_engine(monkeypatch):
    """The FEM model of a case is the same whatever the engine does."""
    case = discover(names=["self_weight"])[0]
    scene = dda.load_scene(case.scene_path)
    before = solve_fem(scene, FemOptions(size=0.25))
    monkeypatch.setattr(dda, "simulate", None)
    monkeypatch.setattr("dda.run.simulation.run", None)
    after = solve_fem(scene, FemOptions(size=0.25))
    assert np.array_equal(before.u, after.u)


# --- block refinement ----------------------------------------------------------


@pytest.fixture(scope="module")
def refinement():
    from verify.studies.refinement import refinement_study

    return refinement_study(ks=(1, 2, 4))


def test_refinement_findings_hold_up_to_k_4(refinement):
    from verify.studies.refinement import findings

    points, references = refinement
    failed = [(f.body, f.claim, f.value) for f in findings(points) if not f.passed]
    assert not failed
    for body, estimate in references.items():  # the reference is converged far below the errors
        smallest = min(p.displacement for p in points if p.body == body)
        assert max(estimate["displacement"], estimate["stress"], estimate["tip"]) < 0.05 * smallest


def test_rigidly_bonded_squares_lock(refinement):
    """Documented: squares bonded at their corners cannot bend, whatever k."""
    from verify.studies.refinement import series_run

    points, _ = refinement
    for body in ("cantilever", "l_shape"):
        errors = [p.displacement for p in series_run(points, body, "squares, p = 1e4 E")]
        assert min(errors) > 0.75 and max(errors) / min(errors) < 1.02


@pytest.mark.slow
def test_refinement_to_k_16():
    """Triangles converge at P1's orders (cantilever 1.8, L 1.5 over the last doubling)."""
    from verify.studies.refinement import findings, observed_orders, refinement_study

    points, _ = refinement_study()
    assert all(f.passed for f in findings(points))
    orders = observed_orders(points, "displacement")
    assert orders[("cantilever", "triangles, p = 1e4 E")][-1] > 1.7
    assert orders[("l_shape", "triangles, p = 1e4 E")][-1] > 1.4
    stress = observed_orders(points, "stress")
    assert stress[("cantilever", "triangles, p = 1e4 E")][-1] > 0.85


# --- pictures, report, command line ----------------------------------------------


def non_background_fraction(image: np.ndarray) -> float:
    rgb = image[..., :3].astype(int)
    return float((np.abs(rgb - 255).sum(axis=-1) > 30).mean())


def read_image(path) -> np.ndarray:
    import matplotlib.image as mpimg

    image = mpimg.imread(path)
    return image if image.dtype == np.uint8 else (image * 255).astype(np.uint8)


def panels(image: np.ndarray, rows: int, columns: int, top: int = 0):
    """The picture below ``top`` cut into equal panels, (row, column, pixels) each."""
    height, width = image.shape[0] - top, image.shape[1]
    for r in range(rows):
        for c in range(columns):
            yield (
                r,
                c,
                image[
                    top + r * height // rows : top + (r + 1) * height // rows,
                    c * width // columns : (c + 1) * width // columns,
                ],
            )


def assert_data_in_every_panel(image: np.ndarray, rows: int, columns: int, top: int = 0):
    for r, c, part in panels(image, rows, columns, top):
        assert non_background_fraction(part) > 0.05, (r, c)
        rgb = part[..., :3].astype(int)
        assert (rgb.max(axis=-1) - rgb.min(axis=-1) > 40).mean() > 0.005, (r, c)


def colour_at(image: np.ndarray, result, row: int, column: int, point, half: int = 6):
    """Median colour of a small square around a scene point in a field picture's panel."""
    from verify.pictures.field_layout import HEADER, layout

    frame = layout(result)
    width, height = frame.panel
    offset = (np.asarray(point, dtype=float) - frame.focus) / frame.pixel
    x = int(round(column * width + width / 2 + offset[0]))
    y = int(round(HEADER + row * height + height / 2 - offset[1]))
    window = image[y - half : y + half + 1, x - half : x + half + 1, :3].reshape(-1, 3)
    return np.median(window, axis=0)


@pytest.fixture(scope="module")
def self_weight_picture(quick_results, tmp_path_factory):
    """The field picture of self_weight, rendered once (pyvista, off screen)."""
    from verify.pictures.images import case_image

    folder = tmp_path_factory.mktemp("pictures")
    return case_image(quick_results["self_weight"], folder / "verify_self_weight.png")


def test_field_picture_is_a_png_of_sensible_size_with_data_in_every_panel(self_weight_picture):
    from verify.pictures.field_layout import HEADER

    assert self_weight_picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = read_image(self_weight_picture)
    height, width = image.shape[:2]
    assert 1200 <= width <= 2400 and 900 <= height <= 2400, (width, height)
    assert_data_in_every_panel(image, 2, 3, top=HEADER)


def test_field_picture_tells_fixed_blocks_from_a_difference_near_zero(
    quick_results, self_weight_picture
):
    """The block's differences (5e-6 and -5e-5 of a 1e-3 tolerance) are drawn near white;
    the fixed base dark grey (#4d4d4d, hatched: the median of a patch is its fill)."""
    result = quick_results["self_weight"]
    image = read_image(self_weight_picture)
    for row in (0, 1):
        assert (colour_at(image, result, row, 2, (0.5, 0.4)) > 225).all(), row
        for column in (0, 1, 2):
            fill = colour_at(image, result, row, column, (1.5, -0.5))
            assert np.abs(fill - 0x4D).max() < 20, (row, column, fill)


def test_difference_panels_have_a_fixed_tolerance_scale_and_mark_unchecked_blocks(
    quick_results, tmp_path
):
    """A stress difference of +tol/2 takes the colour at 3/4 of the ±tol colour map
    (RdBu_r(0.75) = (228, 128, 102); a scale of ±2 tol would give (251, 204, 180)); a
    block the centroid check leaves out is light grey (#d9d9d9), not white."""
    from verify.pictures.images import case_image

    result = quick_results["self_weight"]
    tolerance = result.expectation.checks["stress"].tolerance

    def moved(row):
        if row.quantity != "stress" or row.component != "syy":
            return row
        return dataclasses.replace(row, dda=row.fem + row.offset + 0.5 * tolerance * row.scale)

    checks = dict(result.expectation.checks)
    checks["centroid"] = dataclasses.replace(checks["centroid"], blocks=("nobody",))
    changed = dataclasses.replace(
        result,
        rows=[moved(row) for row in result.rows],
        expectation=dataclasses.replace(result.expectation, checks=checks),
    )
    image = read_image(case_image(changed, tmp_path / "changed.png"))
    red = colour_at(image, changed, 0, 2, (0.5, 0.4))
    assert np.abs(red - (228, 128, 102)).max() < 20, red
    grey = colour_at(image, changed, 1, 2, (0.5, 0.4))
    assert np.abs(grey - 0xD9).max() < 15, grey


def test_history_picture_shows_data_in_every_panel(quick_results, tmp_path):
    from verify.pictures.images import case_image

    path = case_image(quick_results["released"], tmp_path / "verify_released.png")
    assert_data_in_every_panel(read_image(path), 2, 2)


def test_summary_and_refinement_charts(quick_results, refinement, tmp_path):
    from verify.pictures.images import refinement_chart, summary_chart

    chart = summary_chart(list(quick_results.values()), tmp_path / "summary.png")
    assert non_background_fraction(read_image(chart)) > 0.02
    chart = refinement_chart(refinement[0], tmp_path / "refinement.png")
    assert non_background_fraction(read_image(chart)) > 0.05


def test_the_refinement_chart_labels_an_error_axis_within_a_decade(tmp_path, monkeypatch):
    """Errors from 0.33 to 0.36 (k = 1, 2): the y axis has labelled ticks (minor ticks were
    off on both axes, and such a panel had no y label at all)."""
    from types import SimpleNamespace

    import matplotlib.pyplot as plt

    from verify.pictures import plots

    kept = []
    monkeypatch.setattr(plots, "save", lambda fig, path, dpi: kept.append(fig) or path)
    points = [
        SimpleNamespace(body="b", series=s, k=k, displacement=0.3 * (1 + 0.1 * k), stress=0.2 / k)
        for s in ("P2", "P1 FEM")
        for k in (1, 2)
    ]
    plots.refinement_chart(points, tmp_path / "r.png")
    (figure,) = kept
    figure.canvas.draw()
    for ax in figure.axes:
        low, high = ax.get_ylim()
        shown = [
            label.get_text()
            for ticks, labels in ((ax.yaxis.get_majorticklocs(), ax.yaxis.get_majorticklabels()),
                                  (ax.yaxis.get_minorticklocs(), ax.yaxis.get_minorticklabels()))
            for tick, label in zip(ticks, labels, strict=False)
            if low <= tick <= high and label.get_text()
        ]  # fmt: skip
        assert len(shown) >= 2, shown
    plt.close(figure)


def test_the_summary_reads_at_full_size(tmp_path, monkeypatch):
    """32 cases and 20 checked quantities: a row per case and a labelled column per
    quantity, grouped, at most 2000 px wide, every ratio written in its cell, a failing
    check in its own colour."""
    from types import SimpleNamespace

    import matplotlib.pyplot as plt

    from verify.pictures.plots import QUANTITY_GROUPS, summary_chart

    quantities = [q for group in QUANTITY_GROUPS.values() for q in group][:20]
    results = [
        SimpleNamespace(
            case=SimpleNamespace(name=f"case{i}"), passed=i != 3,
            verdicts=[SimpleNamespace(quantity=q, error=10.0 ** -(i % 9) * (3 if i == 3 else 1),
                                      tolerance=1.0) for q in quantities[i % 5 :: 3]],
        )
        for i in range(32)
    ]  # fmt: skip
    figures, save = [], plt.Figure.savefig
    monkeypatch.setattr(
        plt.Figure, "savefig", lambda f, *a, **k: (figures.append(f), save(f, *a, **k))
    )
    image = read_image(summary_chart(results, tmp_path / "summary.png"))
    assert image.shape[1] <= 2000 and image.shape[0] <= 1500
    ax = figures[-1].axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == [
        q for q in quantities if any(v.quantity == q for r in results for v in r.verdicts)
    ]
    assert len(ax.get_yticklabels()) == 32 and ax.get_yticklabels()[3].get_text() == "case3  FAIL"
    cells = sum(len(r.verdicts) for r in results)
    assert len([t for t in ax.texts if t.get_text() not in ("", *QUANTITY_GROUPS)]) == cells


QUICK_CLI = ["--no-images", "--no-convergence", "--no-refinement"]


def test_cli_writes_report_and_fails_on_unknown_case(tmp_path, capsys):
    from verify.cli import main

    code = main(["self_weight", "column", "-o", str(tmp_path), *QUICK_CLI])
    assert code == 0
    out = capsys.readouterr().out
    assert "self_weight" in out and "PASS" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["passed"] and [c["name"] for c in report["cases"]] == ["self_weight", "column"]
    assert "| self_weight | stress |" in (tmp_path / "report.md").read_text()
    assert main(["no_such_case", "-o", str(tmp_path), "--no-images"]) == 2
    assert main(["self_weight", "-o", str(tmp_path), "--refinement-max", "6"]) == 2
    assert main(["self_weight", "-o", str(tmp_path), "--refinement-max", "0"]) == 2  # not 16
    assert main(["self_weight", "--cases-dir", str(tmp_path / "none")]) == 2  # was 1


@pytest.mark.parametrize(("name", "make"), [("images", "file"), ("report.md", "folder")])
def test_a_report_place_taken_by_the_wrong_kind_is_refused_before_any_case(tmp_path, name, make):
    """``-o D`` where D/images is a file or D/report.md a folder: exit 2 at once, nothing
    run or written (it ran the cases, then failed with exit 1 and half a report)."""
    from verify.cli import main

    blocked = tmp_path / name
    blocked.write_text("") if make == "file" else blocked.mkdir()
    assert main(["self_weight", "-o", str(tmp_path), "--no-images"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_cli_returns_nonzero_when_a_tolerance_fails(tmp_path):
    from verify.cli import main

    source = discover(names=["self_weight"])[0]
    (tmp_path / "strict.toml").write_text(source.scene_path.read_text())
    # a wrong predicted offset (its sign turned round) must fail the case
    text = source.expect_path.read_text().replace(
        '"centroid.block.uy" = 1.7658e-6', '"centroid.block.uy" = -1.7658e-6'
    )
    assert text != source.expect_path.read_text()
    (tmp_path / "strict.expect.toml").write_text(text)
    code = main(["--cases-dir", str(tmp_path), "-o", str(tmp_path / "out"), *QUICK_CLI])
    assert code == 1


def test_cli_refuses_a_bad_expectation_file_in_one_line(tmp_path, capsys):
    from verify.cli import main

    source = discover(names=["self_weight"])[0]
    (tmp_path / "bad.toml").write_text(source.scene_path.read_text())
    text = source.expect_path.read_text().replace("[checks.centroid]", "[checks.centroids]")
    (tmp_path / "bad.expect.toml").write_text(text)
    assert main(["--cases-dir", str(tmp_path), "-o", str(tmp_path / "out"), *QUICK_CLI]) == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "bad.expect.toml" in error and "checks.centroids" in error and "Traceback" not in error
    assert not (tmp_path / "out" / "report.md").exists()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: "bogus = 1\n" + t, "bogus: unknown key"),
        (lambda t: t.replace("[checks.centroid]", "[checks.centroid]\ntolerence = 5"),
         "checks.centroid.tolerence: unknown key"),
        (lambda t: t.replace("[fem]", "[fem]\nsise = 0.1"), "fem.sise: unknown key"),
        (lambda t: t.split("[checks.")[0], "checks: the case checks nothing"),
        (lambda t: t.replace("tolerance = 1e-3", 'tolerance = "x"', 1),
         "tolerance: must be a finite number >= 0, got 'x'"),
        # an audit's (each ran, then failed, crashed or passed checking nothing)
        (lambda t: t.replace("tolerance = 1e-3", "tolerance = inf", 1),
         "tolerance: must be a finite number >= 0, got inf"),
        (lambda t: t.replace("[fem]", "[fem]\nsize = 0", 1) if "size" not in t
         else t.replace("size = ", "size = -", 1), "fem.size: must be a length > 0"),
        (lambda t: t.replace("[checks.centroid]", '[checks.centroid]\ncomponents = "uy"'),
         "checks.centroid.components: must be a list of names, got 'uy'"),
        (lambda t: t + '\n[dda_closed_form]\n"block.szz" = 1.0\n',
         "dda_closed_form.block.szz: expected BLOCK.COMPONENT"),
        (lambda t: t + '\n[dda_closed_form]\n"block.syy" = "abc"\n',
         "dda_closed_form.block.syy: must be a number, got 'abc'"),
        (lambda t: t.replace('kind = "static"', 'kind = "motion"') if 'kind = "static"' in t
         else 'kind = "motion"\n' + t, "reference: required for kind = 'motion'"),
    ],
)  # fmt: skip
def test_an_expectation_that_cannot_be_used_is_refused_by_its_key(tmp_path, capsys, edit, message):
    """An unknown key, a check table that checks nothing, a tolerance that is no number:
    was "1/1 cases within their tolerances" with no check, exit 0."""
    from verify.cli import main

    source = discover(names=["self_weight"])[0]
    (tmp_path / "mine.toml").write_text(source.scene_path.read_text())
    text = edit(source.expect_path.read_text())
    assert text != source.expect_path.read_text()
    (tmp_path / "mine.expect.toml").write_text(text)
    assert main(["--cases-dir", str(tmp_path), "-o", str(tmp_path / "out"), *QUICK_CLI]) == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "mine.expect.toml" in error and message in error
    assert not (tmp_path / "out").exists()


def test_a_file_given_as_the_cases_folder_is_refused_as_such(tmp_path, capsys):
    from verify.cli import main

    (tmp_path / "afile").write_text("")
    assert main(["--cases-dir", str(tmp_path / "afile"), "-o", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.endswith("afile: is a file, not a folder of cases")


def test_a_cases_folder_without_cases_is_refused(tmp_path, capsys):
    from verify.cli import main

    (tmp_path / "cases").mkdir()
    assert main(["--cases-dir", str(tmp_path / "cases"), "-o", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err.strip()
    assert error == f"dda verify: --cases-dir {tmp_path / 'cases'}: no NAME.expect.toml in it"
    assert not (tmp_path / "out").exists()


def test_dda_command_has_verify():
    from dda.commands.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["verify", "--quick", "-o", "x"])
    assert args.func.__name__ == "run_verify" and args.quick


@pytest.mark.slow
def test_full_suite_with_images(tmp_path):
    from verify.suite import run_suite

    output = run_suite(outdir=tmp_path)
    assert output.passed
    for name in ("verify_summary.png", "verify_refinement.png", "verify_released.png"):
        assert (tmp_path / "images" / name).is_file()
    report = (tmp_path / "report.md").read_text()
    assert "Observed P1 rates" in report and "Block refinement" in report


def test_the_released_block_agrees_with_the_fem_under_a_damped_velocity_update(tmp_path):
    """The FEM side reads ``newmark_gamma`` from the scene and integrates with it: the
    released block's histories agree at γ = 0.9 within the case's own tolerances
    (measured 1.6e-4 against 1e-3)."""
    case = discover(names=["released"])[0]
    damped = "[analysis]\nnewmark_gamma = 0.9\n"
    text = case.scene_path.read_text().replace("[analysis]\n", damped, 1)
    assert "newmark_gamma" in text
    (tmp_path / "released.toml").write_text(text)
    (tmp_path / "released.expect.toml").write_text(case.expect_path.read_text())
    result = run_case(discover(tmp_path)[0])
    assert result.scene.analysis.newmark_gamma == 0.9
    assert all(v.passed for v in result.verdicts), [(v.quantity, v.error) for v in result.verdicts]


def raising_for(name: str, monkeypatch) -> list[str]:
    """Make the case ``name`` raise SimulationError; returns the names of the cases run."""
    import verify.suite

    ran, real = [], verify.suite.run_case

    def run_case(case, reference=None):
        ran.append(case.name)
        if case.name == name:
            raise dda.SimulationError("step 3: the contacts did not settle")
        return real(case, reference)

    monkeypatch.setattr(verify.suite, "run_case", run_case)
    return ran


def test_a_case_that_raises_is_an_error_and_the_others_still_run(tmp_path, capsys, monkeypatch):
    """A crash cannot silence the suite: the raising case is ERROR in the console table,
    report.md and report.json, the cases after it still run, and the exit status (3)
    says "a case raised", apart from "a check failed" (1)."""
    from verify.cli import EXIT_ERRORS, main

    ran = raising_for("self_weight", monkeypatch)
    code = main(["self_weight", "column", "-o", str(tmp_path), *QUICK_CLI])
    assert code == EXIT_ERRORS == 3
    assert ran == ["self_weight", "column"]
    out = capsys.readouterr().out
    assert "ERROR: SimulationError: step 3: the contacts did not settle" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert not report["passed"] and [c["name"] for c in report["cases"]] == ["column"]
    assert report["errors"] == [
        {"name": "self_weight", "message": "SimulationError: step 3: the contacts did not settle"}
    ]
    markdown = (tmp_path / "report.md").read_text()
    assert "| self_weight | - | - | - | ERROR: SimulationError" in markdown
    assert "## Errors" in markdown


def test_an_output_folder_that_cannot_be_written_is_refused_before_any_case(
    tmp_path, capsys, monkeypatch
):
    """-o below a file: exit 2 with the folder and the reason, before any case runs."""
    from verify.cli import main

    ran = raising_for("none", monkeypatch)
    (tmp_path / "a_file").write_text("")
    out = tmp_path / "a_file" / "report"
    assert main(["self_weight", "-o", str(out), *QUICK_CLI]) == 2
    assert ran == []
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert str(out) in error and "cannot write there" in error and "Traceback" not in error


def test_a_read_only_output_folder_is_refused_before_any_case(tmp_path, capsys, monkeypatch):
    """-o on a read-only file system (a tmpfs mounted read-only; skipped where it cannot
    be mounted): exit 2 naming the folder, before any case runs."""
    from tests.tmpfs import mounted
    from verify.cli import main

    ran = raising_for("none", monkeypatch)
    with mounted(tmp_path / "read_only", read_only=True) as read_only:
        for out in (read_only, read_only / "report"):
            assert main(["self_weight", "-o", str(out), *QUICK_CLI]) == 2
            error = capsys.readouterr().err.strip().splitlines()[-1]
            assert str(out) in error and "Read-only file system" in error
    assert ran == []


def test_a_study_that_raises_is_an_error_too(tmp_path, monkeypatch):
    """The block-refinement study raising (as it did under a fault that left cohesion out
    of the friction bound) is ERROR, with exit status 3, not an aborted suite."""
    import verify.suite
    from verify.cli import main

    def refinement(largest, progress=None):
        raise np.linalg.LinAlgError("Singular matrix")

    monkeypatch.setattr(verify.suite, "run_refinement", refinement)
    options = ["-o", str(tmp_path), "--no-images", "--no-convergence", "--refinement-max", "2"]
    assert main(["self_weight", *options]) == 3
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["errors"] == [
        {"name": "block refinement study", "message": "LinAlgError: Singular matrix"}
    ]
    assert [c["name"] for c in report["cases"]] == ["self_weight"]


def test_report_markdown_escapes_the_bar_of_contact_rows():
    """An audit: "base|lower" split its cell in report.md and shifted the row."""
    from verify.report import _markdown_table

    header, row = _markdown_table(["item", "error"], [["base|lower", "1e-3"]])[::2]
    assert row == "| base\\|lower | 1e-3 |" and header == "| item | error |"
