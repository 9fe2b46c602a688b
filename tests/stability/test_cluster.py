"""``dda fos`` and ``dda ensemble`` on a real cluster (acceptance 5): a ``dask
scheduler`` and a ``dask worker`` started in other folders, reached through the
scheduler file, give the numbers of a local run; Ctrl-C keeps the finished trials and a
rerun reuses them."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import tomli_w

from tests.stability.test_ensemble import slope_ensemble
from tests.stability.test_fos import block_on_plane, phi_for
from tests.tradeoff.test_cluster import TIMEOUT, cluster  # noqa: F401 (the fixture)

pytest.importorskip("dask.distributed")


def dda(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "dda", *args], cwd=cwd, capture_output=True, text=True,
        timeout=TIMEOUT,
    )  # fmt: skip


def client_folder(tmp_path: Path, scene: dict) -> Path:
    folder = tmp_path / "client_dir"
    folder.mkdir(exist_ok=True)
    (folder / "slope.toml").write_bytes(tomli_w.dumps(scene).encode())
    return folder


def outcomes(path: Path, columns: tuple[str, ...]) -> list[tuple[str, ...]]:
    with path.open() as stream:
        rows = list(csv.DictReader(stream))
    return sorted(tuple(r[c] for c in columns) for r in rows)


@pytest.mark.slow  # 30 s: a scheduler, a worker and two searches, two ensembles
def test_fos_and_ensemble_on_a_cluster_match_the_local_run(tmp_path, cluster):  # noqa: F811
    folder = client_folder(tmp_path, block_on_plane(30.0, phi_for(30.0, 1.3)))
    local = dda(["fos", "slope.toml", "-o", "local", "--serial"], folder)
    remote = dda(["fos", "slope.toml", "-o", "remote", "--scheduler-file", str(cluster)], folder)
    assert local.returncode == 0 and remote.returncode == 0, remote.stderr
    assert json.loads((folder / "remote/fos.json").read_text()) == json.loads(
        (folder / "local/fos.json").read_text()
    )
    columns = ("factor", "failed", "speed", "steps")
    assert outcomes(folder / "remote/fos.csv", columns) == outcomes(
        folder / "local/fos.csv", columns
    )
    assert not (tmp_path / "worker_dir" / "remote").exists()

    (folder / "slope.toml").write_bytes(tomli_w.dumps(slope_ensemble(6)).encode())
    local = dda(["ensemble", "slope.toml", "-o", "elocal", "--serial"], folder)
    remote = dda(["ensemble", "slope.toml", "-o", "eremote", "--scheduler-file", str(cluster)],
                 folder)  # fmt: skip
    assert local.returncode == 0 and remote.returncode == 0, remote.stderr
    assert remote.stdout == local.stdout  # P(failure) and its interval
    columns = ("realisation", "joints.default.friction_angle", "failed", "speed")
    assert outcomes(folder / "eremote/ensemble.csv", columns) == outcomes(
        folder / "elocal/ensemble.csv", columns
    )


@pytest.mark.slow  # 35 s
def test_ctrl_c_keeps_the_finished_trials(tmp_path, cluster):  # noqa: F811
    """Trials of 2 s simulated at Δt = 0.01 (about a second each): interrupted after two
    rows, exit 130 with the rows on disk; the rerun reuses them and finishes."""
    scene = block_on_plane(30.0, phi_for(30.0, 1.3))
    scene["analysis"].update(time_step=0.01, duration=2.0)
    folder = client_folder(tmp_path, scene)
    command = [sys.executable, "-m", "dda", "fos", "slope.toml", "-o", "out",
               "--scheduler-file", str(cluster)]  # fmt: skip
    process = subprocess.Popen(command, cwd=folder, stderr=subprocess.PIPE, text=True)
    table = folder / "out" / "fos.csv"
    deadline = time.monotonic() + TIMEOUT
    while not (table.exists() and len(table.read_text().splitlines()) >= 3):
        assert process.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert "the finished trials are in out/fos.csv: the same command reuses them" in err
    kept = len(table.read_text().splitlines()) - 1
    assert kept >= 2
    assert not (folder / "out" / "fos.json").exists()
    rerun = dda(["fos", "slope.toml", "-o", "out", "--scheduler-file", str(cluster)], folder)
    assert rerun.returncode == 0, rerun.stderr
    assert rerun.stderr.count("reused") == kept
    assert abs(json.loads((folder / "out/fos.json").read_text())["fos"] - 1.3) <= 0.02
