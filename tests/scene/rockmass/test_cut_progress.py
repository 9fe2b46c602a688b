"""A long rock-mass cut reports its progress: to a callback in the library, as a bar on
stderr in ``dda cut`` and ``dda run`` (none with ``-q``, none for a small cut)."""

from __future__ import annotations

import logging
import re
import tomllib

import numpy as np
import pytest
from tomli_w import dumps

import dda.cases
import dda.run.cut_bar as cut_bar
import dda.scene.rockmass.expand as expand
from dda.commands.cli import main
from dda.scene.rockmass.expand import cut_rock_mass
from dda.scene.rockmass.progress import CHUNKS, STAGES, CutProgress

BAR_LINE = re.compile(r"^(\S+) \(~([\d,]+) blocks\) \[[#-]+\] +([\d.]+)% .* stage=(\w+)$")


def crossed_slope(spacing: float = 0.8) -> dict:
    """The rock slope's section cut by two crossing persistent sets: 2,351 blocks at 0.8 m
    (estimate 2,346), about a second to cut."""
    raw = tomllib.loads(dda.cases.folder().joinpath("rock_slope.toml").read_text())
    raw["joint_sets"] = [
        {"dip": 35.0, "spacing": spacing, "offset": 0.1},
        {"dip": 110.0, "spacing": 1.3 * spacing, "offset": 0.1},
    ]
    raw["cutting"] = {}
    return raw


def test_the_cut_reports_every_stage_in_order_monotone_to_exactly_one(caplog, monkeypatch):
    monkeypatch.setattr(expand, "LARGE_CUT", 2_000)  # 5,000 in use; this cut's 2,346
    calls = []
    with caplog.at_level(logging.INFO, logger="dda.scene.rockmass.expand"):
        cut, scene = cut_rock_mass(crossed_slope(), "<t>", lambda f, i: calls.append((f, i)))
    fractions = [f for f, _ in calls]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    assert all(b >= a for a, b in zip(fractions, fractions[1:], strict=False))
    assert all(0.0 <= f <= 1.0 for f in fractions)
    stages = [i["stage"] for _, i in calls]
    assert stages[-1] == "done"
    order = [*STAGES, "done"]
    assert [order.index(s) for s in stages] == sorted(order.index(s) for s in stages)
    assert {"noding", "polygonising", "tagging", "tables"} <= set(stages)
    assert {i["blocks"] for _, i in calls} == {2346}  # the estimate, before cutting
    # the 9,000-odd block edges are tagged in chunks of 1,000 or more, each reported
    assert stages.count("tagging") >= 5
    # the callback's caller shows the progress: the "may take a minute" is no warning
    assert "<t>: cutting about 2,346 blocks; this may take a minute" in caplog.text
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    # the chunked stages give the same blocks as one piece (no callback: no chunks)
    plain, plain_scene = cut_rock_mass(crossed_slope(), "<t>")
    assert len(cut.names) == len(plain.names) == 2351
    np.testing.assert_array_equal(cut.blocks.vertices, plain.blocks.vertices)
    np.testing.assert_array_equal(cut.blocks.edge_source, plain.blocks.edge_source)
    assert scene == plain_scene


def test_the_reporter_without_a_callback_runs_every_stage_in_one_piece():
    silent = CutProgress(None, 10**6)
    assert list(silent.chunks("tagging", 50_000)) == [slice(0, 50_000)]
    calls = []
    loud = CutProgress(lambda f, i: calls.append(f), 10**6)
    assert len(list(loud.chunks("tagging", 50_000))) == CHUNKS
    assert len(list(loud.chunks("tables", 999))) == 1  # small counts stay whole
    assert len(calls) == 1 + CHUNKS - 1  # the start, then after every chunk but the last


def bar_lines(err: str) -> list[tuple[str, int, float, str]]:
    """(scene, estimate, percent, stage) of every progress line on stderr (not a TTY:
    one line a 5 % step)."""
    found = []
    for line in err.splitlines():
        match = BAR_LINE.match(line)
        if match:
            name, blocks, percent, stage = match.groups()
            found.append((name, int(blocks.replace(",", "")), float(percent), stage))
    return found


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "crossed.toml"
    path.write_text(dumps(crossed_slope()))
    return path


