"""The scene keys of rock engineering (dda/scene/engineering.py): accepted, and refused in
one line naming the key."""

from __future__ import annotations

import copy

import pytest

import dda
from dda.errors import SceneError
from tests.helpers import ROCK, rectangle


def base_scene() -> dict:
    """A fixed floor, two free blocks on it side by side, and a bolt joining them."""
    return {
        "analysis": {"time_step": 0.01, "duration": 1.0, "gravity": [0.0, -9.81]},
        "materials": {"rock": ROCK},
        "blocks": [
            {
                "name": "floor",
                "material": "rock",
                "fixed": True,
                "vertices": rectangle(-5, -1, 5, 0),
            },
            {"name": "a", "material": "rock", "vertices": rectangle(0, 0, 1, 1)},
            {"name": "b", "material": "rock", "vertices": rectangle(1, 0, 2, 1)},
        ],
        "groups": {"pair": ["a", "b"]},
        "bolts": [{"start": [0.5, 0.5], "end": [1.5, 0.5], "stiffness": 1e7, "pretension": 10.0}],
    }


def test_the_sections_load_with_their_defaults(tmp_path):
    raw = base_scene()
    raw["seismic"] = {"acceleration": [[0.0, 1.0], [1.0, 0.0]]}
    raw["water"] = {"table": [[-5.0, 0.5], [5.0, 0.7]], "unit_weight": 9810.0}
    raw["measure"] = [{"point": [0.5, 0.5]}, {"blocks": ["a", "b"]}, {"bolt": "bolt1"}]
    raw["stages"] = [
        {"time": 0.5, "bolts": [{"start": [0.2, 0.2], "end": [0.2, -0.5], "stiffness": 1e6}]},
        {"time": 0.6, "remove": ["b"]},
    ]
    raw["bolts"] = []  # a stage bolt may end in the floor; none joins b, which goes
    scene = dda.load_scene(raw)
    (bolt,) = scene.stages[0].bolts
    assert (bolt.name, bolt.blocks) == ("bolt1", ("a", "floor"))
    assert (bolt.pretension, bolt.capacity) == (0.0, None)
    assert scene.seismic.record == ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    assert scene.seismic.blocks == ("floor",) and scene.seismic.scale == 1.0
    assert [m.kind for m in scene.measure] == ["point", "contact", "bolt"]
    assert scene.measure[0].block == "a" and scene.measure[0].quantities == (
        "displacement", "velocity", "stress"
    )  # fmt: skip
    assert scene.measure[1].columns() == ["m2.N", "m2.fx", "m2.fy"]
    assert scene.stages[1].remove == ("b",)


def test_a_scene_without_the_sections_has_none_of_them():
    scene = dda.load_scene({k: v for k, v in base_scene().items() if k != "bolts"})
    assert (scene.bolts, scene.seismic, scene.water, scene.measure, scene.stages) == (
        (), None, None, (), ()
    )  # fmt: skip


def test_a_record_file_is_read_relative_to_the_scene(tmp_path):
    (tmp_path / "quake.csv").write_text("# a pulse\nt,ax,ay\n0,1.5,0\n0.2,1.5,-0.5\n")
    raw = base_scene()
    raw["seismic"] = {"file": "quake.csv", "scale": 9.81, "blocks": ["floor"]}
    import tomli_w

    (tmp_path / "s.toml").write_text(tomli_w.dumps(raw))
    scene = dda.load_scene(tmp_path / "s.toml")
    assert scene.seismic.record == ((0.0, 1.5, 0.0), (0.2, 1.5, -0.5))
    assert scene.seismic.file == "quake.csv" and scene.seismic.scale == 9.81


def test_stage_polygons_and_groups_select_blocks_at_t0():
    raw = base_scene()
    raw["bolts"] = []
    raw["stages"] = [{"time": 0.1, "polygon": rectangle(0.9, -0.5, 2.5, 2)}]
    assert dda.load_scene(raw).stages[0].remove == ("b",)
    raw["blocks"].append({"name": "c", "material": "rock", "vertices": rectangle(3, 0, 4, 1)})
    raw["stages"] = [{"time": 0.1, "remove": ["pair"]}]
    assert dda.load_scene(raw).stages[0].remove == ("a", "b")


