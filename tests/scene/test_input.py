"""What a scene file's reader says: encodings, block names, absurd speeds, odd paths."""

from __future__ import annotations

import codecs

import pytest
import tomli_w

import dda
import dda.cases
from dda.commands.cli import main

TEXT = dda.cases.folder().joinpath("sliding_block.toml").read_text(encoding="utf-8")


def test_a_byte_order_mark_is_read_past(tmp_path):
    """Windows Notepad's UTF-8 starts with EF BB BF (was: Invalid statement, line 1)."""
    path = tmp_path / "bom.toml"
    path.write_bytes(codecs.BOM_UTF8 + TEXT.encode("utf-8"))
    assert dda.load_scene(path).blocks == dda.load_scene(TEXT).blocks


@pytest.mark.parametrize(
    ("encoding", "reason"),
    [
        ("utf-16", "is UTF-16 text, not UTF-8; save it as UTF-8"),
        ("utf-16-le", "is UTF-16 text, not UTF-8; save it as UTF-8"),
        ("latin-1", "is not UTF-8 text (byte 0xe9 on line 1: Latin-1 or Windows-1252?); save"),
    ],
)
def test_other_encodings_are_refused_with_the_fix(tmp_path, capsys, encoding, reason):
    path = tmp_path / "scene.toml"
    path.write_bytes(TEXT.replace("Block sliding", "Bloc glissé").encode(encoding))
    for argv in (["run", str(path), "-o", str(tmp_path / "out")], ["cut", str(path)]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{path}: {reason}" in err[0]
        assert "codec" not in err[0]


@pytest.mark.parametrize(
    "data", [b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), bytes(300)]
)
def test_a_binary_file_is_refused_as_such(tmp_path, capsys, data):
    """A picture given as the scene was called UTF-16 text (any NUL byte was)."""
    path = tmp_path / "picture.toml"
    path.write_bytes(data)
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"dda run: {path}: is not a text file (binary data): a scene is TOML text"]
    assert not (tmp_path / "out").exists()


def test_an_error_in_a_thousand_blocks_names_the_block(tmp_path, capsys):
    floor = [[-1, -1], [1001, -1], [1001, 0], [-1, 0]]
    blocks = [{"name": "floor", "material": "rock", "fixed": True, "vertices": floor}]
    for i in range(1000):
        square = [[i, 0], [i + 0.9, 0], [i + 0.9, 1], [i, 1]]
        blocks.append({"name": f"column_{i + 1}", "material": "rock", "vertices": square})
    blocks[735]["material"] = "rokc"
    raw = {"analysis": {"steps": 2}, "blocks": blocks,
           "materials": {"rock": {"density": 2600.0, "young": 5e9, "poisson": 0.25}}}  # fmt: skip
    path = tmp_path / "columns.toml"
    path.write_text(tomli_w.dumps(raw))
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "blocks[735].material: (block 'column_735') unknown material 'rokc'" in err


def test_an_absurd_initial_speed_is_refused_by_name_before_the_run(tmp_path, capsys):
    """1e10 m/s (a unit mix-up) was blamed on "contacts did not settle" after the run."""
    path = tmp_path / "fast.toml"
    path.write_text(TEXT.replace('name = "slider"', 'name = "slider"\nvelocity = [1e10, 0, 0]'))
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "blocks[1].velocity: (block 'slider') moves 9.19e+06 model sizes (10.9)" in err
    assert "no step can follow it" in err and not (tmp_path / "out").exists()
    path.write_text(TEXT.replace('name = "slider"', 'name = "slider"\nvelocity = [100, 0, 0]'))
    assert dda.load_scene(path).blocks[1].velocity == (100.0, 0.0, 0.0)  # 0.09 sizes a step


def test_a_path_without_toml_is_read_as_a_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "slide.txt").write_text(TEXT)
    assert len(dda.load_scene("slide.txt").blocks) == 2
    with pytest.raises(dda.SceneError, match="^missing_scene: no such file$"):
        dda.load_scene("missing_scene")
    assert dda.load_scene(TEXT).title  # TOML text still works


def test_an_unknown_material_in_a_scene_without_materials_says_so():
    """Was "unknown material 'x'; expected one of " with nothing after it."""
    raw = {"blocks": [{"name": "a", "material": "x", "vertices": [[0, 0], [1, 0], [0, 1]]}]}
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(raw)
    assert str(caught.value).endswith("unknown material 'x'; the scene defines no material")


def _block_on_plane(joints: dict) -> dict:
    rock = {"density": 2600.0, "young": 1e9, "poisson": 0.25}
    base = [[0, -1], [10, -1], [10, 0], [0, 0]]
    return {
        "materials": {"rock": rock},
        "joints": joints,
        "blocks": [
            {"name": "base", "material": "rock", "fixed": True, "vertices": base},
            {"name": "b", "material": "rock", "vertices": [[4, 0], [5, 0], [5, 1], [4, 1]]},
        ],
    }


def test_a_misspelt_default_joint_is_refused_not_left_frictionless():
    """An audit's ``[joints.defualt]``: nothing named it, every edge took the implicit
    frictionless default, and a block that should stand slid 2 m without a word."""
    raw = _block_on_plane({"defualt": {"friction_angle": 35.0}})
    with pytest.raises(dda.SceneError) as caught:
        dda.load_scene(raw)
    assert "joints.defualt: names no edge" in str(caught.value)
    assert str(caught.value).endswith("did you mean 'default'?")


def test_a_joint_near_default_is_accepted_where_named_or_a_default_is_given():
    named = _block_on_plane({"defaults": {"friction_angle": 35.0}})
    named["interfaces"] = [{"blocks": ["base", "b"], "joint": "defaults"}]
    assert dda.load_scene(named).interfaces[0].joint == "defaults"
    both = _block_on_plane({"default": {"friction_angle": 30.0}, "defualt": {}})
    assert dda.load_scene(both).joints["default"].friction_angle == 30.0
    for name in ("bedding", "fault", "defect"):  # library entries, not typos
        unrelated = _block_on_plane({name: {"friction_angle": 35.0}})
        assert name in dda.load_scene(unrelated).joints
    with pytest.raises(dda.SceneError, match="did you mean 'default'"):
        dda.load_scene(_block_on_plane({"Default": {"friction_angle": 35.0}}))
