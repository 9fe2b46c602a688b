"""dda tradeoff: grid syntax, Pareto fronts, one serial sweep, one through dask."""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest

import dda
from dda.commands.tradeoff import register
from dda.tradeoff.cases import fine_setting, get_case, pushed_block
from dda.tradeoff.grid import Setting, expand, parse_grid
from dda.tradeoff.pareto import cheapest_within, pareto_front
from dda.tradeoff.runner import Cluster, add_errors, make_tasks, run_task, sweep

TINY = "method=al,penalty;penalty=1;tolerance=1e-4;time_step=0.02;ratio=0.01"


def test_grid_spec_fills_defaults_and_expands_without_duplicates():
    grid = parse_grid(
        "method=al,penalty;time_step=0.01,0.005",
        {"penalty": [1.0], "tolerance": [1e-4, 1e-6], "ratio": [0.01]},
    )
    settings = expand(grid)
    # AL: 2 tolerances x 2 steps; penalty ignores the tolerance: 2 steps
    assert len(settings) == 6
    assert {s.method for s in settings} == {"augmented-lagrangian", "penalty"}


def test_the_wall_case_sweeps_the_tolerance_against_a_fine_run():
    case = get_case("wall")
    assert case.reference is None and not case.per_model_size
    assert len(case.grid["tolerance"]) > 1
    assert fine_setting(case.grid).tolerance == min(case.grid["tolerance"]) / 10
    assert len(case.raw["blocks"]) == 101


@pytest.mark.parametrize(
    "spec", ["speed=1", "method=fast", "time_step=-1", "ratio=x", "penalty=", "state_band=1e-9"]
)
def test_bad_grid_specs_are_refused(spec):
    with pytest.raises(ValueError):
        parse_grid(spec, get_case("sliding_block").grid)


def row(error, seconds, method="penalty"):
    return {"error": error, "seconds": seconds, "method": method}


def test_pareto_front_keeps_only_undominated_runs():
    rows = [row(1e-2, 1.0), row(1e-3, 2.0), row(2e-2, 3.0), row(1e-4, 5.0), row(math.nan, 0.1)]
    front = pareto_front(rows)
    assert [r["seconds"] for r in front] == [1.0, 2.0, 5.0]
    assert cheapest_within(rows, 1e-3)["seconds"] == 2.0
    assert cheapest_within(rows, 1e-9) is None


def test_a_task_times_its_repeats_and_measures_the_closed_form_error():
    case = get_case("sliding_block")
    setting = Setting("augmented-lagrangian", 1.0, 1e-4, 0.02, 0.01)
    (task,) = make_tasks(case, [setting], threads=1, repeats=3)
    assert task.scene["contact"]["method"] == "augmented-lagrangian"  # a dict, no file
    out = run_task(task)
    assert out["status"] == "finished" and out["steps"] == 50
    assert out["repeats"] == 3 and len(out["seconds_all"]) == 3
    assert out["seconds"] == sorted(out["seconds_all"])[1]  # the median
    assert out["host"] and out["threads"] == 1
    rows = [out]
    add_errors(rows, case, case.reference)
    assert rows[0]["error"] < 0.01