def edit(path, value):
    """A scene with the value at ``path`` (keys and indices) set (None: removed)."""

    def make():
        raw = base_scene()
        raw["seismic"] = {"acceleration": [[0.0, 1.0], [1.0, 0.0]]}
        raw["water"] = {"table": [[-5.0, 0.5], [5.0, 0.7]], "unit_weight": 9810.0}
        raw["measure"] = [{"name": "p", "point": [0.5, 0.5]}]
        raw["stages"] = [{"time": 0.5, "polygon": rectangle(-9, 2, 9, 3)}]
        raw["blocks"].append({"name": "top", "material": "rock", "vertices": rectangle(0, 2, 1, 3)})
        target = raw
        for key in path[:-1]:
            target = target[key]
        if value is None:
            del target[path[-1]]
        else:
            target[path[-1]] = copy.deepcopy(value)
        return raw

    return make


REFUSED = [
    (("bolts", 0, "stifness"), 1.0, "bolts[0].stifness", "unknown key; did you mean 'stiffness'"),
    (("bolts", 0, "stiffness"), -1.0, "bolts[0].stiffness", "must be > 0"),
    (("bolts", 0, "stiffness"), None, "bolts[0].stiffness", "is required"),
    (("bolts", 0, "end"), [0.5, 0.5], "bolts[0].end", "coincides with start"),
    (("bolts", 0, "end"), [0.7, 0.5], "bolts[0].end", "same block 'a'"),
    (("bolts", 0, "end"), [9.0, 9.0], "bolts[0].end", "lies in no block"),
    (("bolts", 0, "end"), [1.0, 0.5], "bolts[0].end", "boundary of blocks 'a' and 'b'"),
    (("bolts", 0, "blocks"), ["a", "c"], "bolts[0].blocks[1]", "unknown block 'c'"),
    (("bolts", 0, "blocks"), ["a", "floor"], "bolts[0].end", "lies outside block 'floor'"),
    (("bolts", 0, "capacity"), 5.0, "bolts[0].capacity", "must exceed the pretension 10"),
    (("seismic", "acceleration"), [[0.0, 1.0]], "seismic.acceleration", "at least 2 rows"),
    (("seismic", "acceleration"), [[0.0, 1.0], [0.0, 2.0]], "seismic.acceleration[1]",
     "times must increase strictly"),
    (("seismic", "acceleration"), [[0.0, 1.0, 2.0], [1.0, 2.0]], "seismic.acceleration",
     "every row must hold"),
    (("seismic", "acceleration"), [0.0, 1.0, 0.1, 2.0], "seismic.acceleration[0]",
     "expected a list, got the number 0.0"),
    (("seismic", "acceleration"), [[0.0, 1.0], True], "seismic.acceleration[1]",
     "expected a list, got"),
    (("seismic", "file"), "missing.csv", "seismic", "give the record as"),
    (("seismic",), {"file": "missing.csv"}, "seismic.file", "cannot read"),
    (("seismic", "blocks"), ["a"], "seismic.blocks[0]", "'a' is not fixed"),
    (("seismic", "component"), "z", "seismic.component", "unknown value 'z'"),
    (("water", "table"), [[0.0, 1.0], [0.0, 2.0]], "water.table[1]", "x must increase"),
    (("water", "unit_weight"), None, "water.unit_weight", "is required"),
    (("water", "unit_weight"), 0.0, "water.unit_weight", "must be > 0"),
    (("measure", 0, "point"), [9.0, 9.0], "measure[0].point", "lies in no block"),
    (("measure", 0, "blocks"), ["a", "b"], "measure[0]", "exactly one of point, blocks"),
    (("measure", 0, "name"), "x.y", "measure[0].name", "without , ."),
    (("measure", 0, "quantities"), ["stress", "force"], "measure[0].quantities[1]",
     "unknown value 'force'"),
    (("stages", 0, "time"), 2.0, "stages[0].time", "not before the end of the run"),
    (("stages", 0, "polygon"), rectangle(-9, 5, 9, 6), "stages[0].polygon", "no block"),
    (("stages", 0, "remove"), ["zz"], "stages[0].remove[0]", "unknown block or group 'zz'"),
    # an empty list would do nothing, silently: refused as the key left out is
    (("stages", 0, "remove"), [], "stages[0].remove", "is empty: list at least one"),
    (("stages", 0, "bolts"), [], "stages[0].bolts", "is empty: list at least one"),
    (("stages", 0, "boundary_stresses"), [], "stages[0].boundary_stresses", "is empty"),
    (("stages", 0, "remove_boundary_stresses"), [], "stages[0].remove_boundary_stresses",
     "is empty"),
    (("seismic", "blocks"), [], "seismic.blocks", "is empty: list at least one"),
    (("seismic", "scale"), 0.0, "seismic.scale", "the ground would not move"),
    (("stages", 0, "polygon"), rectangle(-0.5, 0.2, 0.8, 0.8), "stages[0].remove",
     "removes block 'a', which measure[0].point is attached to"),
    (("stages", 0), {"time": 0.5, "strength_factor": 2.0, "intact": True}, "stages[0].intact",
     "no block's material is breakable"),
    (("stages", 0, "remove"), ["floor"], "stages[0].remove",  # it carries the earthquake
     "removes block 'floor', which seismic.blocks[0] is attached to"),
    (("stages", 0, "polygon"), rectangle(-9, -0.5, 9, 9), "stages",
     "remove every free block"),
]  # fmt: skip


