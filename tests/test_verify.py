"""Verification harness: meshing, FEM with contact, comparison with the DDA, images, CLI.

The quick cases run in the default test run; the others are marked slow.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely

import dda
from verify import fields
from verify.cases import discover, run_case
from verify.contact import default_penalty
from verify.convergence import convergence_study, observed_rates
from verify.expect import load_expectation
from verify.fem import FemOptions, solve_fem
from verify.geometry import insert_points_on_edges
from verify.interfaces import find_interfaces
from verify.mesh import mesh_blocks

RHO, G, E, NU = 2700.0, 9.81, 5.0e9, 0.25


def rectangle(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def rotate(points, degrees):
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    return [[c * x - s * y, s * x + c * y] for x, y in points]


def stack_scene(heights=(1.0, 1.0), friction=0.0, angle=0.0, plane="stress"):
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
            "contact": {"method": "penalty"},
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
    assert all(i.contacts == 2 and i.locked for i in interfaces)
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
    assert forces[0]["penetration"] == pytest.approx(
        weight / (2 * default_penalty(scene)), rel=1e-4
    )


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


# --- cases ---------------------------------------------------------------------


def test_every_case_is_a_valid_scene_with_reasoned_expectations():
    cases = discover()
    names = {c.name for c in cases}
    assert {"self_weight", "platens", "column", "side_by_side", "l_shape"} <= names
    for case in cases:
        scene = dda.load_scene(case.scene_path)
        assert scene.analysis.mode == "static"
        expectation = load_expectation(case.expect_path)
        assert expectation.summary and expectation.checks
        assert "stress" in expectation.checks or "closed_form" in expectation.checks
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
    assert result.dda.settled < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_slow_case_agrees_within_its_tolerances(name):
    result = run_case(discover(names=[name])[0])
    assert result.passed, [(v.quantity, v.error, v.tolerance) for v in result.verdicts]


# --- pictures, report, command line ----------------------------------------------


def non_background_fraction(image: np.ndarray) -> float:
    rgb = image[..., :3].astype(int)
    return float((np.abs(rgb - 255).sum(axis=-1) > 30).mean())


def test_case_image_shows_data_in_every_panel(quick_results, tmp_path):
    import matplotlib.image as mpimg

    from verify.images import case_image, summary_chart

    path = case_image(quick_results["self_weight"], tmp_path / "verify_self_weight.png")
    image = mpimg.imread(path)
    if image.dtype != np.uint8:
        image = (image * 255).astype(np.uint8)
    height, width = image.shape[:2]
    body = image[: int(height * 0.85)]  # above the colour bars
    halves = [body[:, : width // 2], body[:, width // 2 :]]
    thirds = [body[:, k * width // 3 : (k + 1) * width // 3] for k in range(3)]
    for part in halves + thirds:
        assert non_background_fraction(part) > 0.05
    # the DDA and FEM panels are coloured, not grey
    for part in thirds[:2]:
        rgb = part[..., :3].astype(int)
        assert (rgb.max(axis=-1) - rgb.min(axis=-1) > 40).mean() > 0.02
    chart = summary_chart(list(quick_results.values()), tmp_path / "summary.png")
    assert non_background_fraction(mpimg.imread(chart)) > 0.02


def test_cli_writes_report_and_fails_on_unknown_case(tmp_path, capsys):
    from verify.cli import main

    code = main(["self_weight", "column", "-o", str(tmp_path), "--no-images", "--no-convergence"])
    assert code == 0
    out = capsys.readouterr().out
    assert "self_weight" in out and "PASS" in out
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["passed"] and [c["name"] for c in report["cases"]] == ["self_weight", "column"]
    assert "| self_weight | stress |" in (tmp_path / "report.md").read_text()
    assert main(["no_such_case", "-o", str(tmp_path), "--no-images"]) == 2


def test_cli_returns_nonzero_when_a_tolerance_fails(tmp_path):
    from verify.cli import main

    source = discover(names=["self_weight"])[0]
    (tmp_path / "strict.toml").write_text(source.scene_path.read_text())
    text = source.expect_path.read_text().replace("tolerance = 0.17", "tolerance = 0.01")
    (tmp_path / "strict.expect.toml").write_text(text)
    code = main(
        [
            "--cases-dir",
            str(tmp_path),
            "-o",
            str(tmp_path / "out"),
            "--no-images",
            "--no-convergence",
        ]
    )
    assert code == 1


def test_dda_command_has_verify():
    from dda.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["verify", "--quick", "-o", "x"])
    assert args.func.__name__ == "run_verify" and args.quick


@pytest.mark.slow
def test_full_suite_with_images(tmp_path):
    from verify.suite import run_suite

    output = run_suite(outdir=tmp_path)
    assert output.passed
    assert (tmp_path / "images" / "verify_summary.png").is_file()
    assert "Observed P1 rates" in (tmp_path / "report.md").read_text()
