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