@pytest.mark.parametrize(("path", "value", "key", "reason"), REFUSED)
def test_a_bad_entry_is_refused_naming_its_key(path, value, key, reason):
    with pytest.raises(SceneError) as info:
        dda.load_scene(edit(path, value)())
    assert info.value.key == key
    assert reason in info.value.reason
    assert "\n" not in str(info.value)


def test_bolt_pretension_and_seismic_mode_and_stage_order_are_checked():
    raw = edit(("bolts", 0, "pretension"), 10.0)()
    dda.load_scene(raw)
    raw["analysis"]["mode"] = "static"
    with pytest.raises(SceneError, match="seismic: earthquake input needs"):
        dda.load_scene(raw)
    raw = edit(("stages",), [{"time": 0.5, "remove": ["top"]}, {"time": 0.4, "remove": ["b"]}])()
    with pytest.raises(SceneError, match=r"stages\[1\].time: stages must come in order"):
        dda.load_scene(raw)
    raw = edit(("stages",), [{"time": 0.5, "remove": ["top"]}, {"time": 0.6, "remove": ["top"]}])()
    with pytest.raises(SceneError, match="removed already by stages"):
        dda.load_scene(raw)
    raw = edit(("stages",), [{"time": 0.5}])()
    with pytest.raises(SceneError, match=r"stages\[0\]: a stage removes blocks"):
        dda.load_scene(raw)
    # a run given in steps ends at steps x time_step: a stage after it never came (silently)
    raw = edit(("stages",), [{"time": 0.7, "remove": ["top"]}])()
    raw["analysis"].pop("duration")
    raw["analysis"]["steps"] = 50
    with pytest.raises(SceneError, match=r"stages\[0\].time: 0.7 is not before the end of "
                       r"the run \(analysis.steps x time_step = 0.5"):  # fmt: skip
        dda.load_scene(raw)


def test_the_cli_refuses_a_bad_section_in_one_line(tmp_path, capsys):
    import tomli_w

    from dda.commands import cli

    raw = edit(("water", "unit_weight"), -1.0)()
    (tmp_path / "bad.toml").write_text(tomli_w.dumps(raw))
    code = cli.main(["run", str(tmp_path / "bad.toml"), "-o", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "water.unit_weight: must be > 0" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("text", "record"),
    [
        ("time\taccel\n0\t1.5\n0.2\t-0.5\n", ((0.0, 1.5, 0.0), (0.2, -0.5, 0.0))),
        ("0;1.5\n0.2;-0.5\n", ((0.0, 1.5, 0.0), (0.2, -0.5, 0.0))),
        ("  0   1.5e0\n  0.2 -5E-1 \n", ((0.0, 1.5, 0.0), (0.2, -0.5, 0.0))),
    ],
    ids=["tabs and a header", "semicolons", "spaces"],
)
def test_a_record_file_may_separate_its_numbers_by_spaces_tabs_or_semicolons(
    tmp_path, text, record
):
    """They were all read as header lines ('expected at least 2 rows, got 0')."""
    import tomli_w

    (tmp_path / "quake.txt").write_text(text)
    raw = base_scene()
    raw["seismic"] = {"file": "quake.txt", "blocks": ["floor"]}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(raw))
    assert dda.load_scene(tmp_path / "s.toml").seismic.record == record


