"""Runs that survive: one run per output folder, signals, streamed outputs, checkpoints, resume.

The resumed runs are compared with uninterrupted ones bit for bit under
``DDA_SOLVER=superlu`` (SuperLU and LAPACK factorise deterministically;
docs/runs.md).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import dda
from dda.blocks import BlockSet
from dda.commands import cli
from dda.contact.contact_set import ContactSet
from dda.io.run_folder import RunFolder
from dda.io.run_writer import RunWriter
from dda.run.checkpoint import (
    CheckpointError,
    CheckpointPlan,
    capture,
    read_checkpoint,
    write_checkpoint,
)
from dda.run.simulation import shown_time
from tests.helpers import use_policy

ROOT = Path(__file__).resolve().parents[2]
SLOPE = ROOT / "cases" / "rock_slope.toml"


@pytest.fixture
def superlu(monkeypatch):
    """A deterministic sparse solver (PARDISO on two threads may not repeat to the bit)."""
    monkeypatch.setenv("DDA_SOLVER", "superlu")


def slope_file(folder: Path, steps: int, save_every: int = 10) -> Path:
    """The rock slope case (81 blocks, contacts that open, close and slide) run for ``steps``."""
    text = SLOPE.read_text().replace("duration = 2.0", f"steps = {steps}")
    text = text.replace("save_every = 25", f"save_every = {save_every}")
    path = folder / "slope.toml"
    path.write_text(text)
    return path


def slope_scene(steps: int) -> dda.Scene:
    scene = dda.load_scene(SLOPE)
    analysis = dataclasses.replace(scene.analysis, steps=steps, duration=None)
    return dataclasses.replace(scene, analysis=analysis)


def stop_after(steps: int):
    """A ``stop`` callable that asks the run to stop once ``steps`` steps are done."""
    asked = {"count": 0}

    def stop() -> bool:
        asked["count"] += 1
        return asked["count"] > steps

    return stop


def assert_same_run(a: dda.Result, b: dda.Result) -> None:
    for name in a.history:
        np.testing.assert_array_equal(a.history[name], b.history[name], err_msg=name)
    for name in ("centroids", "velocities", "stresses", "displacements", "rotations"):
        np.testing.assert_array_equal(getattr(a.final, name), getattr(b.final, name))
    keys = ("steps", "time", "iterations", "newton_iterations", "factorisations", "cut_steps")
    for key in (*keys, "max_penetration"):
        assert a.summary[key] == b.summary[key], key


# ------------------------------------------------------------------ engine: resume


@pytest.mark.parametrize("gamma", [1.0, 0.9])
def test_a_resumed_run_repeats_the_uninterrupted_one_bit_for_bit(tmp_path, superlu, gamma):
    """Stopped at step 40 of 80 and resumed from its checkpoint, the rock slope ends
    exactly as the run that went through: same history, same final state, same counts.
    (Without the linear solver's cache in the checkpoint the two differed by 6e-11.)
    With ``newmark_gamma`` below 1 the velocity update uses the last step's
    acceleration, which the checkpoint carries too."""
    scene = slope_scene(80)
    analysis = dataclasses.replace(scene.analysis, newmark_gamma=gamma)
    scene = dataclasses.replace(scene, analysis=analysis)
    whole = dda.simulate(scene)
    plan = CheckpointPlan(tmp_path / "c.npz", every_steps=None, every_seconds=None)
    first = dda.simulate(scene, stop=stop_after(40), checkpoints=plan)
    assert first.summary["status"] == "interrupted" and first.summary["steps"] == 40
    checkpoint = read_checkpoint(tmp_path / "c.npz")
    # the checkpoint keeps the steps' exact sum; the summary shows it without round-off
    assert (checkpoint.step, shown_time(checkpoint.time)) == (40, first.summary["time"])
    rest = dda.simulate(scene, resume=checkpoint)
    assert rest.frames[0].step == 40 and rest.summary["status"] == "finished"
    assert_same_run(whole, rest)


def test_a_run_resumed_after_a_block_broke_keeps_its_fragments_loads_and_events(tmp_path):
    """Fracture replaces the block set and moves the load points to the fragments: the
    checkpoint after it (step 4; the rock broke at step 2) carries all of that."""
    from tests.fracture.test_run import platen_scene

    scene = dda.load_scene(platen_scene(1.02, steps=8))
    whole = dda.simulate(scene)
    plan = CheckpointPlan(tmp_path / "c.npz", every_steps=None, every_seconds=None)
    dda.simulate(scene, stop=stop_after(4), checkpoints=plan)
    rest = dda.simulate(scene, resume=read_checkpoint(tmp_path / "c.npz"))
    assert [e.step for e in whole.fracture_events] == [2]
    assert rest.fracture_events == whole.fracture_events
    assert rest.final.names == whole.final.names and len(whole.final.names) == 6
    np.testing.assert_array_equal(rest.final.ids, whole.final.ids)
    assert_same_run(whole, rest)


def test_checkpoints_leave_the_run_unchanged(tmp_path, superlu):
    scene = slope_scene(30)
    plan = CheckpointPlan(tmp_path / "c.npz", every_steps=7, every_seconds=None)
    assert_same_run(dda.simulate(scene), dda.simulate(scene, checkpoints=plan))
    assert plan.written == 4 and read_checkpoint(tmp_path / "c.npz").step == 28


@pytest.mark.parametrize("systems", ["band", "sparse"])
def test_a_checkpoint_holds_every_field_of_the_run_state(tmp_path, systems, monkeypatch):
    """Every attribute of the run (but the model) and every field of the block and
    contact sets is saved, found by walking them: a new field needs no change. The
    linear cache's state is saved too: the band systems' block numbering, and the
    sparse systems' factorised matrix."""
    from dda.run import simulation

    if systems == "sparse":
        use_policy(monkeypatch, band_work=0.0)
    state = simulation._Run(dda.run.simulation.build(slope_scene(5)))
    simulation._advance(state)
    checkpoint = capture(state)
    keys = set(checkpoint.arrays) | set(checkpoint.meta["state"])
    assert {f"run/{name}" for name in vars(state)} - keys == {"run/model", "run/linear"}
    for kind, prefix in ((BlockSet, "run/blocks"), (ContactSet, "run/contacts")):
        saved = {k.split("/")[2] for k in keys if k.startswith(prefix + "/")}
        assert saved == {f.name for f in dataclasses.fields(kind)}
    assert len(state.contacts) > 0 and "run/contacts/normal_multiplier" in checkpoint.arrays
    if systems == "sparse" or not dda.jit.numba_enabled():
        assert "solver/factored/data" in checkpoint.arrays  # the linear cache's matrix
    else:
        assert "solver/cache/band/position" in checkpoint.arrays  # the band numbering


def test_a_checkpoint_of_another_scene_or_version_is_refused(tmp_path):
    scene = slope_scene(3)
    plan = CheckpointPlan(tmp_path / "c.npz", None, None)
    dda.simulate(scene, stop=stop_after(2), checkpoints=plan)
    checkpoint = read_checkpoint(tmp_path / "c.npz")
    other = dataclasses.replace(
        scene, analysis=dataclasses.replace(scene.analysis, gravity=(0, -1))
    )
    with pytest.raises(CheckpointError, match=r"c\.npz: written for another scene \(analysis"):
        dda.simulate(other, resume=checkpoint)
    longer = dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, save_every=1))
    dda.simulate(longer, resume=checkpoint)  # how often frames are kept may change
    extra = dataclasses.replace(checkpoint, arrays={**checkpoint.arrays, "run/contacts/new": 0})
    with pytest.raises(CheckpointError, match="another version of dda.*has extra"):
        dda.simulate(scene, resume=extra)
    arrays = {k: v for k, v in checkpoint.arrays.items() if k != "run/blocks/velocity"}
    with pytest.raises(CheckpointError, match="another version of dda.*lacks"):
        dda.simulate(scene, resume=dataclasses.replace(checkpoint, arrays=arrays))
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(CheckpointError, match="bad.npz: not a dda checkpoint") as caught:
        read_checkpoint(tmp_path / "bad.npz")
    assert "pickle" not in str(caught.value)  # numpy's advice to load it unsafely


