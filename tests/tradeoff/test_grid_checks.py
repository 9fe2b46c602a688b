"""dda tradeoff checks every setting's scene before any run: a grid value the scene
refuses (or that is not finite) is one line naming the grid key and value, exit 2,
nothing printed before it and nothing written (the plan used to be printed, then the
first run raised a SceneError: exit 1, and tracebacks from the dask workers)."""

from __future__ import annotations

import pytest

from dda.commands.cli import main
from dda.tradeoff.cases import get_case
from dda.tradeoff.grid import parse_grid

OTHERS = {"method": "al", "penalty": "1", "tolerance": "1e-4", "time_step": "0.02", "ratio": "0.01"}


def grid_with(key: str, value: str) -> str:
    """A one-setting grid of the sliding block with ``key`` set to ``value``."""
    return ";".join(f"{k}={value if k == key else v}" for k, v in OTHERS.items())


@pytest.fixture
def no_sweep(monkeypatch):
    """Fail the test if any run starts."""

    def sweep(*args, **kwargs):
        raise AssertionError("a run started")

    monkeypatch.setattr("dda.tradeoff.runner.sweep", sweep)


@pytest.mark.parametrize("value", ["inf", "-inf", "nan", "1e400"])
def test_the_grid_parser_refuses_values_that_are_not_finite(value):
    with pytest.raises(ValueError, match="must be a finite positive number"):
        parse_grid(f"time_step={value}", get_case("sliding_block").grid)


@pytest.mark.parametrize(
    "key, value, said",
    [
        ("time_step", "inf", "grid key 'time_step': 'inf' must be a finite positive number"),
        ("tolerance", "1e300", "grid key 'tolerance': '1e300' must be below 1 (a fraction of"),
        ("ratio", "2", "--grid ratio=2: analysis.max_displacement_ratio: must be in (0, 1)"),
        ("penalty", "1e300", "--grid penalty=1e+300: contact.penalty: must be finite"),
        ("time_step", "1e-300", "--grid time_step=1e-300: analysis.duration: 1 s at time_step"),
    ],
)
def test_a_grid_value_the_scene_refuses_is_one_line_before_any_run(
    tmp_path, capsys, no_sweep, key, value, said
):
    out = tmp_path / "out"
    argv = ["tradeoff", "sliding_block", "--grid", grid_with(key, value), "-o", str(out)]
    assert main([*argv, "--serial"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"dda tradeoff: {said}") and err.count("\n") == 1
    assert "Traceback" not in err and "settings" not in err  # no plan printed
    assert not out.exists()


def test_a_dask_sweep_is_refused_in_the_client_too(tmp_path, capsys, no_sweep):
    """Without --serial: refused before a worker starts (they printed tracebacks)."""
    argv = ["tradeoff", "sliding_block", "--grid", grid_with("ratio", "2"), "-o", str(tmp_path)]
    assert main([*argv, "--workers", "1"]) == 2
    assert capsys.readouterr().err.startswith("dda tradeoff: --grid ratio=2: ")


def test_a_reference_run_the_scene_refuses_is_named_as_the_fine_run(tmp_path, capsys, no_sweep):
    """The wall is measured against a fine run at a quarter of the smallest time step: a
    time step whose settings run but whose fine run is too long is refused too."""
    grid = "method=al;tolerance=1e-3;time_step=2e-8"  # 5e6 steps; the fine run 2e7
    argv = ["tradeoff", "wall", "--grid", grid, "-o", str(tmp_path / "out"), "--serial"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "dda tradeoff: --grid time_step: the fine reference run's time_step=5e-9: "
        "analysis.duration: 0.1 s at time_step 5e-09 s is at least 2e+07 steps"
    )
    assert err.count("\n") == 1


def test_a_grid_key_given_twice_and_a_missing_scene_file_are_refused(tmp_path):
    """An audit: "time_step=0.01;time_step=0.003" ran 0.003 alone, and a missing scene
    file was "unknown case 'missing.toml'"."""
    with pytest.raises(ValueError, match="grid key 'time_step' is given twice"):
        parse_grid("time_step=0.01;time_step=0.003", get_case("sliding_block").grid)
    with pytest.raises(ValueError, match=r"^missing\.toml: no such file$"):
        get_case("missing.toml")
    (tmp_path / "x.toml").mkdir()
    with pytest.raises(ValueError, match=r"x\.toml: is not a file$"):
        get_case(str(tmp_path / "x.toml"))
