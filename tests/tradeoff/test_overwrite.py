"""A folder holds one study of a case, as it holds one dda run: a second study of the
same case is refused (exit 2, one line, nothing changed) unless --overwrite, which
replaces the earlier study, an interrupted one's CASE_partial.* included (a second
study used to replace the first silently, and left a partial one beside it)."""

from __future__ import annotations

import pytest

from dda.commands.cli import main
from dda.tradeoff.runner import SweepInterrupted

GRID = "method=penalty;penalty=1;tolerance=1e-4;time_step=0.02;ratio=0.01"


def row(seconds: float = 0.1) -> dict:
    """A finished run's row as run_task gives it (no engine needed)."""
    setting = {"method": "penalty", "penalty": 1.0, "tolerance": 1e-4, "time_step": 0.02}
    return {**setting, "ratio": 0.01, "case": "sliding_block", "status": "finished",
            "seconds": seconds, "seconds_all": [seconds] * 3, "repeats": 3, "threads": 1,
            "host": "here", "steps": 50, "max_penetration": 0.0, "value": [1.0]}  # fmt: skip


@pytest.fixture
def sweeps(monkeypatch):
    """Make the sweep return one row at once; ``sweeps.interrupt = True`` makes it stop
    with that row as Ctrl-C does."""

    class Sweeps:
        interrupt = False
        count = 0

    def sweep(tasks, *args, **kwargs):
        Sweeps.count += 1
        if Sweeps.interrupt:
            raise SweepInterrupted([row()], 2)
        return [row()], None

    monkeypatch.setattr("dda.tradeoff.runner.sweep", sweep)
    monkeypatch.setattr("dda.tradeoff.report.pareto_plot", lambda rows, path, title: None)
    return Sweeps


def study(folder, *extra: str) -> int:
    """``dda tradeoff sliding_block`` of one setting into ``folder``, serially."""
    argv = ["tradeoff", "sliding_block", "--grid", GRID, "-o", str(folder), "--serial"]
    return main([*argv, *extra])


def test_a_second_study_into_the_folder_is_refused_and_changes_nothing(tmp_path, capsys, sweeps):
    assert study(tmp_path) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    capsys.readouterr()
    assert study(tmp_path) == 2
    err = capsys.readouterr().err
    assert err == (
        f"dda tradeoff: -o {tmp_path}: holds a study of sliding_block (sliding_block.csv, "
        "sliding_block.md); --overwrite replaces it\n"
    )
    assert sweeps.count == 1  # nothing ran
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_overwrite_replaces_the_study(tmp_path, sweeps):
    assert study(tmp_path) == 0
    (tmp_path / "sliding_block.csv").write_text("the earlier study\n")
    assert study(tmp_path, "--overwrite") == 0
    assert "the earlier study" not in (tmp_path / "sliding_block.csv").read_text()


def test_an_interrupted_study_is_refused_and_overwrite_removes_its_partial_files(
    tmp_path, capsys, sweeps
):
    sweeps.interrupt = True
    assert study(tmp_path) == 130
    assert (tmp_path / "sliding_block_partial.csv").is_file()
    capsys.readouterr()
    sweeps.interrupt = False
    assert study(tmp_path) == 2
    err = capsys.readouterr().err
    assert "holds an interrupted study of sliding_block (sliding_block_partial.csv, " in err
    assert study(tmp_path, "--overwrite") == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sliding_block.csv", "sliding_block.md"]


def test_an_interrupted_overwrite_does_not_leave_the_earlier_whole_study(tmp_path, sweeps):
    assert study(tmp_path) == 0
    sweeps.interrupt = True
    assert study(tmp_path, "--overwrite") == 130
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["sliding_block_partial.csv", "sliding_block_partial.md"]


def test_studies_of_other_cases_share_a_folder(tmp_path, sweeps):
    (tmp_path / "stack.csv").write_text("another case's study\n")
    assert study(tmp_path) == 0
    assert (tmp_path / "stack.csv").read_text() == "another case's study\n"
