"""dda tradeoff says what it sweeps: the --grid help lists every case's default grid
(a key --grid leaves out sweeps all of its values), and the plan and the table count
settings and runs apart (a setting runs --repeats times)."""

from __future__ import annotations

import argparse

import pytest

from dda.commands.tradeoff import register
from dda.tradeoff.cases import BUILT_IN, get_case
from dda.tradeoff.grid import expand, given_keys, parse_grid, spec
from dda.tradeoff.report import count_line, markdown_table, plan_line
from dda.tradeoff.runner import SweepInterrupted


def tradeoff_help() -> str:
    """``dda tradeoff --help``, its lines joined."""
    subparsers = argparse.ArgumentParser().add_subparsers()
    register(subparsers)
    return " ".join(subparsers.choices["tradeoff"].format_help().split())


@pytest.mark.parametrize("name", sorted(BUILT_IN))
def test_the_help_lists_each_case_default_grid_as_the_code_has_it(name):
    grid = get_case(name).grid
    text = tradeoff_help()
    assert f"{name} ({len(expand(grid))} settings): {spec(grid)}" in text
    assert "a key not given keeps the case's whole default list" in text


def test_a_grid_written_back_reads_the_same():
    for name in BUILT_IN:
        grid = get_case(name).grid
        assert parse_grid(spec(grid)) == grid
    assert given_keys("method=al; time_step=0.01,0.02") == ["method", "time_step"]


def test_settings_and_runs_are_counted_apart():
    assert plan_line(24, 3) == "24 settings × 3 repeats = 72 runs"
    assert plan_line(1, 1) == "1 setting × 1 repeat = 1 run"
    rows = [{"repeats": 3, "status": "finished"}, {"repeats": 1, "status": "failed"}]
    assert count_line(rows) == "2 settings, 4 runs in all"  # a failed setting stops early


def test_the_plan_counts_the_settings_the_user_did_not_name(tmp_path, capsys, monkeypatch):
    """The brief's surprise: method and time step given, the other keys keep their lists."""

    def interrupted(tasks, *args, **kwargs):
        raise SweepInterrupted([], len(tasks))

    monkeypatch.setattr("dda.tradeoff.runner.sweep", interrupted)
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    grid = "method=al;time_step=0.01,0.02"
    argv = ["tradeoff", "sliding_block", "--grid", grid, "-o", str(tmp_path), "--serial"]
    args = parser.parse_args(argv)
    assert args.func(args) == 130
    err = capsys.readouterr().err
    assert "sliding_block: 24 settings × 3 repeats = 72 runs\n" in err
    assert "(penalty, tolerance, ratio: the case's defaults)" in err
    # a run's own progress is not shown: the plan says how long the longest run is (a
    # setting of 1e7 steps ran for hours without a word)
    assert "the longest run: 100 steps (augmented-lagrangian p=0.1E" in err


def test_the_table_counts_settings_and_runs():
    row = {"method": "penalty", "penalty": 1.0, "tolerance": 1e-4, "time_step": 0.01}
    row |= {"ratio": 0.01, "error": 1e-3, "seconds": 0.1, "steps": 10, "status": "finished"}
    rows = [row | {"repeats": 3}, row | {"repeats": 3, "time_step": 0.02}]
    table = markdown_table(rows)
    assert "2 settings × 3 repeats = 6 runs; 0 settings stopped with a SimulationError." in table
