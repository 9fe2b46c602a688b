"""Output paths on the command line: an empty one is refused; --overwrite leaves nothing
of the earlier run, not even the pictures drawn from it in their default places."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from dda.commands.cli import main


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "sliding_block", "-o", ""],
        ["run", "sliding_block", "-o", "  "],
        ["render", "out", "-o", ""],
        ["plot", "out", "-o", ""],
        ["cut", "rock_slope.toml", "-o", ""],
        ["cut", "rock_slope.toml", "--png", ""],
        ["tradeoff", "sliding_block", "-o", ""],
        ["verify", "self_weight", "-o", ""],
        ["movie", "out", "-o", ""],
        ["fos", "sliding_block", "-o", ""],
        ["ensemble", "sliding_block", "-o", ""],
    ],
    ids=lambda argv: " ".join(a or '""' for a in argv),
)
def test_an_empty_output_path_is_refused_and_nothing_is_written(
    tmp_path, monkeypatch, capsys, argv
):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "an empty path; give a" in err[0]
    assert os.listdir(tmp_path) == []


def test_overwrite_removes_the_pictures_drawn_from_the_earlier_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "sliding_block", "-o", "out", "-q"]) == 0
    Path("out/blocks_000100_syy.png").write_bytes(b"png")  # dda render's default name
    Path("out/plots").mkdir()
    Path("out/plots/top_displacement.png").write_bytes(b"png")  # dda plot's
    Path("out/movie.mp4").write_bytes(b"mp4")  # dda movie's
    Path("out/notes.txt").write_text("mine")  # not a run's file: kept
    assert main(["run", "sliding_block", "-o", "out", "-q", "--overwrite"]) == 0
    left = sorted(str(p.relative_to("out")) for p in Path("out").rglob("*") if p.is_file())
    assert "blocks_000100_syy.png" not in left and not Path("out/plots").exists()
    assert "movie.mp4" not in left
    assert "notes.txt" in left and "final.png" in left


def test_cut_into_a_folder_writes_the_scene_in_it(tmp_path, monkeypatch, capsys):
    """``-o DIR/`` (or an existing folder) is a folder: DIR/<scene>.toml and its picture
    (a trailing slash made the files DIR and DIR.png)."""
    monkeypatch.chdir(tmp_path)
    assert main(["cut", "rock_slope", "-o", "new/", "-q"]) == 0
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == [
        "rock_slope.png",
        "rock_slope.toml",
    ]
    (tmp_path / "there").mkdir()
    assert main(["cut", "rock_slope", "-o", "there", "--no-png", "-q"]) == 0
    assert [p.name for p in (tmp_path / "there").iterdir()] == ["rock_slope.toml"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new", "there"]


def test_cut_refuses_a_picture_that_is_not_png_before_cutting(tmp_path, monkeypatch, capsys):
    """Was matplotlib's ``ValueError: Format 'xyz' is not supported``, exit 1, after the cut."""
    monkeypatch.chdir(tmp_path)
    assert main(["cut", "rock_slope", "-o", "z.toml", "--png", "z.xyz"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "dda cut: --png z.xyz: a picture is written as .png, not .xyz; give a file name "
        "ending in .png\n"
    )
    assert os.listdir(tmp_path) == []