def test_serial_sweep_writes_csv_table_and_plot(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    args = parser.parse_args(
        ["tradeoff", "sliding_block", "--grid", TINY, "-o", str(tmp_path), "--serial"]
    )
    assert args.func(args) == 0
    assert (tmp_path / "sliding_block.csv").read_text().count("\n") == 3
    assert "host" in (tmp_path / "sliding_block.csv").read_text().splitlines()[0]
    assert "| augmented-lagrangian |" in (tmp_path / "sliding_block.md").read_text()
    assert (tmp_path / "pareto_sliding_block.png").stat().st_size > 1000
    err = capsys.readouterr().err
    assert "[2/2]" in err and "sliding_block: 2 settings × 3 repeats = 6 runs\n" in err
    assert "2 settings × 3 repeats = 6 runs" in (tmp_path / "sliding_block.md").read_text()


def test_unknown_case_is_bad_input(tmp_path):
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    args = parser.parse_args(["tradeoff", "no_such_case", "-o", str(tmp_path)])
    assert args.func(args) == 2


def test_a_bad_scene_file_is_bad_input_named_by_its_file(tmp_path, capsys):
    scene = tmp_path / "neg.toml"
    text = open("cases/sliding_block.toml").read().replace("density = ", "density = -", 1)
    scene.write_text(text)
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    args = parser.parse_args(["tradeoff", str(scene), "--serial", "-o", str(tmp_path / "out")])
    assert args.func(args) == 2
    err = capsys.readouterr().err
    assert "neg.toml" in err and "density" in err and "settings" not in err
    assert not (tmp_path / "out").exists()


def test_a_cluster_without_dask_is_bad_input_with_the_fix(tmp_path, capsys, monkeypatch):
    import dda.commands.tradeoff as tradeoff_cli

    monkeypatch.setattr(tradeoff_cli, "_has_dask", lambda: False)
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    args = parser.parse_args(["tradeoff", "sliding_block", "-o", str(tmp_path / "out")])
    assert args.func(args) == 2
    err = capsys.readouterr().err
    assert "pip install 'dask[distributed]'" in err and "--serial" in err
    assert not (tmp_path / "out").exists()


def test_sweep_runs_in_dask_workers_with_the_reference_as_a_task(capfd):
    """A scene-file case on a local cluster: the fine run is a task like the others."""
    pytest.importorskip("dask.distributed")
    case = get_case("cases/sliding_block.toml")
    grid = parse_grid(TINY.replace("method=al,penalty", "method=penalty"), case.grid)
    tasks = make_tasks(case, expand(grid), threads=1, repeats=3)
    reference = make_tasks(case, [fine_setting(grid)], threads=1, repeats=3)[0]
    seen = []
    rows, fine = sweep(
        tasks, reference, Cluster(workers=1), progress=lambda d, t, r: seen.append(d)
    )
    assert seen == [1] and rows[0]["status"] == "finished" and rows[0]["repeats"] == 3
    assert fine["status"] == "finished" and fine["time_step"] < rows[0]["time_step"]
    add_errors(rows, case, np.asarray(fine["value"]))
    assert rows[0]["error"] < 0.01
    assert "INFO" not in capfd.readouterr().err  # distributed's logs at WARNING


@pytest.mark.parametrize("span", [(0.7, 7.0), (1.2, 1.9), (0.01, 5.0), (1e-3, 50.0)])
def test_the_pareto_time_axis_labels_do_not_overlap(span):
    """Times spanning less than a decade to several: every x label is a plain number and no
    two drawn labels overlap (matplotlib's default labels the minor ticks of a narrow log
    axis in powers of ten, over each other)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dda.tradeoff.report import _plain_log_ticks

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    ax.plot(span, [1.0, 0.1])
    ax.set_xscale("log")
    _plain_log_ticks(ax.xaxis, list(span))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [t for t in ax.get_xticklabels(which="both") if t.get_visible() and t.get_text()]
    boxes = sorted((t.get_window_extent(renderer) for t in labels), key=lambda b: b.x0)
    plt.close(fig)
    assert len(boxes) >= 2
    assert all("10^" not in t.get_text() and "$" not in t.get_text() for t in labels)
    assert all(a.x1 < b.x0 for a, b in zip(boxes, boxes[1:], strict=False))


@pytest.mark.parametrize(
    "method, penalty",
    [
        ("augmented-lagrangian", 10.0),
        pytest.param("penalty", 1.0, marks=pytest.mark.slow),
        pytest.param("penalty", 1e-2, marks=pytest.mark.slow),
    ],
)
def test_the_pushed_block_is_as_exact_at_small_time_steps(method, penalty):
    """The pushed block runs the engine's defaults (the equilibrium start, material
    damping): its acceleration is the rigid closed form's within 1e-9 at Δt = 0.02 s and
    still at 1e-4 s (5,000 steps). (Undamped it flutters as Δt shrinks: 1.1e-4 at
    1.95e-5 s; tests/standing/test_flutter.py.)"""
    case = pushed_block()
    for dt in (0.02, 1e-4):
        result = dda.simulate(case.scene(Setting(method, penalty, 1e-6, dt, 0.01)))
        error = abs(case.measure(result)[0] - case.reference[0]) / case.reference[0]
        assert error <= 1e-9, (dt, error)


@pytest.mark.parametrize("fine", [3e-4, pytest.param(1e-4, marks=pytest.mark.slow)])
def test_the_pendulum_error_falls_in_proportion_to_the_time_step(fine):
    """The pendulum case against its closed form (Jacobi's sn): 2.1e-3 at Δt = 1e-3 s,
    and at a finer Δt at most Δt / 1e-3 times that (first order: measured 5.4e-4 at
    3e-4 s, 1.8e-4 at 1e-4 s)."""
    case = get_case("pendulum")

    def error(dt: float) -> float:
        result = dda.simulate(case.scene(Setting("penalty", 10.0, 1e-6, dt, 0.5)))
        return abs(case.measure(result)[0] - case.reference[0]) / abs(case.reference[0])

    coarse = error(1e-3)
    assert coarse <= 2.2e-3
    assert error(fine) <= fine / 1e-3 * coarse


def test_the_pendulum_closed_form_is_the_ode_solution():
    """Jacobi's sn against φ'' = −g d cos φ / k² integrated to 1e-12."""
    from scipy.integrate import solve_ivp

    from dda.tradeoff.cases import BAR_HEIGHT, BAR_LENGTH, pendulum_angle

    d = BAR_LENGTH / 2
    k2 = (BAR_LENGTH**2 + BAR_HEIGHT**2) / 12 + d**2
    times = [0.1, 0.5, 1.0, 1.7]
    ode = solve_ivp(
        lambda _, y: [y[1], -9.81 * d * np.cos(y[0]) / k2],
        [0, 2.0], [0.0, 0.0], t_eval=times, rtol=1e-12, atol=1e-12,
    )  # fmt: skip
    assert [pendulum_angle(t) for t in times] == pytest.approx(ode.y[0], abs=1e-9)