def test_a_bad_first_row_of_a_record_is_refused_by_its_line(tmp_path):
    """A typo in the first row was skipped as if it were a header, silently."""
    import tomli_w

    (tmp_path / "quake.csv").write_text("t,a\n0,1.5x\n0.2,1.5\n0.4,1.5\n")
    raw = base_scene()
    raw["seismic"] = {"file": "quake.csv", "blocks": ["floor"]}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(raw))
    with pytest.raises(SceneError, match=r"quake.csv line 2: not numbers: '0,1.5x'"):
        dda.load_scene(tmp_path / "s.toml")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0 0,0\n1 2,0\n2 2,0\n", r"line 1: a comma inside a number, '0 0,0': write decimal"),
        ("0,0;0,5\n0,2;1,5\n", r"line 1: a comma inside a number"),
        ("0.0 0.0\n0.1 2.0 5.0\n0.3 0.0\n", r"line 2: 3 numbers where the rows above hold 2"),
    ],
    ids=["decimal comma and spaces", "decimal comma and semicolons", "a row too long"],
)
def test_a_record_row_that_cannot_be_meant_is_refused_by_its_line(tmp_path, text, message):
    """A decimal-comma file was read as three columns (t, ax, ay) and ran; a row of 3
    numbers among rows of 2 was refused without its line."""
    import tomli_w

    (tmp_path / "rec.txt").write_text(text)
    raw = base_scene()
    raw["seismic"] = {"file": "rec.txt", "blocks": ["floor"]}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(raw))
    with pytest.raises(SceneError, match="rec.txt " + message):
        dda.load_scene(tmp_path / "s.toml")


@pytest.mark.parametrize(
    ("record", "said"),
    [
        ([[0, 0.0], [100, 2.0], [200, 0.0]], "before the record's second time (100 s)"),
        ([[1, 0.0], [2, 2.0], [3, 0.0]], "the record starts at t = 1 s, after the run ends"),
        ([[0, 0.0], [0.5, 2.0], [3, 0.0]], None),
    ],
    ids=["times in ms", "a row index as time", "a record longer than the run"],
)
def test_a_record_the_run_cannot_see_is_warned(record, said):
    """A record in ms, or one whose first column was a row index, ran with the ground
    still (0.21 mm for 0.10 m), unsaid."""
    raw = base_scene()
    raw["analysis"]["mode"] = "dynamic"
    raw["seismic"] = {"acceleration": record}
    warnings = dda.load_scene(raw).load_warnings
    if said is None:
        assert not any("seismic" in w for w in warnings)
    else:
        assert any(w.startswith("seismic.acceleration: ") and said in w for w in warnings)


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        ("# café record\n0 0.5\n0.2 0.5\n".encode("latin-1"), "is not UTF-8 text (byte 0xe9"),
        ("0 0.5\n0.2 0.5\n".encode("utf-16"), "is UTF-16 text, not UTF-8"),
        (b"\x89PNG\r\n\x1a\n\x00\x00", "is not a text file (binary data)"),
    ],
    ids=["latin-1", "utf-16", "binary"],
)
def test_a_record_file_that_is_not_utf8_text_is_refused_with_the_fix(tmp_path, data, reason):
    """A Latin-1 record crashed the scene check (AttributeError: a UnicodeDecodeError has
    no strerror), exit 1 without the key."""
    import tomli_w

    (tmp_path / "rec.txt").write_bytes(data)
    raw = base_scene()
    raw["seismic"] = {"file": "rec.txt", "blocks": ["floor"]}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(raw))
    with pytest.raises(SceneError) as info:
        dda.load_scene(tmp_path / "s.toml")
    assert info.value.key == "seismic.file" and reason in info.value.reason
