"""The ``dda`` command line and the progress bar."""

from __future__ import annotations

import io
import json
import logging
import os
import subprocess
import sys
import textwrap
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

import dda
from dda.commands import cli
from dda.io.fields import unit_name
from dda.result import Frame, Result
from dda.run.progress import ProgressBar

SMALL_SCENE = """\
title = "Block on a base"

[analysis]
mode = "dynamic"
time_step = 0.001
steps = 6
gravity = [0.0, -9.81]
save_every = 3

[materials.rock]
density = 2700.0
young = 5.0e9
poisson = 0.25

[joints.default]
friction_angle = 30.0

[[blocks]]
name = "base"
material = "rock"
fixed = true
vertices = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]]

[[blocks]]
name = "top"
material = "rock"
vertices = [[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]]
"""


def square_frame(step: int = 0, time: float = 0.0) -> Frame:
    vertices = [np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) + [x, 0.0]
                for x in (0.0, 1.5)]  # fmt: skip
    return Frame(
        time=time, step=step, names=("a", "b"), ids=np.array([0, 1]),
        centroids=np.array([[0.5, 0.5], [2.0, 0.5]]), rotations=np.zeros(2),
        velocities=np.zeros((2, 3)), stresses=np.array([[0.0, -1.0, 0.0], [1.0, -3.0, 0.5]]),
        displacements=np.zeros((2, 2)), vertices=vertices, areas=np.ones(2),
        fixed=np.array([True, False]),
    )  # fmt: skip


@pytest.fixture
def case(tmp_path, monkeypatch) -> Path:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "small.toml"
    path.write_text(SMALL_SCENE)
    return path


# ------------------------------------------------------------------ refused input


