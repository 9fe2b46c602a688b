"""``dda tradeoff`` against a real cluster: a ``dask scheduler`` and a ``dask worker``
started as their own processes in other folders, reached through the scheduler file.
The scene file exists only where the client runs: the workers get scene dicts."""

from __future__ import annotations

import csv
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("dask.distributed")

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 120.0


def start(command: list[str], cwd: Path, log: Path) -> subprocess.Popen:
    cwd.mkdir(parents=True, exist_ok=True)
    with log.open("w") as stream:
        return subprocess.Popen(command, cwd=cwd, stdout=stream, stderr=subprocess.STDOUT)


def wait_for(path: Path, process: subprocess.Popen) -> None:
    deadline = time.monotonic() + TIMEOUT
    while not path.exists():
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"the scheduler did not start (exit {process.poll()})")
        time.sleep(0.2)


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and a one-thread worker, each in its own folder; the scheduler file."""
    dask = shutil.which("dask", path=str(Path(sys.executable).parent)) or "dask"
    address_file = tmp_path / "scheduler.json"
    scheduler = start(
        [dask, "scheduler", "--scheduler-file", str(address_file), "--host", "127.0.0.1",
         "--port", "0", "--dashboard-address", ":0"],
        tmp_path / "scheduler_dir", tmp_path / "scheduler.log",
    )  # fmt: skip
    processes = [scheduler]
    try:
        wait_for(address_file, scheduler)
        processes.append(
            start(
                [
                    dask,
                    "worker",
                    "--scheduler-file",
                    str(address_file),
                    "--nthreads",
                    "1",
                    "--nworkers",
                    "1",
                    "--host",
                    "127.0.0.1",
                    "--dashboard-address",
                    ":0",
                ],
                tmp_path / "worker_dir",
                tmp_path / "worker.log",
            )  # fmt: skip
        )
        yield address_file
    finally:
        for process in reversed(processes):
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()


def test_a_scene_file_sweep_runs_on_a_scheduler_and_worker_started_elsewhere(tmp_path, cluster):
    client_dir = tmp_path / "client_dir"
    client_dir.mkdir()
    scene = client_dir / "my_scene.toml"
    scene.write_text((ROOT / "cases" / "sliding_block.toml").read_text())
    grid = "method=penalty;penalty=1;time_step=0.02;ratio=0.01"
    out = subprocess.run(
        [sys.executable, "-m", "dda", "tradeoff", "my_scene.toml", "--grid", grid,
         "--scheduler-file", str(cluster), "-o", "out"],
        cwd=client_dir, capture_output=True, text=True, timeout=TIMEOUT,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "INFO" not in out.stderr  # distributed's logs at WARNING without -v
    with (client_dir / "out" / "my_scene.csv").open() as stream:
        (row,) = list(csv.DictReader(stream))
    assert row["status"] == "finished" and row["repeats"] == "3"
    assert len(row["seconds_all"].split()) == 3 and row["host"]
    assert float(row["error"]) < 1e-2  # against the fine run, itself a task of the worker
    assert not (tmp_path / "worker_dir" / "out").exists()