def test_a_checkpoint_damaged_inside_a_valid_zip_is_refused(tmp_path):
    """Arrays of the wrong length or not finite (bits changed before the zip's checksums
    were made) are refused at the resume, not met as an IndexError or a non-finite
    step later."""
    scene = slope_scene(3)
    plan = CheckpointPlan(tmp_path / "c.npz", None, None)
    dda.simulate(scene, stop=stop_after(2), checkpoints=plan)
    checkpoint = read_checkpoint(tmp_path / "c.npz")
    for key, damage in (
        ("run/blocks/ids", lambda a: a[:-1]),
        ("run/blocks/velocity", lambda a: np.where(a == a.flat[0], np.nan, a)),
        ("run/contacts/block_b", lambda a: a + 1000),
    ):
        arrays = {**checkpoint.arrays, key: damage(checkpoint.arrays[key])}
        with pytest.raises(CheckpointError, match=r"c\.npz: cannot restore the run's state"):
            dda.simulate(scene, resume=dataclasses.replace(checkpoint, arrays=arrays))
    write_checkpoint(tmp_path / "copy.npz", checkpoint)
    assert read_checkpoint(tmp_path / "copy.npz").step == 2


def test_two_runs_of_a_scene_repeat_to_the_bit(superlu):
    """The reproducibility promise of docs/runs.md, in one environment."""
    scene = slope_scene(40)
    assert_same_run(dda.simulate(scene), dda.simulate(scene))


