"""Ctrl-C in dda tradeoff keeps the finished settings; on dask the workers stay quiet."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from dda.commands.cli import main

TINY = "method=al;penalty=1;tolerance=1e-4;time_step=0.02,0.01,0.005;ratio=0.01"


def test_ctrl_c_in_a_serial_sweep_keeps_the_finished_settings(tmp_path, capsys, monkeypatch):
    import dda.tradeoff.runner as runner

    real, calls = runner.run_task, []

    def run_task(task):
        calls.append(task)
        if len(calls) == 3:
            raise KeyboardInterrupt  # Ctrl-C during the third setting
        return real(task)

    monkeypatch.setattr(runner, "run_task", run_task)
    argv = ["tradeoff", "sliding_block", "--grid", TINY, "-o", str(tmp_path), "--serial"]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "dda tradeoff: interrupted after 2 of 3 settings" in err
    assert f"wrote the 2 finished settings to {tmp_path}/sliding_block_partial.csv" in err
    rows = (tmp_path / "sliding_block_partial.csv").read_text().splitlines()
    assert len(rows) == 3 and "Traceback" not in err
    table = (tmp_path / "sliding_block_partial.md").read_text()  # the Pareto front of them
    assert "2 settings × 3 repeats = 6 runs; 0 settings stopped" in table
    assert "| augmented-lagrangian |" in table
    assert not (tmp_path / "sliding_block.csv").exists()  # the whole study's name: not done


@pytest.mark.slow
def test_ctrl_c_to_the_process_group_of_a_dask_sweep(tmp_path):
    """SIGINT to the whole process group (what a terminal's Ctrl-C sends) while the
    workers run: exit 130 within seconds, the finished settings kept, a few lines on
    stderr and no traceback (the workers ignore SIGINT; the client closes them)."""
    pytest.importorskip("dask.distributed")
    grid = "method=al,penalty;penalty=0.1,1,10;tolerance=1e-4;time_step=0.02,0.01,0.005"
    command = [sys.executable, "-m", "dda.commands.cli", "tradeoff", "sliding_block",
               "--grid", grid, "-o", str(tmp_path), "--workers", "2"]  # fmt: skip
    process = subprocess.Popen(
        command, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    lines = []
    deadline = time.monotonic() + 120
    while not any(line.startswith("[2/") for line in lines):  # two settings finished
        assert time.monotonic() < deadline
        lines.append(process.stderr.readline())
    os.killpg(process.pid, signal.SIGINT)
    err = "".join(lines) + process.communicate(timeout=60)[1]
    assert process.returncode == 130
    assert "Traceback" not in err and "interrupted after" in err
    assert len(err.splitlines()) <= 3 + 18  # the header, the progress lines, the outcome
    assert len((tmp_path / "sliding_block_partial.csv").read_text().splitlines()) >= 3
