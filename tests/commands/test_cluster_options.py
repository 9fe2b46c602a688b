"""--workers, --scheduler, --scheduler-file and --serial exclude each other whatever the
value (argparse took ``--workers 2``, the default's value, for an option not given, so
``--serial --workers 2`` passed while ``--serial --workers 3`` was refused)."""

from __future__ import annotations

import argparse

import pytest

from dda.commands.cli import main
from dda.commands.cluster_options import DEFAULT_WORKERS, add_cluster_options, local_workers


@pytest.mark.parametrize("command", ["tradeoff", "fos", "ensemble"])
@pytest.mark.parametrize("workers", ["1", str(DEFAULT_WORKERS), "3"])
def test_serial_and_workers_are_refused_together_whatever_the_count(
    tmp_path, monkeypatch, capsys, command, workers
):
    monkeypatch.chdir(tmp_path)  # were it accepted, its outputs would go to out/ here
    assert main([command, "sliding_block", "--serial", "--workers", workers]) == 2
    assert not (tmp_path / "out").exists()
    err = capsys.readouterr().err
    assert "--workers: not allowed with argument --serial" in err and err.count("\n") == 1


def test_the_local_cluster_has_the_default_workers_unless_told():
    parser = argparse.ArgumentParser()
    add_cluster_options(parser)
    assert local_workers(parser.parse_args([])) == DEFAULT_WORKERS
    assert local_workers(parser.parse_args(["--workers", "3"])) == 3
    add_cluster_options(other := argparse.ArgumentParser(), workers=5)
    assert local_workers(other.parse_args([])) == 5


SCENES = {
    "tradeoff": "sliding_block",
    "fos": "jointed_slope_fos",
    "ensemble": "jointed_slope_ensemble",
}


@pytest.mark.parametrize("command", sorted(SCENES))
@pytest.mark.parametrize(
    ("content", "reason"),
    [
        (None, "no such file"),  # dask would wait for it without end
        ("{", 'not a dask scheduler file (JSON with an "address")'),  # was AssertionError, exit 1
        ('{"port": 1}', 'not a dask scheduler file (JSON with an "address")'),
        ("folder", 'not a file; give a dask scheduler file (JSON with an "address")'),
    ],
)
def test_a_scheduler_file_that_cannot_be_used_is_refused_before_any_work(
    tmp_path, monkeypatch, capsys, command, content, reason
):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "scheduler.json"
    if content == "folder":
        path.mkdir()
    elif content is not None:
        path.write_text(content)
    assert main([command, SCENES[command], "-o", "out", "--scheduler-file", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.endswith(f"dda {command}: --scheduler-file {path}: {reason}\n")
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["fos", "ensemble"])
def test_a_scheduler_that_cannot_be_reached_is_one_line_exit_2_nothing_written(
    tmp_path, monkeypatch, capsys, command
):
    """Was ``OSError: Timed out ...``, exit 1, with the csv begun (its header)."""
    import dask
    import distributed  # noqa: F401  (its defaults in dask's config before the set below)

    monkeypatch.chdir(tmp_path)
    extra = ["--realisations", "2"] if command == "ensemble" else []
    with dask.config.set({"distributed.comm.timeouts.connect": "0.5s"}):
        code = main([command, SCENES[command], "-o", "out", "--scheduler", "tcp://127.0.0.1:1",
                     *extra])  # fmt: skip
    assert code == 2
    last = capsys.readouterr().err.splitlines()[-1]
    assert last.startswith(f"dda {command}: --scheduler tcp://127.0.0.1:1: cannot connect (")
    assert not (tmp_path / "out").exists()