def test_keep_frames_false_keeps_the_first_and_the_latest_frame():
    scene = dda.load_scene(SLOPE.read_text().replace("duration = 2.0", "steps = 30"))
    seen = []
    lean = dda.simulate(scene, keep_frames=False, on_frame=seen.append)
    full = dda.simulate(scene)
    assert [f.step for f in lean.frames] == [0, 30] and len(full.frames) == 3
    assert [f.step for f in seen] == [f.step for f in full.frames]
    np.testing.assert_array_equal(lean.final.centroids, full.final.centroids)


def test_the_step_limit_is_checked_before_and_during_a_run(monkeypatch):
    scene = slope_scene(5)
    capped = dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, max_steps=3))
    with pytest.raises(dda.SceneError, match="analysis.steps: 5 steps are more than"):
        dda.simulate(capped)
    monkeypatch.setattr(dda.run.simulation, "check_run_size", lambda scene: None)
    with pytest.raises(dda.SimulationError, match="step 3 .* reached analysis.max_steps = 3"):
        dda.simulate(capped)


# ------------------------------------------------------------------ dda run: the folder


def test_a_folder_in_use_is_refused_and_left_alone(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 3)
    with RunFolder("out") as holder:
        holder.claim()
        assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 2
        assert cli.main(["run", str(scene), "-o", "out", "-q", "--overwrite"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and f"-o out: in use by run {holder.run_id} (process" in err[0]
    assert sorted(p.name for p in Path("out").iterdir()) == ["frames", "run.lock"]


def test_a_finished_run_is_kept_unless_overwritten(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 3)
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 0
    first = json.loads(Path("out/summary.json").read_text())
    assert first["status"] == "finished" and not Path("out/checkpoint.npz").exists()
    lock = json.loads(Path("out/run.lock").read_text())
    assert lock["run_id"] == first["run_id"] and lock["pid"] == os.getpid()
    read = cli._run_scene
    monkeypatch.setattr(cli, "_run_scene", lambda args: pytest.fail("the scene was read"))
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 2  # refused before the cut
    monkeypatch.setattr(cli, "_run_scene", read)
    err = capsys.readouterr().err.strip()
    assert (
        err == f"dda run: -o out: holds run {first['run_id']} (finished); --overwrite replaces it"
    )
    assert cli.main(["run", str(scene), "-o", "out", "-q", "--overwrite"]) == 0
    second = json.loads(Path("out/summary.json").read_text())
    assert second["run_id"] != first["run_id"] and second["status"] == "finished"
    assert cli.main(["run", str(scene), "-o", "out", "-q", "--resume"]) == 0
    assert "finished already; nothing to resume" in capsys.readouterr().out


def test_resuming_a_finished_run_of_another_scene_is_refused(tmp_path, monkeypatch, capsys):
    """It said "the run finished already; nothing to resume" and exited 0, as if the
    folder held this scene's results; a run-control key (save_every) may still differ."""
    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 3)
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 0
    before = Path("out/summary.json").read_text()
    other = tmp_path / "other.toml"
    other.write_text(SLOPE.read_text().replace("duration = 2.0", "steps = 4"))
    capsys.readouterr()
    assert cli.main(["run", str(other), "-o", "out", "-q", "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "out/summary.json: the finished run there is of another scene (analysis differ" in err
    assert Path("out/summary.json").read_text() == before
    same = tmp_path / "same.toml"
    same.write_text(slope_file(tmp_path, 3, save_every=5).read_text())
    assert cli.main(["run", str(same), "-o", "out", "-q", "--resume"]) == 0
    assert "finished already; nothing to resume" in capsys.readouterr().out


# ------------------------------------------------------------------ dda run: signals


def test_sigterm_stops_after_the_step_and_resume_finishes_the_same_run(
    tmp_path, monkeypatch, capsys, superlu
):
    """SIGTERM (a real one, to this process) during the run: status "interrupted", exit
    143, a checkpoint of the step where it stopped; --resume then writes exactly the
    history.csv and summary numbers of a run that was never stopped."""
    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 60)
    assert cli.main(["run", str(scene), "-o", "whole", "-q"]) == 0
    add_frame = RunWriter.add_frame

    def add_and_signal(writer, frame):
        add_frame(writer, frame)
        if frame.step == 20:
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(RunWriter, "add_frame", add_and_signal)
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 143
    err = capsys.readouterr().err
    assert "SIGTERM: stopping after this step" in err and "--resume" in err
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["steps"] == 20
    assert read_checkpoint("out/checkpoint.npz").step == 20
    monkeypatch.setattr(RunWriter, "add_frame", add_frame)
    assert cli.main(["run", str(scene), "-o", "out", "-q", "--resume"]) == 0
    assert Path("out/history.csv").read_bytes() == Path("whole/history.csv").read_bytes()
    resumed, whole = (json.loads(Path(d, "summary.json").read_text()) for d in ("out", "whole"))
    assert resumed["resumed_from_step"] == 20 and resumed["frames_written"] == 7
    for key in ("steps", "time", "iterations", "newton_iterations", "factorisations"):
        assert resumed[key] == whole[key], key
    assert resumed["max_penetration"] == whole["max_penetration"]
    assert not Path("out/checkpoint.npz").exists()


def test_sigterm_during_the_equilibrium_start_stops_it(tmp_path, monkeypatch, capsys):
    """SIGTERM while the equilibrium start runs stops it after the solve under way (it
    went on for minutes on a large model): status "interrupted" before step 1, no
    checkpoint (a resumed run would skip the start), and the command to run again."""
    from dda.run import equilibrium_start
    from dda.run.simulation import INTERRUPTED_START

    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 20)
    solve = equilibrium_start._Limit.count

    def count_and_signal(limit, iterations):
        os.kill(os.getpid(), signal.SIGTERM)
        solve(limit, iterations)

    monkeypatch.setattr(equilibrium_start._Limit, "count", count_and_signal)
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 143
    err = capsys.readouterr().err
    assert "stopped during the equilibrium start, before step 1 (SIGTERM)" in err
    assert "--overwrite" in err and "--resume" not in err
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["steps"] == 0
    assert summary["start"] == INTERRUPTED_START and summary["start_newton_iterations"] > 0
    assert not Path("out/checkpoint.npz").exists()


def test_sigterm_during_an_interior_point_solve_stops_the_start_at_its_next_iteration(
    tmp_path, monkeypatch, capsys
):
    """SIGTERM in the middle of the start's interior-point solve (one solve took ~100 s on
    a 5,000-block model) stops the start after the iteration under way, not at the
    solve's end: the start's Newton iterations are the two spent."""
    from dda.run import equilibrium_start
    from dda.run.simulation import INTERRUPTED_START

    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 20)
    tell = equilibrium_start._Limit.tell

    def tell_and_signal(limit, under_way):
        if under_way == 2:
            os.kill(os.getpid(), signal.SIGTERM)
        tell(limit, under_way)

    monkeypatch.setattr(equilibrium_start._Limit, "tell", tell_and_signal)
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 143
    assert "stopped during the equilibrium start" in capsys.readouterr().err
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["start"] == INTERRUPTED_START and summary["start_newton_iterations"] == 2


def test_sigkill_leaves_a_readable_prefix_and_the_run_resumes(tmp_path, monkeypatch, superlu):
    """Killed (SIGKILL: nothing runs) mid-run: summary.json (status "running"), history.csv
    (whole frames) and the PVD indexes are readable, a new run is refused, --resume
    continues from the last checkpoint to the uninterrupted run's history."""
    monkeypatch.chdir(tmp_path)
    scene = slope_file(tmp_path, 100)
    command = [sys.executable, "-m", "dda.commands.cli", "run", str(scene), "-o", "out", "-q"]
    process = subprocess.Popen([*command, "--checkpoint-every", "10"])
    try:
        summary = {}
        deadline = time.monotonic() + 120
        while summary.get("steps", 0) < 30 and process.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.02)
            try:
                summary = json.loads(Path("out/summary.json").read_text())
            except (OSError, ValueError):  # not written yet (never half: it is atomic)
                pass
        process.send_signal(signal.SIGKILL)
    finally:
        process.wait()
    assert process.returncode == -signal.SIGKILL
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "running" and 30 <= summary["steps"] < 100
    text = Path("out/history.csv").read_text()
    rows = list(csv.DictReader(text.splitlines()))
    assert text.endswith("\n") and len(rows) % 81 == 0 and len(rows) >= 81 * 4
    for index in ("blocks.pvd", "contacts.pvd"):
        files = [d.get("file") for d in ET.parse(Path("out", index)).getroot().iter("DataSet")]
        assert len(files) >= summary["frames_written"] and all(
            Path("out", f).is_file() for f in files
        )
    assert cli.main(["run", str(scene), "-o", "out", "-q"]) == 2  # stopped, not finished
    assert cli.main(["run", str(scene), "-o", "out", "-q", "--resume"]) == 0
    assert cli.main(["run", str(scene), "-o", "whole", "-q"]) == 0
    assert Path("out/history.csv").read_bytes() == Path("whole/history.csv").read_bytes()


