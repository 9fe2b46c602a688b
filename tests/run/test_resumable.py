"""Every ``dda run`` is resumable: a checkpoint of the first state and one every minute of
wall time by default, so SIGKILL at any moment loses at most a minute of work."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dda.commands import cli
from dda.run.checkpoint import read_checkpoint
from tests.run.test_runs import slope_file


def checkpoint_step(path: Path) -> int:
    try:
        return read_checkpoint(path).step
    except ValueError:  # not written yet (never half: it is atomic)
        return -1


def test_the_default_cadence_is_a_minute_of_wall_time_and_the_first_state():
    args = cli.build_parser().parse_args(["run", "sliding_block"])
    assert args.checkpoint_minutes == 1.0


@pytest.mark.parametrize(
    ("options", "first_checkpoint"),
    [
        pytest.param([], 0, id="defaults"),
        pytest.param(["--checkpoint-minutes", "0.01"], 1, id="every 0.6 s", marks=pytest.mark.slow),
    ],
)
def test_sigkill_with_the_default_options_resumes_to_the_same_history(
    tmp_path,
    monkeypatch,
    options,
    first_checkpoint,
):
    """Killed before any step-count checkpoint: the run resumes from the first state (the
    defaults) or from the last checkpoint by wall time, to the uninterrupted history."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DDA_SOLVER", "superlu")  # deterministic factorisations
    scene = slope_file(tmp_path, 100)
    command = [sys.executable, "-m", "dda.commands.cli", "run", str(scene), "-o", "out", "-q"]
    process = subprocess.Popen([*command, *options])
    try:
        deadline = time.monotonic() + 120
        while checkpoint_step(Path("out/checkpoint.npz")) < first_checkpoint:
            assert time.monotonic() < deadline and process.poll() is None
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
    finally:
        process.wait()
    assert process.returncode == -signal.SIGKILL
    assert json.loads(Path("out/summary.json").read_text())["status"] == "running"
    step = read_checkpoint("out/checkpoint.npz").step
    assert step >= first_checkpoint
    assert cli.main(["run", str(scene), "-o", "out", "-q", "--resume"]) == 0
    assert json.loads(Path("out/summary.json").read_text())["resumed_from_step"] == step
    assert cli.main(["run", str(scene), "-o", "whole", "-q"]) == 0
    assert Path("out/history.csv").read_bytes() == Path("whole/history.csv").read_bytes()