def test_dda_cut_shows_a_bar_on_stderr_that_ends_at_100_percent(
    scene_file, tmp_path, capsys, monkeypatch
):
    monkeypatch.setattr(cut_bar, "LONG_CUT", 2_000)  # 5,000 in use; this cut's 2,346
    out = tmp_path / "blocks.toml"
    assert main(["cut", str(scene_file), "-o", str(out), "--no-png"]) == 0
    captured = capsys.readouterr()
    lines = bar_lines(captured.err)
    assert len(lines) >= 5
    assert {(name, blocks) for name, blocks, _, _ in lines} == {("crossed.toml", 2346)}
    percents = [p for _, _, p, _ in lines]
    assert percents == sorted(percents) and percents[-1] == 100.0
    assert lines[-1][3] == "done"
    assert captured.out == f"{out}: 2351 blocks, 177 fixed\n"
    assert len(tomllib.loads(out.read_text())["blocks"]) == 2351


def test_dda_cut_quiet_prints_nothing(scene_file, tmp_path, capsys, monkeypatch, caplog):
    monkeypatch.setattr(cut_bar, "LONG_CUT", 2_000)
    monkeypatch.setattr(expand, "LARGE_CUT", 2_000)  # the "may take a minute" warning
    out = tmp_path / "blocks.toml"
    with caplog.at_level(logging.INFO, logger="dda.scene.rockmass.expand"):
        assert main(["cut", str(scene_file), "-o", str(out), "--no-png", "-q"]) == 0
    assert capsys.readouterr() == ("", "")
    assert "cutting about 2,346 blocks" in caplog.text  # an info message only
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(tomllib.loads(out.read_text())["blocks"]) == 2351


def test_a_small_cut_prints_no_bar(scene_file, tmp_path, capsys):
    out = tmp_path / "blocks.toml"  # 2,346 estimated blocks, below the 5,000 in use
    assert main(["cut", str(scene_file), "-o", str(out), "--no-png"]) == 0
    assert capsys.readouterr() == (f"{out}: 2351 blocks, 177 fixed\n", "")


@pytest.mark.parametrize("quiet", [False, True])
def test_dda_run_shows_the_cut_of_its_scene_unless_quiet(
    scene_file, tmp_path, capsys, monkeypatch, quiet
):
    monkeypatch.setattr(cut_bar, "LONG_CUT", 2_000)
    # --max-output 0 refuses the run right after the scene is loaded (and cut)
    argv = ["run", str(scene_file), "-o", str(tmp_path / "o"), "--max-output", "0"]
    assert main(argv + ["-q"] * quiet) == 2
    err = capsys.readouterr().err
    assert "--max-output 0 GB" in err.splitlines()[-1]
    lines = bar_lines(err)
    if quiet:
        assert lines == [] and len(err.splitlines()) == 1
    else:
        percents = [p for _, _, p, _ in lines]
        assert len(lines) >= 5 and percents == sorted(percents)
        assert lines[-1][2:] == (100.0, "done")


def test_dda_fos_and_ensemble_show_the_cut_of_their_scene(scene_file, capsys, monkeypatch):
    """They load the scene once before their trials (dda.commands.fos.prepare)."""
    import argparse

    from dda.commands.fos import OVERRIDES, prepare

    monkeypatch.setattr(cut_bar, "LONG_CUT", 2_000)
    args = argparse.Namespace(
        scene=scene_file, blocks=None, intact=False, **dict.fromkeys(OVERRIDES),
        outdir=scene_file.parent / "out", serial=True,
    )  # fmt: skip
    prepared = prepare(args, "fos", reduced=False)
    assert not isinstance(prepared, str), prepared
    assert len(prepared[1].blocks) == 2351
    lines = bar_lines(capsys.readouterr().err)
    assert {(name, blocks) for name, blocks, _, _ in lines} == {("crossed.toml", 2346)}
    assert lines[-1][2:] == (100.0, "done")


def test_cut_takes_a_shipped_case_by_name(tmp_path, monkeypatch):
    """Like ``dda run``, ``dda cut`` finds a shipped case by its name from any folder."""
    monkeypatch.chdir(tmp_path)
    assert main(["cut", "jointed_slope_fos", "-o", "cut.toml", "--no-png", "-q"]) == 0
    assert "[[blocks]]" in (tmp_path / "cut.toml").read_text()