# ------------------------------------------------------------------ engineering state


def engineering_scene(steps: int = 40) -> dict:
    """A stack on a floor that follows the ground, bolted to it, under water, with a block
    excavated and a bolt installed by stages, and measurements of all of it."""
    from tests.helpers import ROCK, G, rectangle

    t = np.linspace(0.0, 0.4, 41)
    return {
        "analysis": {"time_step": 0.01, "steps": steps, "gravity": [0.0, -G], "save_every": 7},
        "contact": {"penalty": 5e10, "tolerance": 1e-6},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": 25.0}},
        "blocks": [
            {"name": "floor", "material": "rock", "fixed": True,
             "vertices": rectangle(-3, -1, 4, 0)},
            *({"name": f"b{k}", "material": "rock", "vertices": rectangle(0, k, 1, k + 1)}
              for k in range(3)),
        ],
        "seismic": {"acceleration": np.column_stack([t, 8.0 * np.sin(12 * t)]).tolist()},
        "water": {"table": [[-3.0, 0.6], [4.0, 0.4]], "unit_weight": 9810.0},
        "bolts": [{"name": "b0", "start": [0.2, 0.5], "end": [2.0, -0.5], "stiffness": 1e7,
                   "capacity": 1.2e4}],
        "stages": [
            {"time": 0.1, "remove": ["b2"]},
            {"time": 0.2, "bolts": [{"name": "b1", "start": [0.8, 1.5], "end": [2.0, -0.5],
                                     "stiffness": 1e7, "pretension": 1e3}]},
        ],
        "measure": [{"name": "top", "point": [0.5, 1.5]},
                    {"name": "base", "blocks": ["b0", "floor"]},
                    {"name": "b0", "bolt": "b0"}, {"name": "b1", "bolt": "b1"}],
    }  # fmt: skip