@pytest.mark.parametrize(
    "text",
    [SMALL_SCENE + "\nbogus_key = 1\n", "title = [unclosed\n"],
    ids=["unknown-key", "bad-toml"],
)
def test_run_refuses_a_bad_scene_and_writes_nothing(tmp_path, monkeypatch, capsys, text):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.toml").write_text(text)
    assert cli.main(["run", "bad.toml", "--quiet"]) == 2
    assert "bad.toml" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_run_refuses_a_missing_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "absent.toml"]) == 2
    assert "absent.toml" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_run_takes_a_shipped_case_by_name_from_any_folder(tmp_path, monkeypatch, capsys):
    """``dda run sliding_block`` runs the shipped scene (dda.cases) into out/run_sliding_block,
    from a folder without it; a name that is neither a file nor a shipped case is refused
    with the shipped names, exit 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "sliding_blok", "--quiet"]) == 2
    error = capsys.readouterr().err
    assert "sliding_blok" in error and "no shipped case" in error and "sliding_block" in error
    assert list(tmp_path.iterdir()) == []
    assert cli.main(["run", "sliding_block", "--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "run_sliding_block" / "summary.json").read_text())
    assert summary["status"] == "finished"
    # a folder of the case's name (its own output, -o sliding_block) does not hide the
    # case: it was read as the scene ("is a directory, not a scene file", exit 2)
    assert cli.main(["run", "sliding_block", "-o", "sliding_block", "--quiet"]) == 0
    assert cli.main(["run", "sliding_block", "-o", "sliding_block", "--quiet", "--overwrite"]) == 0


@pytest.mark.parametrize(
    ("variable", "value", "message"),
    [
        ("DDA_THREADS", "0", "DDA_THREADS='0'"),
        ("DDA_THREADS", "two", "DDA_THREADS='two'"),
        ("DDA_THREADS", "-1", "DDA_THREADS='-1'"),
        ("DDA_SOLVER", "super-lu", "DDA_SOLVER='super-lu': expected pardiso or superlu"),
        ("DDA_SOLVER", "mumps", "DDA_SOLVER='mumps': expected pardiso or superlu"),
        ("DDA_SYSTEMS", "band", "DDA_SYSTEMS='band': expected sparse"),
        ("DDA_NO_NUMBA", "true", "DDA_NO_NUMBA='true': expected 0 or 1"),  # was the kernels
    ],
)
def test_run_refuses_a_bad_solver_setting_and_writes_nothing(
    tmp_path, monkeypatch, capsys, variable, value, message
):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(variable, value)
    (tmp_path / "ok.toml").write_text(SMALL_SCENE)
    assert cli.main(["run", "ok.toml", "--quiet"]) == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.toml"]


# ------------------------------------------------------------------ dda run, engine replaced


def test_run_failure_keeps_partial_output_and_exits_3(case, monkeypatch, capsys):
    def failing(scene, progress=False, on_frame=None, **options):
        on_frame(square_frame(0))
        on_frame(square_frame(3, 0.003))
        raise dda.SimulationError("step 4 at t = 0.004: contact did not settle")

    monkeypatch.setattr(dda, "simulate", failing)
    assert cli.main(["run", str(case), "-o", "out", "--quiet"]) == 3
    assert "did not settle" in capsys.readouterr().err
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "failed" and "did not settle" in summary["error"]
    assert summary["steps"] == 3 and summary["frames_written"] == 2
    assert Path("out/blocks.pvd").is_file() and Path("out/history.csv").is_file()


def test_an_engine_error_marks_the_run_failed_in_one_line(case, monkeypatch, capsys):
    """An error the engine did not expect (a density of 1e-200 kg/m³ underflowed the
    equilibrium start's products to 0: ZeroDivisionError) left no summary.json and the
    traceback's last line, exit 1: now the summary says "failed" and why, exit 1."""

    def failing(scene, progress=False, on_frame=None, **options):
        on_frame(square_frame(0))
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(dda, "simulate", failing)
    assert cli.main(["run", str(case), "-o", "out", "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("dda run: internal error: ZeroDivisionError: float division by zero")
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "failed"
    assert summary["error"] == "internal error: ZeroDivisionError: float division by zero"
    assert summary["frames_written"] == 1 and Path("out/blocks.pvd").is_file()


def test_a_python_warning_is_one_line_without_its_source_line():
    """numpy's RuntimeWarnings of a run of absurd numbers showed their source paths and
    lines (``damping.py:57 ... symmetric = inverse @ ...``)."""
    text = cli._one_line_warning(
        "overflow encountered\nin matmul", RuntimeWarning, "/x/dda/effects/damping.py", 57,
        "symmetric = inverse @ stiffness",
    )  # fmt: skip
    assert text == "dda: warning: RuntimeWarning: overflow encountered in matmul (damping.py:57)\n"


def test_run_passes_options_to_the_engine(case, monkeypatch, capsys):
    seen = {}

    def fake(scene, progress=False, on_frame=None, **options):
        seen.update(save_every=scene.analysis.save_every, progress=progress)
        seen.update(keep_frames=options["keep_frames"], stop=callable(options["stop"]))
        frames = [square_frame(0), square_frame(7, 0.007)]
        for frame in frames:
            on_frame(frame)
        return Result(
            frames=frames,
            summary={
                "steps": 7,
                "time": 0.007,
                "wall_seconds": 0.1,
                "max_penetration": 1e-7,
                "status": "finished",
            },
        )

    monkeypatch.setattr(dda, "simulate", fake)
    assert cli.main(["run", str(case), "--save-every", "7"]) == 0
    assert seen == {"save_every": 7, "progress": True, "keep_frames": False, "stop": True}
    out = capsys.readouterr().out
    assert "7 steps" in out and "out/run_small" in out.replace("\\", "/")
    assert Path("out/run_small/final.png").is_file()


# ------------------------------------------------------------------ dda run, real engine


def test_run_writes_all_outputs(case, capsys):
    assert cli.main(["run", str(case), "-o", "result"]) == 0
    out = Path("result")
    assert (out / "blocks.pvd").is_file() and (out / "contacts.pvd").is_file()
    assert len(list((out / "frames").glob("blocks_*.vtu"))) == 3  # steps 0, 3, 6
    assert len(list((out / "frames").glob("contacts_*.vtu"))) == 3
    assert (out / "history.csv").read_text().count("\n") == 1 + 3 * 2
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["steps"] == 6
    assert summary["friction_dissipation"] == 0.0
    assert (out / "final.png").stat().st_size > 1000
    assert "Block on a base" in capsys.readouterr().out


# what a run imports (start-up: the libraries a run does not use stay unloaded)
HEAVY = ("matplotlib", "pyvista", "vtk", "dask", "distributed", "skfem", "numba", "verify")
IMPORTED = (
    "import sys; from dda.commands.cli import main; watch = set(sys.argv[1].split(',')); "
    "code = main(sys.argv[2:]); "
    "print(code, *sorted({m.split('.')[0] for m in sys.modules} & watch))"
)


def imported_by_a_run(case: Path, *options: str, threads: str = "1") -> list[str]:
    """``dda run CASE`` in a new interpreter (``DDA_THREADS=threads``): its exit code,
    then which of HEAVY it imported."""
    argv = [",".join(HEAVY), "run", str(case), "-o", "result", "-q", *options]
    env = {**os.environ, "DDA_THREADS": threads}
    command = [sys.executable, "-c", IMPORTED, *argv]
    out = subprocess.run(command, capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_a_run_without_a_picture_imports_no_plotting_or_cluster_library(case):
    """Two blocks, six steps: no matplotlib, no VTK, no dask, no numba (too little work)."""
    assert imported_by_a_run(case, "--no-picture") == ["0"]
    assert not Path("result/final.png").exists() and Path("result/blocks.pvd").is_file()


def test_a_run_draws_its_picture_with_matplotlib_alone(case):
    assert imported_by_a_run(case) == ["0", "matplotlib"]
    assert Path("result/final.png").stat().st_size > 1000


def test_a_run_with_a_second_core_leaves_matplotlib_to_its_picture_helper(case):
    assert imported_by_a_run(case, threads="2") == ["0"]
    assert Path("result/final.png").stat().st_size > 1000


def test_run_and_render_do_not_load_the_plugin_commands(monkeypatch):
    def no_plugins(*args, **kwargs):
        raise AssertionError("plugins loaded")

    monkeypatch.setattr(cli, "load_plugins", no_plugins)
    assert cli.main(["run", "--help"]) == 0
    assert cli.main(["-v", "render", "--help"]) == 0
    with pytest.raises(AssertionError, match="plugins loaded"):
        cli.main(["fos", "--help"])


def test_the_run_paragraph_tells_the_friction_dissipation_only_when_there_is_some():
    base = {"title": "t", "steps": 2, "time": 0.2, "wall_seconds": 1.0, "iterations": 9}
    quiet = cli.summary_paragraph({**base, "friction_dissipation": 0.0}, Path("out"))
    sliding = {**base, "friction_dissipation": 7.61e6}
    assert "Friction" not in quiet
    assert "Friction dissipated 7.61e+06 J." in cli.summary_paragraph(sliding, Path("out"))
    imperial = {**sliding, "units": {"length": "ft", "force": "lb"}, "max_penetration": 0.62}
    text = cli.summary_paragraph(imperial, Path("out"))
    assert "Friction dissipated 7.61e+06 lb·ft." in text and "penetration 0.62 ft." in text


def test_an_unknown_option_is_named_by_its_sub_command(capsys):
    """Was "dda: unrecognized arguments" for an option given to dda run."""
    assert cli.main(["run", "sliding_block", "--bogus"]) == 2
    assert capsys.readouterr().err == (
        "dda run: unrecognized arguments: --bogus (see dda run -h)\n"
    )
    assert cli.main(["--bogus"]) == 2
    assert capsys.readouterr().err.startswith("dda: unrecognized arguments: --bogus")


def test_the_run_paragraph_counts_in_the_singular_and_the_plural():
    base = {"title": "t", "steps": 2, "time": 0.2, "wall_seconds": 1.0}
    one = cli.summary_paragraph({**base, "stages_done": 1, "fracture_events": 1, "bolts": 1},
                                Path("out"))  # fmt: skip
    assert " 1 fracture event. 1 stage applied. 0 of 1 bolt broke." in one  # was "1 stages"
    two = cli.summary_paragraph({**base, "stages_done": 2, "fracture_events": 3, "bolts": 2},
                                Path("out"))  # fmt: skip
    assert " 3 fracture events. 2 stages applied. 0 of 2 bolts broke." in two
    single = {**base, "steps": 1, "iterations": 1, "newton_iterations": 1, "frames_written": 1}
    text = cli.summary_paragraph({**single, "start": "equilibrium", "start_newton_iterations": 1,
                                  "start_seconds": 0.1}, Path("out"))  # fmt: skip
    assert "finished after 1 step to" in text and "1 solve (1 Newton iteration)." in text
    assert "Equilibrium start: 1 Newton iteration, 0.1 s." in text  # was "1 Newton iterations"
    assert text.endswith("Output (1 frame): out")
    assert "after ? steps" in cli.summary_paragraph({"title": "t"}, Path("out"))


def test_the_run_paragraph_tells_the_newton_iterations_beside_the_solves():
    base = {"title": "t", "steps": 2, "time": 0.2, "wall_seconds": 1.0, "iterations": 9}
    assert "9 solves (4 Newton iterations)." in cli.summary_paragraph(
        {**base, "newton_iterations": 4}, Path("out")
    )
    assert "9 solves." in cli.summary_paragraph(base, Path("out"))  # an older summary.json


def test_the_run_paragraph_tells_how_the_run_started():
    """The equilibrium start's cost; a start that did not settle is never silent."""
    from dda.run.simulation import UNSETTLED_START

    base = {"title": "t", "steps": 2, "time": 0.2, "wall_seconds": 1.0, "iterations": 9}
    loaded = {**base, "start": "equilibrium", "start_newton_iterations": 12}
    text = cli.summary_paragraph({**loaded, "start_seconds": 0.0312}, Path("out"))
    assert "Equilibrium start: 12 Newton iterations, 0.0312 s." in text
    assert "continuation" not in text
    compiled = {**loaded, "start_seconds": 47.3, "start_compile_seconds": 46.8}
    text = cli.summary_paragraph(compiled, Path("out"))  # the first run after installing
    assert "Equilibrium start: 12 Newton iterations, 47.3 s (46.8 s of it compiling" in text
    by_continuation = {**loaded, "start_seconds": 0.0312, "start_method": "continuation"}
    text = cli.summary_paragraph(by_continuation, Path("out"))
    assert "interior-point solve did not settle: it went on by continuation" in text
    fallen_back = cli.summary_paragraph({**base, "start": UNSETTLED_START}, Path("out"))
    assert "The equilibrium start did not settle: the run started unloaded." in fallen_back
    spent = {**base, "start": UNSETTLED_START, "start_newton_iterations": 5463,
             "start_seconds": 824.2}  # fmt: skip
    assert (
        "The equilibrium start did not settle after 5463 Newton iterations and 824 s: the "
        "run started unloaded." in cli.summary_paragraph(spent, Path("out"))
    )
    assert "start" not in cli.summary_paragraph({**base, "start": "unloaded"}, Path("out"))


# ------------------------------------------------------------------ dda render


def test_render_a_written_run(tmp_path, capsys):
    from dda.io import RunWriter

    writer = RunWriter(tmp_path / "run", image=False)
    writer.add_frame(square_frame(0))
    writer.add_frame(square_frame(4, 0.4))
    png = tmp_path / "pic.png"
    args = ["render", str(tmp_path / "run"), "-o", str(png), "--scalars", "von_mises"]
    assert cli.main([*args, "--size", "300", "200"]) == 0
    assert png.stat().st_size > 1000
    vtu = tmp_path / "run" / "frames" / "blocks_000000.vtu"
    assert cli.main(["render", str(vtu), "--size", "300", "200"]) == 0
    assert (tmp_path / "run" / "blocks_000000_syy.png").is_file()
    assert cli.main(["render", str(tmp_path / "missing")]) == 2
    capsys.readouterr()
    assert cli.main(["render", str(tmp_path / "run"), "--step", "7"]) == 2
    assert "no written frame (step 7); written steps: 0, 4" in capsys.readouterr().err
    assert cli.main(["render", str(vtu), "--step", "4"]) == 2  # was drawn at step 0, unsaid
    assert "--step 4: a VTU file is one frame" in capsys.readouterr().err
    huge = ["render", str(tmp_path / "run"), "--size", "100000", "100000"]
    assert cli.main(huge) == 2  # was a MemoryError of 40 GB, exit 1
    assert "at most 16384 pixels" in capsys.readouterr().err
    deeper = tmp_path / "new" / "dir" / "pic.png"  # a missing folder is made
    small = ["--size", "300", "200"]
    assert cli.main(["render", str(tmp_path / "run"), "-o", str(deeper), *small]) == 0
    assert deeper.stat().st_size > 1000
    capsys.readouterr()
    jpeg = tmp_path / "pic.jpg"  # was PNG bytes under a .jpg name
    assert cli.main(["render", str(tmp_path / "run"), "-o", str(jpeg), *small]) == 2
    assert capsys.readouterr().err == (
        f"dda render: -o {jpeg}: a picture is written as .png, not .jpg; give a file name "
        "ending in .png\n"
    )
    assert not jpeg.exists()
    bare = tmp_path / "pic"  # was "a picture is written as .png, not no suffix"
    assert cli.main(["render", str(tmp_path / "run"), "-o", str(bare), *small]) == 2
    assert capsys.readouterr().err == (
        f"dda render: -o {bare}: a picture is written as .png; give a file name ending in .png\n"
    )
    assert not bare.exists()


def test_a_frame_read_without_its_run_is_labelled_by_dimension(tmp_path, monkeypatch, caplog):
    """A VTU holds numbers only: copied out of its run folder (no summary.json), its
    picture says force/length², not Pa that an ft/lb run's numbers are not in."""
    import shutil

    import dda.io.images
    from dda.io import RunWriter

    writer = RunWriter(tmp_path / "run", image=False)
    writer.add_frame(square_frame(0))
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(tmp_path / "run" / "frames" / "blocks_000000.vtu", alone)
    given = {}
    monkeypatch.setattr(dda.io.images, "render_frame", lambda *a, **k: given.update(k))
    with caplog.at_level(logging.WARNING):
        assert cli.main(["render", str(alone / "blocks_000000.vtu")]) == 0
    # nor its contacts file: drawn without contact forces, and said
    assert "no contacts file beside it (contacts_000000.vtu)" in caplog.text
    assert given["units"] == {"length": "length", "force": "force", "time": "time"}
    assert unit_name("stress", given["units"]) == "force/length²"
    assert "is not there" in caplog.text and "units are unknown" in caplog.text
    caplog.clear()  # a summary.json that cannot be parsed is there, not "not there"
    (tmp_path / "run" / "summary.json").write_text("{")
    with caplog.at_level(logging.WARNING):
        assert cli.main(["render", str(tmp_path / "run")]) == 0
    assert "summary.json of" in caplog.text and "cannot be read" in caplog.text


# ------------------------------------------------------------------ plugins


def test_plugins_register_and_a_missing_module_is_skipped(tmp_path, monkeypatch, caplog):
    (tmp_path / "hello_plugin.py").write_text(
        textwrap.dedent(
            """
            def register(subparsers):
                parser = subparsers.add_parser("hello")
                parser.set_defaults(func=lambda args: 7)
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    entries = [
        metadata.EntryPoint("ghost", "no_such_module_for_dda:register", cli.PLUGIN_GROUP),
        metadata.EntryPoint("hello", "hello_plugin:register", cli.PLUGIN_GROUP),
        metadata.EntryPoint("clash", "hello_plugin:register", cli.PLUGIN_GROUP),
    ]
    monkeypatch.setattr(cli.metadata, "entry_points", lambda group: entries)
    with caplog.at_level(logging.WARNING, logger="dda.commands.cli"):
        assert cli.main(["hello"]) == 7
    messages = " ".join(r.getMessage() for r in caplog.records)
    assert "ghost" in messages and "clash" in messages


def test_the_cli_does_not_import_verify():
    code = (
        "import dda.commands.cli, sys; print(any(m.split('.')[0] == 'verify' for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "False", out.stderr


# ------------------------------------------------------------------ progress bar


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_in_a_log_writes_about_every_five_percent():
    stream = io.StringIO()
    bar = ProgressBar(total=2.0, label="run", stream=stream)
    for k in range(1, 1001):
        bar.update(2.0 * k / 1000, step=k, time=0.001 * k)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert 20 <= len(lines) <= 22
    assert "\r" not in stream.getvalue()
    assert lines[-1].startswith("run [") and "100.0%" in lines[-1] and "step=1000" in lines[-1]


def test_the_eta_leaves_out_the_compiling_of_kernels(monkeypatch):
    """10 s into a run at 1 %, 9 of them compiling kernels: the ETA is 99 x 1 s, not
    99 x 10 s (the first run after installing read 2:56:11 at its first step)."""
    from dda.run import progress

    clock, compiled = [100.0], [0.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: clock[0])
    bar = ProgressBar(1.0, label="run", stream=io.StringIO(), aside=lambda: compiled[0])
    clock[0], compiled[0] = 110.0, 9.0
    bar.update(0.01, step=1)
    assert " 10.0s eta 1:39 " in bar.text()  # 99 s
    plain = ProgressBar(1.0, label="run", stream=io.StringIO())
    plain._start = 100.0
    plain.update(0.01)
    assert " eta 16:30" in plain.text()  # 990 s: without the clock, all of it


def test_an_error_ends_the_bar_without_a_last_line():
    stream = io.StringIO()
    with pytest.raises(OSError), ProgressBar(total=10, label="movie", stream=stream) as bar:
        bar.update(0)
        raise OSError("broken pipe")
    assert stream.getvalue().count("movie [") == 1  # the first line only, no closing one


def test_progress_bar_on_a_terminal_redraws_in_place():
    stream = FakeTerminal()
    with ProgressBar(total=10, label="run", stream=stream) as bar:
        for k in range(11):
            bar.update(k, contacts=3)
    text = stream.getvalue()
    assert text.startswith("\r") and text.endswith("\n") and text.count("\n") == 1
    assert "100.0%" in text.rsplit("\r", 1)[-1]


def test_progress_bar_on_a_narrow_terminal_fits_its_width(monkeypatch):
    """A line wider than the terminal would wrap, and each redraw leave a row behind."""
    monkeypatch.setenv("COLUMNS", "60")
    stream = FakeTerminal()
    with ProgressBar(total=10, label="paper_uniaxial_fracture", stream=stream) as bar:
        for k in range(11):
            bar.update(k, step=k, time=0.001 * k, contacts=1234, iterations=5, broken=17)
    redraws = stream.getvalue().strip("\n").split("\r")[1:]
    assert len(redraws) >= 2 and max(len(line) for line in redraws) <= 59


def test_the_run_paragraph_tells_the_cut_steps():
    base = {"title": "t", "steps": 78, "time": 2.0, "wall_seconds": 1.0}
    text = cli.summary_paragraph({**base, "cut_steps": 75, "smallest_cut_time_step": 0.0133},
                                 Path("out"))  # fmt: skip
    assert "Δt cut at 75 steps (to 0.0133 s at the least)." in text
    assert "cut" not in cli.summary_paragraph({**base, "cut_steps": 0}, Path("out"))


def test_run_prints_the_run_warnings_quiet_or_not(tmp_path, monkeypatch, capsys):
    """The sliding block at Δt = 1 s: its steps are cut at most steps (it slides off its
    slab and falls), which `dda run -q` says on stderr although it prints no summary."""
    monkeypatch.chdir(tmp_path)
    scene = (Path(dda.__file__).parents[1] / "cases" / "sliding_block.toml").read_text()
    scene = scene.replace("time_step = 0.01", "time_step = 1.0").replace(
        "duration = 1.0", "duration = 2.0"
    )
    (tmp_path / "big_step.toml").write_text(scene)
    assert cli.main(["run", "big_step.toml", "-q", "--no-picture", "-o", "out"]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "dda run: warning: the time step was cut at" in captured.err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["warnings"] and summary["warnings"][0].startswith("the time step was cut")


def test_the_process_s_own_command_line_ignores_ctrl_c_once_the_command_ends():
    """A Ctrl-C that came as `dda fos` ended broke dask's clean-up at exit with a
    traceback (its atexit hook closing the cluster); a call with arguments (a test's, a
    script's) leaves the handler alone."""
    probe = (
        "import signal, sys\n"
        "from dda.commands import cli\n"
        "cli.main(['cases'])\n"
        "before = signal.getsignal(signal.SIGINT) is signal.SIG_IGN\n"
        "sys.argv = ['dda', 'cases']\n"
        "cli.main()\n"
        "print(before, signal.getsignal(signal.SIGINT) is signal.SIG_IGN)\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1] == "False True"
