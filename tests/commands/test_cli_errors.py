"""Every refused input of the ``dda`` command: exit code 2 (130 for Ctrl-C), one line on
stderr naming the file, key or argument and the reason, no traceback, nothing written."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import pytest

import dda
from dda.commands import cli
from tests.commands.test_cli import SMALL_SCENE

FAR_LOAD = '\n[[loads]]\nblock = "top"\npoint = [1.5, 50.0]\nforce = [0.0, -10.0]\n'
FIXED_LOAD = '\n[[loads]]\nblock = "base"\npoint = [1.0, 0.5]\nforce = [0.0, -10.0]\n'
ROUND = [[3 + math.cos(2 * math.pi * k / 1024), 3 + math.sin(2 * math.pi * k / 1024)]
         for k in range(1024)]  # fmt: skip
SCENES = {
    "ok.toml": SMALL_SCENE,
    "all_fixed.toml": SMALL_SCENE.replace('name = "top"', 'name = "top"\nfixed = true'),
    "round.toml": SMALL_SCENE.replace(
        "vertices = [[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]]", f"vertices = {ROUND}"
    ),
    "far_load.toml": SMALL_SCENE + FAR_LOAD,
    "fixed_load.toml": SMALL_SCENE + FIXED_LOAD,
    "moving_base.toml": SMALL_SCENE.replace("fixed = true", "fixed = true\nvelocity = [1, 0, 0]"),
    "forever.toml": SMALL_SCENE.replace("steps = 6", "duration = 1e9"),
    "every_step.toml": SMALL_SCENE.replace("steps = 6", "steps = 9000000").replace(
        "save_every = 3", "save_every = 1"
    ),
    "heavier.toml": SMALL_SCENE.replace("density = 2700.0", "density = 2800.0"),
    "not_toml.toml": SMALL_SCENE.replace("[analysis]", "[analysis"),
}

# (arguments, exit code, what the one line says); {d} is the test's directory
REFUSED = [
    (["run", "all_fixed.toml"], 2, "all_fixed.toml: blocks: every block is fixed"),
    (
        ["run", "round.toml"],
        2,
        "round.toml: blocks[1].vertices: (block 'top') 1024 vertices, at most 1023",
    ),
    (["run", "ok.toml", "-o", "a_file"], 2, "-o a_file: exists and is not a directory"),
    (["run", "ok.toml", "-o", "a_file/x"], 2, "-o a_file/x: {d}/a_file is a file, not a directory"),
    (
        ["run", "ok.toml", "-o", "read_only/x"],
        2,
        "-o read_only/x: cannot create it in {d}/read_only",
    ),
    (["run", "a_dir"], 2, "a_dir: is a directory, not a scene file"),
    (["run", "absent.toml"], 2, "absent.toml: no such file"),
    (["run", "/dev/null"], 2, "/dev/null: is not a regular file (a scene is a TOML file)"),
    (["cut", "/dev/null"], 2, "/dev/null: is not a regular file (a scene is a TOML file)"),
    (["run", "not_toml.toml"], 2, "not_toml.toml: not valid TOML: Expected ']' at the end of"),
    (
        ["run", "forever.toml"],
        2,
        "forever.toml: analysis.duration: 1e+09 s at time_step 0.001 s "
        "is at least 1e+12 steps, more than analysis.max_steps = 10000000",
    ),
    (["run", "ok.toml", "--max-steps", "5"], 2, "ok.toml: analysis.steps: 6 steps are more than"),
    (["run", "every_step.toml"], 2, "every_step.toml: analysis.save_every: about 9,000,002 frames"),
    (
        ["run", "far_load.toml"],
        2,
        "far_load.toml: loads[0].point: lies outside block 'top' (distance 48)",
    ),
    (["run", "fixed_load.toml"], 2, "loads[0].block: 'base' is fixed: a load on it does nothing"),
    (
        ["run", "moving_base.toml"],
        2,
        "moving_base.toml: blocks[0].velocity: (block 'base') the block is fixed",
    ),
    (["run", "ok.toml", "-o", "fresh", "--resume"], 2, "-o fresh: holds no run to resume"),
    (["run", "ok.toml", "-o", "stopped", "--resume"], 2, "stopped/checkpoint.npz: no checkpoint"),
    (
        ["run", "heavier.toml", "-o", "paused", "--resume"],
        2,
        "paused/checkpoint.npz: written for another scene (materials differ",
    ),
    (["run", "ok.toml", "-o", "damaged", "--resume"], 2, "damaged/checkpoint.npz: not a dda chec"),
    (["run", "ok.toml", "--resume", "--overwrite"], 2, "argument --overwrite: not allowed with"),
    (["run", "ok.toml", "--checkpoint-every", "0"], 2, "argument --checkpoint-every: must be a p"),
    (["run", "ok.toml", "--max-output", "-1"], 2, "argument --max-output: must be a finite n"),
    (["cut", "ok.toml", "-o", "a_file/x.toml"], 2, "-o a_file/x.toml: a_file is a file, not a"),
    (["cut", "no_such_case", "-o", "x.toml"], 2, "dda cut: no_such_case: no such file"),
    (["cut", "ok.toml", "-o", "heavier.toml"], 2, "-o heavier.toml: exists; give --overwrite to"),
    (["cut", "ok.toml", "-o", "new.toml", "--png", "a_file.png"], 2, "--png a_file.png: exists;"),
    (["cut", "ok.toml", "-o", "new.toml", "--png", "a_file"], 2, "--png a_file: a picture is"),
    (["render", "a_file"], 2, "dda render: a_file: not a blocks frame file"),
    (["render", "contacts_000000.vtu"], 2, "contacts_000000.vtu: not a blocks frame file"),
    (["render", "a_dir"], 2, "dda render: a_dir: no written frame"),
    (["render", "stopped", "-o", "a_file/x.png"], 2, "a_file/x.png: a_file is a file, not a dir"),
    (["render", "broken/frames/blocks_000000.vtu"], 2, "blocks_000000.vtu: cannot read it as a"),
    (
        ["bench", "--sizes", "0"],
        2,
        "dda bench: argument --sizes: must be a positive integer, got 0",
    ),
    (["bench", "--steps", "0"], 2, "dda bench: argument --steps: must be a positive integer, got"),
    (["bench", "--sizes", "2"], 130, "dda bench: interrupted"),  # Ctrl-C
    (["tradeoff", "sliding_block", "--serial"], 130, "dda tradeoff: interrupted"),  # Ctrl-C
    (["tradeoff", "sliding_block", "-o", "a_file"], 2, "-o a_file: exists and is not a direc"),
    (["verify", "nosuchcase"], 2, "case(s): nosuchcase; the cases are al_rate, bolted, bonded,"),
]


@pytest.fixture(scope="module")
def prepared(tmp_path_factory) -> Path:
    """Scenes, a file, directories and run folders in several states (made once)."""
    root = tmp_path_factory.mktemp("inputs")
    here = Path.cwd()
    os.chdir(root)
    try:
        _prepare()
    finally:
        os.chdir(here)
    return root


@pytest.fixture
def workdir(prepared, monkeypatch) -> Path:
    """The prepared directory as working directory, ``read_only`` unwritable, Ctrl-C
    pressed in ``dda bench`` and ``dda tradeoff`` as soon as they start working."""
    monkeypatch.chdir(prepared)
    real_access = os.access
    monkeypatch.setattr(
        os, "access", lambda p, mode: False if Path(p).name == "read_only" else real_access(p, mode)
    )  # as on a read-only file system (root may write anywhere else)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("dda.bench.run.measure_in_subprocess", interrupted)
    monkeypatch.setattr("dda.tradeoff.runner.sweep", interrupted)
    return prepared


def _prepare() -> None:
    for name, text in SCENES.items():
        Path(name).write_text(text)
    Path("a_file").write_text("not a directory")
    Path("a_file.png").write_text("a picture")
    Path("contacts_000000.vtu").write_text("<VTKFile")
    Path("a_dir").mkdir()
    Path("read_only").mkdir()
    assert cli.main(["run", "ok.toml", "-o", "stopped", "-q", "--save-every", "1"]) == 0
    Path("stopped/summary.json").write_text('{"status": "interrupted", "steps": 3}')
    assert cli.main(["run", "ok.toml", "-o", "paused", "-q", "--checkpoint-every", "2"]) == 0
    Path("paused/summary.json").write_text('{"status": "interrupted", "steps": 3}')
    dda.simulate(dda.load_scene(SMALL_SCENE), stop=lambda: True, checkpoints=_plan("paused"))
    assert cli.main(["run", "ok.toml", "-o", "damaged", "-q"]) == 0
    Path("damaged/summary.json").write_text('{"status": "running", "steps": 3}')
    Path("damaged/checkpoint.npz").write_bytes(b"PK\x03\x04 cut short")
    assert cli.main(["run", "ok.toml", "-o", "broken", "-q"]) == 0
    Path("broken/frames/blocks_000000.vtu").write_text("<VTKFile")


def _plan(folder: str):
    from dda.run.checkpoint import CheckpointPlan

    return CheckpointPlan(Path(folder, "checkpoint.npz"), None, None)


def _listing(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in sorted(root.rglob("*"))}


@pytest.mark.parametrize(
    ("argv", "code", "message"), REFUSED, ids=[" ".join(a) for a, _, _ in REFUSED]
)
def test_refused_input_exits_with_one_line_naming_it(workdir, capsys, argv, code, message):
    capsys.readouterr()
    before = _listing(workdir)
    assert cli.main(argv) == code
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line]
    if code == 2:
        assert len(lines) == 1, captured.err
    assert message.format(d=workdir) in lines[-1]  # (after progress lines when interrupted)
    assert not re.search(r"<[a-z]+>:", lines[-1])  # no placeholder such as <file>: or <toml>:
    assert "Traceback" not in captured.err + captured.out
    assert _listing(workdir) == before  # nothing written, nothing removed


def test_an_unexpected_error_is_one_line_and_its_traceback_comes_with_v(
    tmp_path, monkeypatch, capsys
):
    def broken(*args, **kwargs):
        raise RuntimeError("something\nunforeseen")

    monkeypatch.setattr(dda, "simulate", broken)
    monkeypatch.chdir(tmp_path)
    Path("ok.toml").write_text(SMALL_SCENE)
    assert cli.main(["run", "ok.toml", "-o", "new", "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == (
        "dda run: internal error: RuntimeError: something unforeseen (dda -v run ... shows "
        "where); partial output in new (a new run into it needs --overwrite)"
    )
    with pytest.raises(RuntimeError, match="unforeseen"):
        cli.main(["-v", "run", "ok.toml", "-o", "newer", "-q"])


def test_load_scene_of_a_wrong_type_is_a_scene_error():
    with pytest.raises(dda.SceneError, match="^scene int: expected a path, TOML text or a"):
        dda.load_scene(123)


@pytest.mark.parametrize("text", ["", "  "])
def test_an_empty_scene_text_is_said_to_be_empty(text):
    """Was read as the path "." ("is a directory, not a scene file")."""
    with pytest.raises(dda.SceneError, match="^scene text: empty: give a path, TOML text"):
        dda.load_scene(text)


def test_render_takes_a_runs_frames_folder_for_the_run(tmp_path, monkeypatch, capsys):
    """``dda render OUT/frames`` drew nothing: "no written frame (any frame)"."""
    monkeypatch.chdir(tmp_path)
    Path("ok.toml").write_text(SMALL_SCENE)
    assert cli.main(["run", "ok.toml", "-o", "out", "-q", "--no-picture"]) == 0
    assert cli.main(["render", "out/frames", "-o", "from_frames.png"]) == 0
    assert Path("from_frames.png").stat().st_size > 10_000
