"""Drawings in: a scene's ``[drawing]`` (or ``dda cut drawing.dxf``) reads a DXF file's layers
as blocks, fixed blocks, joint traces and an excavation (docs/rock_masses.md, "Drawings").

The shipped example (cases/drawing_example.dxf) is what tests/drawings.py builds with ezdxf;
a drawing round-trips to the very blocks of the same geometry typed as a rock mass; bad
drawings are refused in one line, exit 2, nothing written."""

from __future__ import annotations

import logging
import math
import os
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import shapely

import dda
from dda.commands import cli
from dda.scene.rockmass import cut_rock_mass
from tests import drawings

CASES = Path(__file__).resolve().parents[3] / "cases"
EXAMPLE = CASES / "drawing_example.toml"


def example_raw() -> dict:
    return tomllib.loads(EXAMPLE.read_text())


def blocks_of(raw: dict, source: str) -> list[np.ndarray]:
    cut, _ = cut_rock_mass(raw, source)
    return [cut.blocks.polygon(i) for i in range(len(cut.names))]


def test_the_shipped_drawing_is_the_one_the_builder_makes(tmp_path):
    """cases/drawing_example.dxf, rebuilt by tests/drawings.py, cuts into the same blocks
    (the file itself carries creation times, so it is compared by what it gives)."""
    rebuilt = drawings.example_drawing(tmp_path / "drawing_example.dxf")
    raw = example_raw()
    shipped = blocks_of(raw, str(EXAMPLE))
    raw["drawing"]["file"] = str(rebuilt)
    again = blocks_of(raw, str(EXAMPLE))
    assert len(shipped) == len(again) == 20
    for a, b in zip(shipped, again, strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_drawing_round_trips_to_the_blocks_of_the_same_geometry_typed(tmp_path):
    """The example without its curve (a polygon in place of the tunnel's circle): the
    drawing gives, vertex for vertex, the blocks, fixed blocks, group and stage of the
    same polygons and lines typed as [[regions]], [[joint_lines]], [[fix]] and [groups]."""
    import ezdxf

    tunnel = [(29.0, 6.0), (33.0, 6.0), (33.0, 10.0), (29.0, 10.0)]
    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = 6
    space = document.modelspace()
    space.add_lwpolyline(drawings.SLOPE, close=True, dxfattribs={"layer": "BLOCKS"})
    space.add_lwpolyline(drawings.BASE, close=True, dxfattribs={"layer": "FIXED"})
    for start, end in drawings.BEDDING + drawings.CROSS:
        space.add_line(start, end, dxfattribs={"layer": "JOINTS"})
    space.add_lwpolyline(drawings.KINKED, dxfattribs={"layer": "JOINTS"})
    space.add_lwpolyline(tunnel, close=True, dxfattribs={"layer": "EXCAVATION"})
    document.saveas(tmp_path / "section.dxf")
    drawn = example_raw()
    drawn["drawing"]["file"] = str(tmp_path / "section.dxf")
    cut, scene = cut_rock_mass(drawn, str(EXAMPLE))

    typed = {k: v for k, v in example_raw().items() if k != "drawing"}
    rock = shapely.Polygon(drawings.SLOPE)
    hole = shapely.Polygon(tunnel)
    outside = rock.difference(hole)
    typed["regions"] = [
        {"polygon": _ring(outside.exterior), "holes": [_ring(r) for r in outside.interiors]},
        {"polygon": [list(p) for p in tunnel]},
        {"polygon": [list(p) for p in drawings.BASE]},
    ]
    lines = [[list(a), list(b)] for a, b in drawings.BEDDING + drawings.CROSS]
    lines.append([list(p) for p in drawings.KINKED])
    typed["joint_lines"] = [{"points": p, "joint": "bedding", "name": "JOINTS"} for p in lines]
    typed["fix"] = [*typed["fix"], {"inside": [list(p) for p in drawings.BASE]}]
    typed["groups"] = {"excavation": {"inside": [list(p) for p in tunnel]}}
    typed["stages"] = [{"time": 0.05, "remove": ["excavation"]}]
    cut_typed, scene_typed = cut_rock_mass(typed, "typed")

    assert len(cut.names) == len(cut_typed.names) > 10
    for i in range(len(cut.names)):
        np.testing.assert_array_equal(cut.blocks.polygon(i), cut_typed.blocks.polygon(i))
    np.testing.assert_array_equal(cut.fixed, cut_typed.fixed)
    assert scene["groups"] == scene_typed["groups"] and scene["stages"] == scene_typed["stages"]
    assert len(scene["groups"]["excavation"]) == 3  # the tunnel cut by a bedding and a cross joint


def _ring(ring) -> list[list[float]]:
    return np.asarray(ring.coords)[:-1].tolist()


def test_the_example_reads_its_layers(tmp_path):
    """Blocks from BLOCKS and FIXED (the base and the sides fixed), the joints of JOINTS
    with the bedding's friction on their edges, the tunnel's circle as chords within the
    arc tolerance, its blocks removed by the stage at 0.05 s."""
    scene = dda.load_scene(EXAMPLE)
    assert len(scene.blocks) == 20 and sum(b.fixed for b in scene.blocks) == 7
    tunnel = [b for b in scene.blocks if b.name in scene.groups["excavation"]]
    area = sum(shapely.Polygon(b.vertices).area for b in tunnel)
    sagitta = 1e-3 * math.hypot(40.0, 24.0)  # ARC_TOLERANCE of the drawing's size
    assert math.pi * 2.5**2 - 2 * math.pi * 2.5 * sagitta < area < math.pi * 2.5**2
    assert scene.stages[0].time == 0.05 and set(scene.stages[0].remove) == {b.name for b in tunnel}
    bedding = [j for b in scene.blocks for j in b.edge_joints if j == "bedding"]
    assert len(bedding) > 20


def test_dda_cut_reads_a_drawing_with_the_scene_of_its_name(tmp_path, monkeypatch, capsys):
    """``dda cut drawing.dxf -o blocks.toml``: the materials and joints from drawing.toml
    beside it (or --scene); the explicit scene runs, the picture shows the tunnel hatched."""
    monkeypatch.chdir(tmp_path)
    drawings.example_drawing(tmp_path / "section.dxf")
    assert cli.main(["cut", "section.dxf", "-o", "blocks.toml"]) == 2
    assert "give --scene FILE.toml" in capsys.readouterr().err
    assert not (tmp_path / "blocks.toml").exists()
    raw = EXAMPLE.read_text().replace('file = "drawing_example.dxf"', 'file = "elsewhere.dxf"')
    (tmp_path / "section.toml").write_text(raw)
    assert cli.main(["cut", "section.dxf", "-o", "blocks.toml"]) == 0
    assert capsys.readouterr().out.strip() == "blocks.toml: 20 blocks, 7 fixed"
    assert Path("blocks.png").stat().st_size > 0
    explicit = dda.load_scene("blocks.toml")
    assert len(explicit.blocks) == 20 and explicit.stages[0].remove
    assert cli.main(["cut", "section.dxf", "--scene", str(EXAMPLE), "-o", "b2.toml"]) == 0


# ------------------------------------------------------------------------ refused


def _scene_for(tmp_path: Path, dxf: Path, **drawing) -> Path:
    raw = EXAMPLE.read_text().replace('file = "drawing_example.dxf"', f'file = "{dxf.name}"')
    extra = "".join(f"{k} = {_toml(v)}\n" for k, v in drawing.items())
    path = tmp_path / "scene.toml"
    path.write_text(raw.replace("[drawing]\n", "[drawing]\n" + extra))
    return path


def _toml(value) -> str:
    """A value of a [drawing] key as TOML: a string, a number, or an inline table."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return repr(value).replace("'", '"')


SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]


def _lines_with_a_gap(path: Path, gap: float) -> None:
    """The square on BLOCKS as four LINEs (an exploded polyline), the last ending ``gap``
    short of the first's start (an audit: the error named the intact first line)."""
    import ezdxf

    document = ezdxf.new("R2010")
    corners = [*SQUARE, (0.0, gap)]
    for start, end in zip(corners[:-1], corners[1:], strict=True):
        document.modelspace().add_line(start, end, dxfattribs={"layer": "BLOCKS"})
    document.saveas(path)


def _overlapping(path: Path) -> None:
    """Two squares on BLOCKS that overlap (the cut refuses the regions they become)."""
    drawings.drawing_with(path, "BLOCKS", SQUARE, closed=True)
    import ezdxf

    document = ezdxf.readfile(path)
    moved = [(x + 5.0, y + 5.0) for x, y in SQUARE]
    document.modelspace().add_lwpolyline(moved, close=True, dxfattribs={"layer": "BLOCKS"})
    hole = [(x / 5.0 + 1.0, y / 5.0 + 1.0) for x, y in SQUARE]  # the scene's excavation
    document.modelspace().add_lwpolyline(hole, close=True, dxfattribs={"layer": "EXCAVATION"})
    document.saveas(path)


def _excavation_outside(path: Path) -> None:
    """A square on BLOCKS and a circle on EXCAVATION beside it: it removes nothing."""
    drawings.drawing_with(path, "BLOCKS", SQUARE, closed=True)
    import ezdxf

    document = ezdxf.readfile(path)
    document.modelspace().add_circle((30.0, 5.0), 3.0, dxfattribs={"layer": "EXCAVATION"})
    document.saveas(path)


@pytest.mark.parametrize(
    ("make", "drawing", "message"),
    [
        (lambda p: drawings.drawing_with(p, "BLOCKS", SQUARE, closed=False), {},
         "scene.toml: drawing.file: {dxf}: layer BLOCKS: LWPOLYLINE (handle 30) is open: its "
         "ends (0, 0) and (0, 10) are 10 apart: a block or an excavation is a closed "
         "polyline"),
        (lambda p: _lines_with_a_gap(p, 0.001), {},
         "scene.toml: drawing.file: {dxf}: layer BLOCKS: LINE (handle 2F) has a loose end at "
         "(0, 0), which no other shape of the layer meets; the nearest loose end is LINE "
         "(handle 32)'s at (0, 0.001), 0.001 away: join them: a block or an excavation is a "
         "closed polyline"),
        (lambda p: drawings.drawing_with(p, "ROCK", SQUARE, closed=True), {},
         "scene.toml: drawing.blocks: no layer 'BLOCKS' in the drawing {dxf} (its layers: 0, "
         "Defpoints, ROCK)"),
        (lambda p: drawings.drawing_with(p, "BLOCKS", SQUARE, closed=True), {"joints": "FAULTS"},
         "scene.toml: drawing.joints: no layer 'FAULTS' in the drawing {dxf}"),
        (lambda p: drawings.drawing_with(p, "BLOCKS", SQUARE, closed=True, units=4), {},
         "scene.toml: drawing.file: {dxf}: $INSUNITS: the drawing is in mm ($INSUNITS = 4) "
         "and the scene in m ([units] length): give [drawing] scale = 0.001 to read it in m"),
        (lambda p: p.write_text("not a drawing"), {},
         "scene.toml: drawing.file: {dxf}: not a DXF drawing ezdxf can read"),
        (lambda p: p.write_text("0\nSECTION\n2\nHEADER\n"), {},
         "scene.toml: drawing.file: {dxf}: not a DXF drawing ezdxf can read (it ends early)"),
        (lambda p: p.write_text("0\nSECTION\n2\nENTITIES\n0\nEOF\n"), {},
         "scene.toml: drawing.file: {dxf}: not a DXF drawing ezdxf can read (DXFStructureError: "
         "missing ENDSEC tag.)"),
        (lambda p: drawings.drawing_with(p, "BLOCKS", [], closed=False), {},
         "scene.toml: drawing.file: {dxf}: layer BLOCKS: holds no shape"),
        (_overlapping, {},
         "scene.toml: drawing.file: {dxf}: layer BLOCKS: LWPOLYLINE (handle 34) crosses "
         "LWPOLYLINE (handle 30) by 25 of area near (7.5, 7.5): closed shapes on the blocks "
         "layer do not cross"),
        (lambda p: None, {}, "scene.toml: drawing.file: no such file "),
        # refused as "groups.excavation: selects no block", naming neither file nor entity
        (_excavation_outside, {}, "scene.toml: drawing.file: {dxf}: layer EXCAVATION: CIRCLE "
         "(handle 34) lies outside the rock or in one of its openings: it removes nothing"),
        # a closed polyline of one segment was "open (from (30, 0) to (30, 0))"
        (lambda p: drawings.drawing_with(p, "BLOCKS", [(30.0, 0.0), (40.0, 0.0)], closed=True),
         {}, "scene.toml: drawing.file: {dxf}: layer BLOCKS: LWPOLYLINE (handle 30) has no "
         "area"),
    ],
    ids=["open polyline", "lines with a gap", "no blocks layer", "a named layer missing",
         "units", "not DXF", "cut short", "broken DXF", "no shape", "overlap", "no file",
         "an excavation outside", "a closed segment"],
)  # fmt: skip
def test_a_bad_drawing_is_refused_in_one_line(tmp_path, monkeypatch, capsys, make, drawing,
                                              message):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    make(tmp_path / "bad.dxf")
    scene = _scene_for(tmp_path, tmp_path / "bad.dxf", **drawing)
    before = sorted(os.listdir(tmp_path))
    message = message.format(dxf=tmp_path / "bad.dxf")
    for argv in (["cut", str(scene), "-o", "out.toml"], ["run", str(scene), "-o", "out"]):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0] and "Traceback" not in err[0], err
        assert "bad.dxf" in err[0]
    assert sorted(os.listdir(tmp_path)) == before  # nothing written


