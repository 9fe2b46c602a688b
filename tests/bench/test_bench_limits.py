"""dda bench checks every size's wall before the warm-ups: a wall its run would refuse
(too many steps, too many blocks) or one estimated not to fit in memory is one line
naming the option, exit 2, and no size is measured (a SceneError traceback came after
the warm-ups, exit 1, and a 2000 x 2000 wall ended in a MemoryError)."""

from __future__ import annotations

import pytest

from dda.bench import limits
from dda.commands.cli import main


@pytest.fixture
def no_measurement(monkeypatch):
    """Fail the test if a size's process (its warm-ups first) is started."""

    def measure_in_subprocess(*args, **kwargs):
        raise AssertionError("a size was measured")

    monkeypatch.setattr("dda.bench.run.measure_in_subprocess", measure_in_subprocess)


def refusal(capsys, *argv: str) -> str:
    """The one line ``dda bench argv`` writes on stderr, after checking it exits 2."""
    assert main(["bench", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert "Traceback" not in captured.err
    return captured.err


def test_steps_beyond_a_run_limit_are_refused_before_the_warm_ups(capsys, no_measurement):
    err = refusal(capsys, "--sizes", "2", "--steps", "20000000")
    assert err == (
        "dda bench: --steps 20000000: more than the 10,000,000 steps a run may take "
        "(analysis.max_steps)\n"
    )


def test_a_wall_larger_than_the_memory_available_is_refused(capsys, no_measurement, monkeypatch):
    monkeypatch.setattr(limits, "available_memory_bytes", lambda: 8e9)
    err = refusal(capsys, "--sizes", "5", "2000", "--steps", "1")
    assert err.startswith(
        "dda bench: --sizes 2000: a 2000 x 2000 wall (4,000,001 blocks) needs about 111 GB"
    )
    assert "more than the 8 GB of memory available on this machine (--max-memory)" in err


def test_max_memory_sets_the_bound(capsys, no_measurement):
    err = refusal(capsys, "--sizes", "5", "100", "--max-memory", "0.4")
    assert err.startswith("dda bench: --sizes 100: a 100 x 100 wall (10,001 blocks)")
    assert "more than --max-memory 0.4 GB" in err


def test_the_memory_estimate_matches_the_measured_peaks():
    """docs/benchmarks.md: 481 MiB at 10,001 blocks, 1,261 MiB at 40,001."""
    mib = 1024.0 * 1024.0
    assert limits.estimated_peak_bytes(10_001) / mib == pytest.approx(481, rel=0.05)
    assert limits.estimated_peak_bytes(40_001) / mib == pytest.approx(1261, rel=0.05)
    assert limits.available_memory_bytes() is None or limits.available_memory_bytes() > 0