def test_bolts_stages_ground_and_measurements_survive_a_checkpoint(tmp_path, superlu):
    """Stopped between the two stages (step 15, the first bolt broken, a block excavated,
    the ground moving) and resumed: the same run to the bit, measurements and events too."""
    scene = dda.load_scene(engineering_scene())
    whole = dda.simulate(scene)
    assert [e.bolt for e in whole.bolt_events] == ["b0"] and whole.bolt_events[0].step < 15
    assert whole.summary["stages_done"] == 2 and len(whole.final.names) == 3
    plan = CheckpointPlan(tmp_path / "c.npz", every_steps=None, every_seconds=None)
    first = dda.simulate(scene, stop=stop_after(15), checkpoints=plan)
    assert first.summary["stages_done"] == 1
    rest = dda.simulate(scene, resume=read_checkpoint(tmp_path / "c.npz"))
    assert_same_run(whole, rest)
    assert rest.bolt_events == whole.bolt_events
    assert rest.summary["excavated_energy"] == whole.summary["excavated_energy"]
    for name, values in whole.measurements.items():
        np.testing.assert_array_equal(rest.measurements[name], values, err_msg=name)


def test_a_resumed_run_writes_the_measurements_of_the_uninterrupted_one(tmp_path, superlu):
    """history_points.csv of a run stopped at step 17 (between frames: save_every 7) and
    resumed is byte for byte that of the run that went through."""
    import tomli_w

    path = tmp_path / "s.toml"
    path.write_text(tomli_w.dumps(engineering_scene(30)))
    assert cli.main(["run", str(path), "-o", str(tmp_path / "whole"), "-q"]) == 0
    scene = dda.load_scene(path)
    writer = RunWriter(tmp_path / "out", image=False, scene=scene)
    plan = CheckpointPlan(tmp_path / "out" / "checkpoint.npz", None, None)
    first = dda.simulate(scene, on_frame=writer.add_frame, stop=stop_after(17), checkpoints=plan)
    writer.finish(first, scene)
    assert cli.main(["run", str(path), "-o", str(tmp_path / "out"), "-q", "--resume"]) == 0
    for name in ("history_points.csv", "history.csv", "steps.csv"):
        assert (tmp_path / "out" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()


@pytest.mark.parametrize("damage", ["cut", "deleted", "points cut"])
def test_a_folder_whose_tables_end_before_the_checkpoint_is_not_resumed(tmp_path, capsys, damage):
    """A history.csv cut short (written without fsync before a power loss) or deleted was
    resumed silently, leaving a gap (rows 19-25 missing, or a history from step 30 only);
    now refused, exit 2, the folder as it was."""
    import tomli_w

    path = tmp_path / "s.toml"
    path.write_text(tomli_w.dumps(engineering_scene(30)))
    scene = dda.load_scene(path)
    out = tmp_path / "out"
    writer = RunWriter(out, image=False, scene=scene)
    plan = CheckpointPlan(out / "checkpoint.npz", None, None)
    first = dda.simulate(scene, on_frame=writer.add_frame, stop=stop_after(17), checkpoints=plan)
    writer.finish(first, scene)
    name = "history_points.csv" if damage == "points cut" else "history.csv"
    table = out / name
    if damage == "deleted":
        table.unlink()
    else:
        lines = table.read_text().splitlines(keepends=True)
        table.write_text("".join(lines[:4]))  # the header and steps 1-3 (points: 0-2)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    capsys.readouterr()
    assert cli.main(["run", str(path), "-o", str(out), "-q", "--resume"]) == 2
    err = capsys.readouterr().err
    assert f"{table}: " in err and "--overwrite runs it again" in err
    assert ("is missing" if damage == "deleted" else "ends at step ") in err
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before


def test_a_run_writes_its_energy_account_a_row_a_step(tmp_path):
    """The energy account was in Result.history alone: a command-line user could not
    check E ≤ E0 + W from the files. steps.csv holds every step's row, exact."""
    import csv

    import dda.cases

    out = tmp_path / "out"
    assert cli.main(["run", "sliding_block", "-o", str(out), "-q", "--no-picture"]) == 0
    rows = list(csv.DictReader((out / "steps.csv").open()))
    result = dda.simulate(dda.load_scene(dda.cases.folder() / "sliding_block.toml"))
    assert len(rows) == len(result.history["time"]) == result.summary["steps"]
    assert [int(r["step"]) for r in rows[:2]] == [1, 2]
    for name in ("total_energy", "external_work", "kinetic_energy", "time"):
        assert [float(r[name]) for r in rows] == result.history[name].tolist(), name