def test_a_scale_reads_a_drawing_in_other_units(tmp_path):
    """The example drawn in millimetres: refused as it is, read with scale = 0.001."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = 4
    space = document.modelspace()
    square = [(1000.0 * x, 1000.0 * y) for x, y in SQUARE]
    space.add_lwpolyline(square, close=True, dxfattribs={"layer": "BLOCKS"})
    space.add_line((-1000.0, 5000.0), (11000.0, 5000.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(tmp_path / "mm.dxf")
    scene = _scene_for(tmp_path, tmp_path / "mm.dxf", scale=0.001)
    text = (
        scene.read_text()
        .replace("excavation_time = 0.05", "")
        .replace('"left", "right"', '"bottom"')
    )
    scene.write_text(text)
    loaded = dda.load_scene(scene)
    assert sorted(shapely.Polygon(b.vertices).area for b in loaded.blocks) == [50.0, 50.0]


def test_a_joint_beside_a_joints_table_is_refused(tmp_path, monkeypatch, capsys):
    """[drawing] joint names the joint of a single joints layer; beside a table of layers
    it was ignored without a word (the traces took the table's joints)."""
    monkeypatch.chdir(tmp_path)
    drawings.drawing_with(tmp_path / "bad.dxf", "BLOCKS", SQUARE, closed=True)
    scene = _scene_for(tmp_path, tmp_path / "bad.dxf", joints={"JOINTS": "bedding"})
    assert 'joint = "bedding"' in scene.read_text()  # the example's own
    assert cli.main(["cut", str(scene), "-o", "out.toml"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "scene.toml: drawing.joint: the joints table names each" in err[0]
    assert not (tmp_path / "out.toml").exists()


def test_an_empty_joints_table_is_refused_as_such(tmp_path, monkeypatch, capsys):
    """joints = {} was refused by what followed from it (every free block removed)."""
    monkeypatch.chdir(tmp_path)
    drawings.drawing_with(tmp_path / "bad.dxf", "BLOCKS", SQUARE, closed=True)
    scene = _scene_for(tmp_path, tmp_path / "bad.dxf", joints={})
    assert cli.main(["cut", str(scene), "-o", "out.toml"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "scene.toml: drawing.joints: is an empty table" in err[0]


def _cad_drawing(path: Path, layers=("Blocks", "joints", "Excavation"), units: int = 6) -> Path:
    """A 10 m square cut by one joint, with a hole to excavate, on layers named as a CAD
    user may name them; a stray zero-length LINE on the joints layer."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = units
    space = document.modelspace()
    blocks, joints, excavation = layers
    space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": blocks})
    space.add_line((-1.0, 5.0), (11.0, 5.0), dxfattribs={"layer": joints})
    space.add_line((3.0, 3.0), (3.0, 3.0), dxfattribs={"layer": joints})  # a CAD leftover
    hole = [(6.0, 6.0), (8.0, 6.0), (8.0, 8.0), (6.0, 8.0)]
    space.add_lwpolyline(hole, close=True, dxfattribs={"layer": excavation})
    document.saveas(path)
    return path


def _cad_scene(
    tmp_path: Path,
    drawing: str,
    units: str = "m",
    fix: str = "inside = [[-1, -1], [11, -1], [11, 5.5], [-1, 5.5]]",
) -> Path:
    path = tmp_path / "cad.toml"
    path.write_text(
        f'[units]\nlength = "{units}"\n'
        '[analysis]\nmode = "dynamic"\ntime_step = 0.001\nduration = 0.1\n'
        "[materials.rock]\ndensity = 2600.0\nyoung = 1e9\npoisson = 0.25\n"
        "[joints.default]\nfriction_angle = 30.0\n[joints.bedding]\nfriction_angle = 25.0\n"
        f"[[fix]]\n{fix}\n"
        f'[drawing]\nfile = "cad.dxf"\n{drawing}'
    )
    return path


def test_layers_units_and_names_are_read_as_cad_gives_them(tmp_path, caplog):
    """Layer names in any case (CAD matches them so; layers Blocks, joints and Excavation
    were the default BLOCKS, JOINTS and EXCAVATION only in capitals, and were left out
    without a word), a length unit spelt "metre", a zero-length joint line left out with a
    warning."""
    _cad_drawing(tmp_path / "cad.dxf")
    scene = dda.load_scene(_cad_scene(tmp_path, 'joint = "bedding"\nexcavation_time = 0.05\n'))
    areas = sorted(shapely.Polygon(b.vertices).area for b in scene.blocks)
    # cut by the joint; the hole a block of its own, the rock around it split in two (a
    # block has no holes: [cutting] holes = "split")
    assert areas == pytest.approx([4.0, 13.0, 33.0, 50.0])
    (stage,) = scene.stages  # the excavation: the hole's block
    removed = [b for b in scene.blocks if b.name in stage.remove]
    assert [shapely.Polygon(b.vertices).area for b in removed] == pytest.approx([4.0])
    assert "has no length: left out" in caplog.text
    _cad_drawing(tmp_path / "cad.dxf", units=4)  # drawn in mm
    for spelt in ("metre", "meters", "M"):
        with pytest.raises(dda.SceneError, match=r"give \[drawing\] scale = 0.001"):
            dda.load_scene(
                _cad_scene(tmp_path, 'joint = "bedding"\nexcavation_time = 0.05\n', spelt)
            )
    with pytest.raises(dda.SceneError, match="length unit 'furlong' .* is none this check knows"):
        dda.load_scene(_cad_scene(tmp_path, "excavation_time = 0.05\n", "furlong"))


@pytest.mark.parametrize(
    ("drawing", "key", "words"),
    [
        ('joint = "beding"\nexcavation_time = 0.05\n', "drawing.joint",
         "unknown joint 'beding': did you mean 'bedding'?"),
        ('material = "rok"\nexcavation_time = 0.05\n', "drawing.material",
         "unknown material 'rok': did you mean 'rock'?"),
        ('excavation_time = 0.05\nexcavation = "HOLES"\n', "drawing.excavation",
         "no layer 'HOLES' in the drawing"),
    ],
)  # fmt: skip
def test_a_drawing_s_own_keys_are_named_in_its_refusals(tmp_path, drawing, key, words):
    _cad_drawing(tmp_path / "cad.dxf")
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(_cad_scene(tmp_path, drawing))
    assert caught.value.key == key and words in str(caught.value), str(caught.value)


def test_an_excavation_time_with_nothing_to_excavate_is_refused(tmp_path):
    _cad_drawing(tmp_path / "cad.dxf", layers=("BLOCKS", "JOINTS", "OTHER"))
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(_cad_scene(tmp_path, "excavation_time = 0.05\n"))
    assert caught.value.key == "drawing.excavation_time"
    assert "no closed shape on layer 'EXCAVATION' to excavate" in str(caught.value)


def test_a_joint_snapped_to_a_curved_boundary_cuts(tmp_path, caplog):
    """The top of a slab drawn as an arc sagging 3 m (a bulge), a joint from the base to a
    point on the true arc (CAD's 'nearest' snap): the rock's chords leave the arc by up
    to the arc tolerance, on this concave side inside the rock, where the joint ended and
    cut nothing (1 block); drawn on by two arc tolerances it cuts (2 blocks). A joint that
    stops 0.5 m short of the top (by design: more than the 0.08 m arc tolerance) stays
    short and cuts nothing."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    outline = [(0, 0, 0), (70, 0, 0), (70, 40, 0), (40, 40, 0), (20, 10, -0.3), (0, 10, 0)]
    space.add_lwpolyline(outline, format="xyb", close=True, dxfattribs={"layer": "BLOCKS"})
    chord, sagitta = 20.0, 3.0
    radius = (chord * chord / 4.0 + sagitta * sagitta) / (2.0 * sagitta)
    y = 7.0 + radius - math.sqrt(radius * radius - (4.0 - 10.0) ** 2)  # the arc at x = 4
    space.add_line((4.0, 0.0), (4.0, y), dxfattribs={"layer": "JOINTS"})
    space.add_line((60.0, 0.0), (60.0, 39.5), dxfattribs={"layer": "JOINTS"})  # stops short
    document.saveas(tmp_path / "cad.dxf")
    with caplog.at_level(logging.WARNING):
        scene = dda.load_scene(_cad_scene(tmp_path, 'joint = "bedding"\n', fix='sides = ["right"]'))
    assert len(scene.blocks) == 2
    # the short one is said (it cut nothing without a word), the one that cuts is not
    (said,) = [r.getMessage() for r in caplog.records if "cuts nothing" in r.getMessage()]
    assert "joint_lines[1] ('JOINTS', from (60, -0.161" in said  # drawn on to the base
    assert "to (60, 39.5)) cuts nothing: it ends inside the rock" in said
    assert scene.load_warnings == (said,)  # an audit: the run's summary did not say it
    summary = dda.simulate(scene, stop=lambda: True).summary
    assert said in summary["warnings"]


def test_an_exploded_outline_is_read_as_the_shape_it_closes(tmp_path):
    """The slab's outline as CAD explodes a polyline: separate LINEs and an ARC end to
    end (one LINE's end 1e-10 m off), on the blocks layer; read as the closed shape they
    make (it was refused as an open LINE), named by its pieces."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    blocks = {"layer": "BLOCKS"}
    space.add_line((0.0, 0.0), (10.0, 0.0), dxfattribs=blocks)
    space.add_line((10.0, 0.0), (10.0, 10.0 + 1e-10), dxfattribs=blocks)
    space.add_arc((5.0, 10.0), 5.0, 0.0, 180.0, dxfattribs=blocks)  # the top: a half circle
    space.add_line((0.0, 10.0), (0.0, 0.0), dxfattribs=blocks)
    space.add_line((-1.0, 5.0), (11.0, 5.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(tmp_path / "cad.dxf")
    scene = dda.load_scene(_cad_scene(tmp_path, 'joint = "bedding"\n', fix='sides = ["bottom"]'))
    areas = sorted(shapely.Polygon(b.vertices).area for b in scene.blocks)
    assert len(areas) == 2 and areas[0] == pytest.approx(50.0)
    # chords inscribed in the arc within the tolerance t (1e-3 of the 18 m extent): the
    # area they cut off is at most 2/3 t of the arc's length, and none is added
    true, tolerance = 100.0 + math.pi * 25.0 / 2.0, 1e-3 * math.hypot(10.0, 15.0)
    assert true - 2.0 / 3.0 * tolerance * math.pi * 5.0 <= sum(areas) <= true


def _circle_drawing(path: Path, curve: str, radius: float = 10.0) -> None:
    """A disc of ``radius`` on BLOCKS drawn as a CIRCLE, a polyline of two bulges, or a
    rational SPLINE (a NURBS circle), and a joint across its diameter on JOINTS."""
    import ezdxf
    from ezdxf.math import rational_bspline_from_arc

    document = ezdxf.new("R2010")
    space = document.modelspace()
    blocks = {"layer": "BLOCKS"}
    if curve == "circle":
        space.add_circle((0.0, 0.0), radius, dxfattribs=blocks)
    elif curve == "bulges":
        ring = [(-radius, 0.0, 1.0), (radius, 0.0, 1.0)]  # two half circles
        space.add_lwpolyline(ring, format="xyb", close=True, dxfattribs=blocks)
    else:
        nurbs = rational_bspline_from_arc((0.0, 0.0), radius, 0.0, 360.0)
        space.add_spline(dxfattribs=blocks).apply_construction_tool(nurbs)
    space.add_line((-radius, 0.0), (radius, 0.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(path)


LOWER_HALF = "inside = [[-11, -11], [11, -11], [11, 0.001], [-11, 0.001]]"


@pytest.mark.parametrize("curve", ["circle", "bulges", "spline"])
@pytest.mark.parametrize("tolerance", [1e-2, 1e-3, 1e-4])
def test_curves_are_drawn_within_the_arc_tolerance(tmp_path, curve, tolerance):
    """Every vertex within a tenth of ``arc_tolerance`` of the circle of R = 10 m, every
    chord within the tolerance: the points were ezdxf's cubic Béziers', up to
    2.7e-3 m off the circle whatever the tolerance (a rational spline 4.1e-3 m, 256 points
    at any tolerance), and a joint snapped to the circle at 1e-3 m cut nothing. The disc is
    cut in two by its diameter at every tolerance."""
    _circle_drawing(tmp_path / "cad.dxf", curve)
    scene = dda.load_scene(_cad_scene(tmp_path, f"arc_tolerance = {tolerance}\n", fix=LOWER_HALF))
    assert len(scene.blocks) == 2
    vertices = np.concatenate([np.asarray(b.vertices) for b in scene.blocks])
    radius = np.hypot(*vertices.T)
    rim = radius > 5.0  # all but the diameter's middle
    assert np.all(np.abs(radius[rim] - 10.0) <= 0.1 * tolerance)
    for block in scene.blocks:  # the chords on the rim: within t of the circle
        points = np.asarray(block.vertices)
        ends = np.roll(points, -1, axis=0)
        chord = np.hypot(*(ends - points).T) < 5.0  # not the diameter
        middles = 0.5 * (points + ends)[chord]
        assert np.all(10.0 - np.hypot(*middles.T) <= tolerance)
    area = sum(shapely.Polygon(b.vertices).area for b in scene.blocks)
    assert math.pi * 100.0 - 2.0 / 3.0 * tolerance * 2.0 * math.pi * 10.0 <= area
    assert area <= math.pi * 100.0 + 1e-9


@pytest.mark.parametrize(
    ("code", "words"),
    [(21, "in US survey feet ($INSUNITS = 21): give [drawing] scale, the scene's length unit "
          "in one drawing unit ([drawing] scale = 0.3048006096012192 reads it in m)"),
     (13, "in microns ($INSUNITS = 13)"),
     (99, "in no unit the DXF reference defines ($INSUNITS = 99)")],
)  # fmt: skip
def test_a_drawing_in_units_the_reader_does_not_convert_is_refused(tmp_path, code, words):
    """$INSUNITS codes outside the reader's table were read as unitless (a drawing in US
    survey feet as metres) without a word."""
    drawings.drawing_with(tmp_path / "cad.dxf", "BLOCKS", SQUARE, closed=True, units=code)
    with pytest.raises(dda.SceneError, match=re.escape(words)):
        dda.load_scene(_cad_scene(tmp_path, ""))


def _inserted_joint(path: Path) -> None:
    """A square on BLOCKS and, in a block reference on layer 0 (nested once), a joint on
    JOINTS across it."""
    import ezdxf

    document = ezdxf.new("R2010")
    document.modelspace().add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "BLOCKS"})
    inner = document.blocks.new("INNER")
    inner.add_line((-1.0, 5.0), (11.0, 5.0), dxfattribs={"layer": "JOINTS"})
    outer = document.blocks.new("OUTER")
    outer.add_blockref("INNER", (0.0, 0.0), dxfattribs={"layer": "0"})
    document.modelspace().add_blockref("OUTER", (0.0, 0.0), dxfattribs={"layer": "0"})
    document.saveas(path)


def _bad_entity(path: Path, kind: str) -> None:
    """A square on BLOCKS beside an entity that is no shape: a circle of radius 0 on
    BLOCKS, a spline without points or a polyface mesh on JOINTS."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "BLOCKS"})
    if kind == "point circle":
        space.add_circle((5.0, 5.0), 0.0, dxfattribs={"layer": "BLOCKS"})
    elif kind == "empty spline":
        space.add_spline(dxfattribs={"layer": "JOINTS"})
    else:
        mesh = space.add_polyface(dxfattribs={"layer": "JOINTS"})
        mesh.append_face([(0, 0, 0), (1, 0, 0), (1, 1, 0)])
    document.saveas(path)


@pytest.mark.parametrize(
    ("make", "words"),
    [(_inserted_joint, "layer JOINTS: INSERT (handle 3"),
     (lambda p: _bad_entity(p, "point circle"), "layer BLOCKS: CIRCLE (handle 30) has no area"),
     (lambda p: _bad_entity(p, "empty spline"),
      "layer JOINTS: SPLINE (handle 30) cannot be read as a shape"),
     (lambda p: _bad_entity(p, "polyface"),
      "layer JOINTS: POLYLINE (handle 30) cannot be read as a shape")],
    ids=["joint in a block reference", "circle of radius 0", "empty spline", "polyface"],
)  # fmt: skip
def test_entities_the_reader_cannot_take_are_refused_by_handle(
    tmp_path, monkeypatch, capsys, make, words
):
    """A joint inside a block reference on layer 0 was left out without a word (the rock
    uncut); a circle of radius 0, a spline without points and a polyface mesh stopped the
    reader with exit 1 and a Python error that named no entity."""
    monkeypatch.chdir(tmp_path)
    make(tmp_path / "bad.dxf")
    scene = _scene_for(tmp_path, tmp_path / "bad.dxf")
    before = sorted(os.listdir(tmp_path))
    assert cli.main(["cut", str(scene), "-o", "out.toml"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert sorted(os.listdir(tmp_path)) == before


def test_a_shape_inside_another_on_the_blocks_layer_is_an_opening(tmp_path):
    """A 20 × 10 rectangle with a circle of R = 2 inside it on BLOCKS (a tunnel open at
    t = 0, as CAD's hatch islands draw it), and a 1 × 1 square inside the circle (an
    island: rock again). The circle was refused as overlapping the rectangle, and a
    drawing had no way to give an opening open at t = 0."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    blocks = {"layer": "BLOCKS"}
    outer = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (0.0, 10.0)]
    space.add_lwpolyline(outer, close=True, dxfattribs=blocks)
    space.add_circle((10.0, 5.0), 2.0, dxfattribs=blocks)
    island = [(9.5, 4.5), (10.5, 4.5), (10.5, 5.5), (9.5, 5.5)]
    space.add_lwpolyline(island, close=True, dxfattribs=blocks)
    document.saveas(tmp_path / "cad.dxf")
    scene = dda.load_scene(_cad_scene(tmp_path, "arc_tolerance = 1e-4\n", fix='sides = ["bottom"]'))
    polygons = [shapely.Polygon(b.vertices) for b in scene.blocks]
    rock = shapely.union_all(polygons)
    circle = shapely.Point(10.0, 5.0).buffer(2.0, 256)
    assert rock.area == pytest.approx(200.0 - circle.area + 1.0, abs=0.01)
    assert not rock.contains(shapely.Point(10.0, 6.5))  # inside the opening
    assert rock.contains(shapely.Point(10.0, 5.0))  # the island
    assert rock.contains(shapely.Point(2.0, 2.0))


def _nested_squares(path: Path, *squares, joint: bool = False) -> None:
    """A drawing of closed squares (x0, y0, x1, y1) on BLOCKS; ``joint``: a joint line
    across them at y = 6 (two blocks, the lower one fixed by the scene's bottom side)."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    for x0, y0, x1, y1 in squares:
        corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        space.add_lwpolyline(corners, close=True, dxfattribs={"layer": "BLOCKS"})
    if joint:
        space.add_line((-1.0, 6.0), (21.0, 6.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(path)


@pytest.mark.parametrize(
    ("squares", "area", "inside"),
    [  # an island standing on its opening's floor: it vanished without a word (140 m²)
        (((0, 0, 20, 10), (5, 2, 15, 8), (8, 2, 12, 4)), 200 - 60 + 8, (10, 3)),
        # a notch opening in the outline's floor: refused as overlapping the outline
        (((0, 0, 20, 10), (8, 0, 12, 3)), 200 - 12, (2, 2)),
    ],
)
def test_a_shape_that_touches_the_one_around_it_is_nested_in_it(tmp_path, squares, area, inside):
    _nested_squares(tmp_path / "cad.dxf", *squares, joint=True)
    scene = dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))
    rock = shapely.union_all([shapely.Polygon(b.vertices) for b in scene.blocks])
    assert rock.area == pytest.approx(area, rel=1e-12)
    assert rock.contains(shapely.Point(*inside))


def test_a_joint_line_drawn_twice_is_said_so_not_said_to_cut_nothing(tmp_path, caplog):
    """The copy was said to cut nothing ("it ends inside the rock"): the block edges name
    the other, and the joint is in the model."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "BLOCKS"})
    for _ in range(2):
        space.add_line((-1.0, 3.0), (11.0, 5.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(tmp_path / "cad.dxf")
    with caplog.at_level(logging.WARNING):
        scene = dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))
    assert len(scene.blocks) == 2
    assert "cuts nothing" not in caplog.text
    assert "lies along joint_lines[" in caplog.text and "drawn twice" in caplog.text


def _exploded_outline(path: Path, extra: list) -> None:
    """The 20 × 10 outline as four LINEs, the ``extra`` LINEs ((x0, y0), (x1, y1)), and a
    joint across it at y = 6 (two blocks, the lower one fixed by the bottom side)."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    corners = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (0.0, 10.0)]
    for a, b in [*zip(corners, corners[1:] + corners[:1], strict=True), *extra]:
        space.add_line(a, b, dxfattribs={"layer": "BLOCKS"})
    space.add_line((-1.0, 6.0), (21.0, 6.0), dxfattribs={"layer": "JOINTS"})
    document.saveas(path)


def test_a_line_drawn_twice_in_an_exploded_outline_is_read_once(tmp_path):
    """The bottom LINE drawn again (a CAD leftover) was refused as "LINE (handle 30) is
    open ... and closes no ring", naming the line that closes it."""
    _exploded_outline(tmp_path / "cad.dxf", [((20.0, 0.0), (0.0, 0.0))])
    scene = dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))
    rock = shapely.union_all([shapely.Polygon(b.vertices) for b in scene.blocks])
    assert rock.area == pytest.approx(200.0, rel=1e-12)


def test_lines_that_overlap_in_an_outline_are_named_as_overlapping(tmp_path):
    """The bottom drawn as two LINEs overlapping by 4: the message said to join two loose
    ends 4 apart, a gap there is not."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    path = [((0, 0), (12, 0)), ((8, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)),
            ((0, 10), (0, 0))]  # fmt: skip
    for a, b in path:
        space.add_line(a, b, dxfattribs={"layer": "BLOCKS"})
    document.saveas(tmp_path / "cad.dxf")
    words = "LINE (handle 2F) overlaps LINE (handle 30) along 4 of their length: draw them end"
    with pytest.raises(dda.SceneError, match=re.escape(words)):
        dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))


def test_a_closed_shape_drawn_twice_is_refused(tmp_path):
    """It was refused as "overlaps ... by 200 of area (regions must not)"."""
    _nested_squares(tmp_path / "cad.dxf", (0, 0, 20, 10), (0, 0, 20, 10))
    words = "LWPOLYLINE (handle 30) is drawn again as LWPOLYLINE (handle 2F) (the same closed"
    with pytest.raises(dda.SceneError, match=re.escape(words)):
        dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))


@pytest.mark.parametrize(
    ("extra", "words"),
    [('blocks = "ROCK"\nfixed = "ROCK"\n',
      "drawing.fixed: layer 'ROCK' is also drawing.blocks's: each role needs its own"),
     ('blocks = "ROCK"\nexcavation = "rock"\n',
      "drawing.excavation: layer 'rock' is also drawing.blocks's"),
     ('blocks = "ROCK"\njoints = {rock = "bedding"}\n',
      "drawing.joints: layer 'rock' is also drawing.blocks's")],
)  # fmt: skip
def test_a_layer_named_for_two_roles_is_refused_at_its_key(tmp_path, extra, words):
    """Rock and fixed on one layer: each shape overlapped itself ("LWPOLYLINE (handle 2F)
    overlaps ... LWPOLYLINE (handle 2F)")."""
    drawings.drawing_with(tmp_path / "cad.dxf", "ROCK", SQUARE, closed=True)
    with pytest.raises(dda.SceneError, match=re.escape(words)):
        dda.load_scene(_cad_scene(tmp_path, extra))


def test_points_are_left_out_and_coordinates_that_are_no_numbers_refused(tmp_path, caplog):
    """A POINT on a mapped layer is a point CAD left behind (it was refused as no line);
    a LINE to NaN or infinity is refused by its handle (NaN was a line of no length, left
    out; infinity named joint_lines[0] after shapely's RuntimeWarnings)."""
    import ezdxf

    for end, refused in (((1.0, 1.0), False), ((math.nan, 5.0), True), ((math.inf, 5.0), True)):
        document = ezdxf.new("R2010")
        space = document.modelspace()
        space.add_lwpolyline(SQUARE, close=True, dxfattribs={"layer": "BLOCKS"})
        if refused:
            space.add_line((0.0, 5.0), end, dxfattribs={"layer": "JOINTS"})
        else:
            space.add_point(end, dxfattribs={"layer": "JOINTS"})
        document.saveas(tmp_path / "cad.dxf")
        scene = _cad_scene(tmp_path, "", fix='sides = ["bottom"]')
        if refused:
            words = "layer JOINTS: LINE (handle 30) has a coordinate that is not a finite number"
            with pytest.raises(dda.SceneError, match=re.escape(words)):
                dda.load_scene(scene)
            continue
        with caplog.at_level(logging.WARNING), pytest.raises(dda.SceneError, match="every block"):
            dda.load_scene(scene)  # read: one block, all fixed
        assert "layer JOINTS: POINT (handle 30) is a point: left out" in caplog.text


def test_crossing_shapes_on_the_blocks_layer_are_refused_by_handle(tmp_path):
    """Two openings that cross inside the rock, a square inside both: its parent was an
    opening (TypeError, exit 1), and without it the two were joined in silence."""
    import ezdxf

    document = ezdxf.new("R2010")
    space = document.modelspace()
    blocks = {"layer": "BLOCKS"}
    for x0, y0, x1, y1 in ((0, 0, 20, 20), (5, 5, 10, 10), (8, 5, 13, 10), (8.5, 6, 9.5, 7)):
        corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        space.add_lwpolyline(corners, close=True, dxfattribs=blocks)
    document.saveas(tmp_path / "cad.dxf")
    words = "LWPOLYLINE (handle 31) crosses LWPOLYLINE (handle 30) by 10 of area near (9, 7.5)"
    with pytest.raises(dda.SceneError, match=re.escape(words)):
        dda.load_scene(_cad_scene(tmp_path, "", fix='sides = ["bottom"]'))


def test_dda_run_of_a_drawing_points_to_its_scene(capsys):
    """`dda run section.dxf` said "not valid TOML: Expected '=' after a key"."""
    assert cli.main(["run", str(CASES / "drawing_example.dxf"), "-o", "never"]) == 2
    err = capsys.readouterr().err
    assert "a drawing runs through the scene of its materials and joints" in err
    assert f"dda run {CASES / 'drawing_example.toml'}" in err
    assert not Path("never").exists()


def test_the_scale_a_refusal_suggests_is_given_in_full(tmp_path):
    """An inch drawing in a scene in feet suggested scale = 0.0833333, which reads 240 in
    as 19.999992 ft; the factor is now given to the last digit."""
    import ezdxf

    from dda.scene.checks import Checker
    from dda.scene.rockmass.drawing import _scale

    document = ezdxf.new("R2010")
    document.header["$INSUNITS"] = 1  # inches
    raw = {"units": {"length": "ft"}}
    with pytest.raises(dda.SceneError, match=r"scale = 0\.08333333333333333 to read it in ft"):
        _scale(Checker("s.toml"), {}, document, raw, tmp_path / "in.dxf")
    assert 240 * 0.08333333333333333 == 20.0
