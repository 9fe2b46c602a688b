"""Room on the output disk: the checkpoint's size is estimated (an upper bound of what a
run writes), a disk that cannot hold a run's start refuses it before anything is
written, and one that cannot hold the whole run gets a warning."""

from __future__ import annotations

import dataclasses
import logging
import os
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

import dda
from dda.cases import folder as cases_folder
from dda.commands.cli import main
from dda.io.disk_space import check_disk_space, disk_need
from dda.io.output_paths import OutputError
from dda.io.run_writer import RunWriter
from dda.run.checkpoint import CheckpointPlan
from dda.scene.limits import CHECKPOINT_BYTES_PER_STEP, estimated_checkpoint_bytes
from tests.run.test_runs import stop_after

SCENE = "sliding_block"  # 2 blocks, 100 steps


def shipped(name: str):
    return dda.load_scene(cases_folder() / f"{name}.toml")


def with_free(monkeypatch, free: int) -> None:
    """The disks report ``free`` bytes free (of 1 TB)."""
    fake = SimpleNamespace(total=10**12, used=10**12 - free, free=free)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: fake)


def test_every_checkpoint_of_a_run_is_within_its_estimate(tmp_path):
    """Measured, not assumed: the checkpoints of a run, every 50 steps, each below the
    estimate for its step and growing by at most CHECKPOINT_BYTES_PER_STEP a step."""
    scene = shipped("stack")
    analysis = dataclasses.replace(scene.analysis, steps=260, duration=None)
    scene = dataclasses.replace(scene, analysis=analysis)
    sizes = {}

    class Plan(CheckpointPlan):
        def write(self, run, wall_seconds):
            path = super().write(run, wall_seconds)
            sizes[run.step] = path.stat().st_size
            return path

    plan = Plan(tmp_path / "c.npz", every_steps=50, every_seconds=None, at_start=True)
    dda.simulate(scene, checkpoints=plan, keep_frames=False)
    assert sorted(sizes) == [0, 50, 100, 150, 200, 250]
    for step, size in sizes.items():
        assert size <= estimated_checkpoint_bytes(scene, step), step
    growth = (sizes[250] - sizes[50]) / 200
    assert 0 < growth <= CHECKPOINT_BYTES_PER_STEP


def test_the_estimate_is_logged_and_a_tight_disk_warned_about(tmp_path, monkeypatch, caplog):
    scene = shipped(SCENE)
    need = disk_need(scene)
    assert need.start < need.total
    caplog.set_level(logging.INFO, logger="dda.io.disk_space")
    with_free(monkeypatch, need.total + 1)
    check_disk_space(scene, tmp_path)
    assert [r.levelname for r in caplog.records] == ["INFO"]
    assert "a checkpoint of up to" in caplog.text
    caplog.clear()
    with_free(monkeypatch, need.total - 1)
    check_disk_space(scene, tmp_path)
    assert [r.levelname for r in caplog.records] == ["INFO", "WARNING"]
    with_free(monkeypatch, need.start - 1)
    with pytest.raises(OutputError, match="less than the run writes before its first step"):
        check_disk_space(scene, tmp_path)
    check_disk_space(scene, tmp_path, reclaimable=1)  # what --overwrite frees counts


def test_dda_run_refuses_a_disk_too_full_to_start_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with_free(monkeypatch, 1000)
    assert main(["run", SCENE, "-o", "deep/out", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dda run: -o deep/out: 1 kB free on its disk")
    assert os.listdir(tmp_path) == []


def test_overwrite_counts_the_space_of_the_run_it_replaces(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", SCENE, "-o", "out", "-q", "--no-picture"]) == 0
    old = sum(p.stat().st_size for p in Path("out").rglob("*") if p.is_file())
    start = disk_need(shipped(SCENE)).start
    assert old > start  # the earlier run frees enough for the start of this one
    with_free(monkeypatch, 0)
    assert main(["run", SCENE, "-o", "out", "-q", "--no-picture", "--overwrite"]) == 0


def test_a_refused_resume_leaves_the_run_as_it_was(tmp_path, monkeypatch, capsys):
    scene = shipped(SCENE)
    writer = RunWriter(tmp_path / "out", image=False, scene=scene)
    plan = CheckpointPlan(tmp_path / "out" / "checkpoint.npz", None, None)
    first = dda.simulate(scene, on_frame=writer.add_frame, stop=stop_after(37), checkpoints=plan)
    writer.finish(first, scene)
    before = {p: p.read_bytes() for p in (tmp_path / "out").rglob("*") if p.is_file()}
    with_free(monkeypatch, 10)
    assert main(["run", SCENE, "-o", str(tmp_path / "out"), "-q", "--resume"]) == 2
    assert "10 B free on its disk" in capsys.readouterr().err
    after = {p: p.read_bytes() for p in (tmp_path / "out").rglob("*") if p.is_file()}
    assert after == before
