"""The block count of a rock mass is estimated before cutting; a huge one is refused."""

from __future__ import annotations

import time
import tomllib

import numpy as np
import pytest
import shapely
from tomli_w import dumps

import dda.cases
from dda.commands.cli import main
from dda.scene.rockmass.domain import build_domain
from dda.scene.rockmass.estimate import estimated_blocks
from dda.scene.rockmass.expand import cut_rock_mass
from dda.scene.rockmass.parse import parse_rock_mass


def shipped(name: str) -> dict:
    return tomllib.loads(dda.cases.folder().joinpath(f"{name}.toml").read_text())


def estimate_and_count(raw: dict) -> tuple[int, int]:
    mass = parse_rock_mass(raw, "<t>")
    estimate = estimated_blocks(mass, build_domain(mass, "<t>"))
    return estimate, len(cut_rock_mass(raw, "<t>")[0].names)


@pytest.mark.parametrize("name", ["rock_slope", "tunnel"])
def test_the_estimate_bounds_the_cut_of_the_shipped_cases_within_30_percent(name):
    estimate, count = estimate_and_count(shipped(name))  # 104 for 81, 319 for 265
    assert count <= estimate <= 1.3 * count


def test_the_estimate_of_two_fine_persistent_sets_is_within_5_percent():
    raw = shipped("rock_slope")
    raw["joint_sets"] = [
        {"dip": 35.0, "spacing": 1.0, "offset": 0.1},
        {"dip": 110.0, "spacing": 1.3, "offset": 0.1},
    ]
    raw.pop("cutting")
    estimate, count = estimate_and_count(raw)
    assert abs(estimate - count) <= 0.05 * count


def test_a_mistyped_spacing_is_refused_within_2_s_with_the_estimate(tmp_path, capsys):
    text = dda.cases.folder().joinpath("rock_slope.toml").read_text()
    scene = tmp_path / "typo.toml"
    scene.write_text(text.replace("spacing = 4.0", "spacing = 0.001"))  # 1 m meant
    cut = ["cut", str(scene), "-o", str(tmp_path / "b.toml")]
    for argv in (cut, ["run", str(scene), "-o", str(tmp_path / "o")]):
        start = time.perf_counter()
        assert main(argv) == 2
        assert time.perf_counter() - start < 2.0
        err = capsys.readouterr().err
        assert (
            "typo.toml: joint_sets[0].spacing: the joints (joint_sets[0].spacing = 0.001, " in err
        )
        assert "about 355,865 blocks, more than cutting.max_blocks = 20,000" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["typo.toml"]


def test_max_blocks_in_the_scene_and_on_the_command_line(tmp_path, capsys):
    raw = shipped("rock_slope")
    raw["cutting"]["max_blocks"] = 50  # the estimate is 104
    scene = tmp_path / "slope.toml"
    scene.write_text(dumps(raw))
    out = tmp_path / "blocks.toml"
    assert main(["cut", str(scene), "-o", str(out), "--no-png"]) == 2
    assert "about 104 blocks, more than cutting.max_blocks = 50" in capsys.readouterr().err
    assert main(["cut", str(scene), "-o", str(out), "--no-png", "--max-blocks", "200"]) == 0
    assert len(tomllib.loads(out.read_text())["blocks"]) == 81


def test_a_second_cut_replaces_the_files_only_with_overwrite(tmp_path, capsys):
    raw = shipped("rock_slope")
    scene = tmp_path / "slope.toml"
    scene.write_text(dumps(raw))
    out = tmp_path / "blocks.toml"
    assert main(["cut", str(scene), "-o", str(out), "-q"]) == 0
    out.write_text("# edited by hand\n")  # a cut scene is meant to be edited
    assert main(["cut", str(scene), "-o", str(out), "-q"]) == 2
    assert capsys.readouterr().err == f"dda cut: -o {out}: exists; give --overwrite to replace it\n"
    assert out.read_text() == "# edited by hand\n"
    assert main(["cut", str(scene), "-o", str(out), "-q", "--overwrite"]) == 0
    assert len(tomllib.loads(out.read_text())["blocks"]) == 81
    assert out.with_suffix(".png").stat().st_size > 0


def test_max_blocks_must_be_a_positive_integer(tmp_path, capsys):
    raw = shipped("rock_slope")
    raw["cutting"]["max_blocks"] = 0
    scene = tmp_path / "slope.toml"
    scene.write_text(dumps(raw))
    assert main(["run", str(scene), "-o", str(tmp_path / "o")]) == 2
    assert "cutting.max_blocks: must be a positive integer" in capsys.readouterr().err


def test_a_large_cut_says_so_before_it_starts(caplog, monkeypatch):
    import dda.scene.rockmass.expand as expand

    monkeypatch.setattr(expand, "LARGE_CUT", 100)  # 5,000 in use; the rock slope's 104
    with caplog.at_level("WARNING"):
        cut = cut_rock_mass(shipped("rock_slope"), "<t>")[0]
    assert "<t>: cutting about 104 blocks; this may take a minute" in caplog.text
    assert len(cut.names) == 81


def _blocks_by_position(raw: dict) -> np.ndarray:
    """(n, 5): centroid x, y, area, joint-tagged edges and the sum of their sources, of
    every cut block, sorted by position."""
    blocks = cut_rock_mass(raw, "<t>")[0].blocks
    shapes = [shapely.Polygon(blocks.polygon(i)) for i in range(len(blocks))]
    tags = np.split(blocks.edge_source, blocks.offsets[1:-1])
    rows = np.array(
        [
            [*s.centroid.coords[0], s.area, np.sum(e >= 0), np.sum(e)]
            for s, e in zip(shapes, tags, strict=True)
        ]
    )
    return rows[np.lexsort((rows[:, 1].round(6), rows[:, 0].round(6)))]


@pytest.mark.parametrize(
    "sets",
    [
        [{"dip": 35.0, "spacing": 0.5, "offset": 0.1}],  # one inclined set: the slow case
        [
            {"dip": 35.0, "spacing": 1.0, "offset": 0.1},
            {"dip": 110.0, "spacing": 1.3, "offset": 0.1},
        ],
    ],
)
def test_a_large_cut_noded_along_its_densest_set_gives_the_same_blocks(monkeypatch, sets):
    """The cut of many pieces (noded and tagged in the frame of the densest set) and the
    cut of few (GEOS's snap-rounding union) give the same blocks: count, centroids and
    areas within 1e-9 of the model size (squared for areas), and the same joint on every
    edge."""
    import dda.scene.rockmass.cutting as cutting
    import dda.scene.rockmass.edges as edges
    import dda.scene.rockmass.expand as expand

    raw = shipped("rock_slope")
    raw["joint_sets"] = sets
    raw.pop("cutting")
    for module in (cutting, edges, expand):
        monkeypatch.setattr(module, "LARGE", 10**9)
    union = _blocks_by_position(raw)
    for module in (cutting, edges, expand):
        monkeypatch.setattr(module, "LARGE", 0)
    along = _blocks_by_position(raw)
    size = 70.0  # the slope's section is 70 m wide
    assert len(along) == len(union) > 100
    np.testing.assert_allclose(along[:, :2], union[:, :2], rtol=0, atol=1e-9 * size)
    np.testing.assert_allclose(along[:, 2], union[:, 2], rtol=0, atol=1e-9 * size**2)
    np.testing.assert_array_equal(along[:, 3:], union[:, 3:])  # every edge's joint
