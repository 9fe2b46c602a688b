"""The benchmark package: the wall scene, one measurement, the command line."""

from __future__ import annotations

import argparse
import math
import os

import numpy as np
import pytest

import dda
from dda.bench.report import growth_exponent, table
from dda.bench.run import WARM_UPS, Measurement, measure
from dda.bench.scenes import wall_scene
from dda.commands import bench as cli


def test_wall_scene_loads_with_shared_edges():
    scene = dda.load_scene(wall_scene(3, 2, steps=4))
    assert len(scene.blocks) == 7
    assert scene.blocks[0].fixed
    corners = np.array([b.vertices for b in scene.blocks[1:]])
    assert corners[:, :, 0].min() == 2.0 and corners[:, :, 0].max() == 5.0
    assert corners[:, :, 1].min() == 1.0 and corners[:, :, 1].max() == 3.0


def test_wall_scene_refuses_unknown_method():
    with pytest.raises(ValueError):
        wall_scene(2, method="lagrange")


@pytest.mark.parametrize("method", ["penalty", "augmented-lagrangian"])
def test_measure_a_small_wall(method):
    m = measure(3, method, steps=3, warm_up=False, start="unloaded")
    assert m.status == "finished" and m.steps == 3 and m.blocks == 10
    assert m.iterations >= 3 and m.factorisations >= 1
    assert 3 <= m.newton_iterations <= m.iterations  # at least one a step; chord steps beside
    assert {"contact_search", "assembly", "solve"} <= set(m.stage_seconds)
    assert m.peak_memory_mib > 0
    assert 0 < m.first_step_seconds < m.seconds  # the first step, timed apart
    assert m.ms_per_later_step == pytest.approx(1000 * (m.seconds - m.first_step_seconds) / 2)
    assert "3x3" in table([m]) and "after step 1" in table([m]) and "Newton/step" in table([m])


def test_the_table_names_its_counts_and_the_stages_units():
    """The factorisations column is a count over the run; each stage's column says it is
    ms a step; the header, the rule and a row have as many cells."""
    m = Measurement(3, 3, "penalty", 4, 10, 0.2, 12, 5, stage_seconds={"factorisation": 0.01})
    head, rule, row = table([m]).splitlines()
    names = [cell.strip() for cell in head.strip("|").split("|")]
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert len(names) == len(cells) == rule.count("---")
    assert cells[names.index("factorisations")] == "5"
    assert cells[names.index("factor ms/step")] == "2.50"  # 10 ms over 4 steps
    assert {"search ms/step", "law ms/step", "output ms/step"} <= set(names)
    assert "factor." not in names and "factor" not in names
    # an audit: band systems factorise inside the compiled loop, timed as "solve"
    band = Measurement(3, 3, "penalty", 4, 10, 0.2, 12, 5, stage_seconds={"solve": 0.01})
    cells = [cell.strip() for cell in table([band]).splitlines()[2].strip("|").split("|")]
    assert cells[names.index("factor ms/step")] == "(in solve)"


def test_the_walls_start_as_users_runs_do_and_report_the_start():
    """By default the wall takes the engine's equilibrium start (and material damping),
    whose seconds and Newton iterations the table gives; ``start="unloaded"`` is Shi's
    start without damping, the C code's, with no start to report."""
    loaded = measure(3, "penalty", steps=3, warm_up=False)
    assert loaded.start == "equilibrium" and loaded.start_newton_iterations >= 1
    assert 0 < loaded.start_seconds < loaded.first_step_seconds
    assert f"| equilibrium | {loaded.start_seconds:.3f} |" in table([loaded])
    shi = measure(3, "penalty", steps=3, warm_up=False, start="unloaded")
    assert shi.start_newton_iterations == 0 and shi.start_seconds == 0.0
    assert "| unloaded | – | – | – |" in table([shi])
    raw = wall_scene(3, start="unloaded")
    assert raw["analysis"]["start"] == "unloaded" and raw["materials"]["rock"]["damping"] == 0
    default = wall_scene(3, start="equilibrium")
    assert "start" not in default["analysis"] and "damping" not in default["materials"]["rock"]
    parser = argparse.ArgumentParser()
    cli.register(parser.add_subparsers())
    assert parser.parse_args(["bench"]).start == "equilibrium"
    assert parser.parse_args(["bench", "--start", "unloaded"]).start == "unloaded"


def test_growth_exponent():
    small = Measurement(10, 10, "penalty", 10, 100, 1.0, 10, 1)
    large = Measurement(20, 20, "penalty", 10, 400, 4.0, 10, 1)
    assert growth_exponent(small, large) == pytest.approx(1.0)


def test_bench_command_registers():
    parser = argparse.ArgumentParser()
    cli.register(parser.add_subparsers())
    args = parser.parse_args(["bench", "--sizes", "2", "--method", "penalty", "--steps", "2"])
    assert args.sizes == [2] and args.method == "penalty" and args.func is cli.run_command


def test_stage_table_runs_on_a_tiny_wall():
    from dda.bench.stages import stage_rows

    rows = stage_rows(2)
    names = [name for name, _ in rows]
    assert "assemble K, scatter kernel" in names and all(t >= 0 for _, t in rows)


def test_machine_line_names_the_solver_threads_and_mkl_reproducibility(monkeypatch):
    from dda.bench.report import machine_line

    monkeypatch.setenv("DDA_THREADS", "2")
    monkeypatch.delenv("MKL_CBWR", raising=False)
    assert machine_line().endswith("2 solver threads (DDA_THREADS)")
    monkeypatch.setenv("MKL_CBWR", "AUTO")
    assert machine_line().endswith("2 solver threads (DDA_THREADS), MKL_CBWR=AUTO")
    monkeypatch.delenv("DDA_THREADS")  # each size's process decides: no count of this one's
    said = "solver threads by the thread policy (DDA_THREADS unset), MKL_CBWR=AUTO"
    assert machine_line().endswith(said)


def test_warm_up_walls_take_each_form_of_systems():
    """The warm-up walls are a band wall, a dense one (dda.solve.dense_system) and one on
    the sparse block pattern, the systems of the walls from 30 x 30 up."""
    from dda.solve.policy import DEFAULT

    sizes = {systems or "by size": [] for _, _, systems in WARM_UPS}
    for size, _, systems in WARM_UPS:
        sizes[systems or "by size"].append(size)
    assert 6 * min(sizes["by size"]) ** 2 <= DEFAULT.dense_system_rows  # dense
    assert 6 * max(sizes["by size"]) ** 2 > DEFAULT.dense_system_rows  # band
    assert sizes["sparse"]


def test_each_warm_up_runs_as_the_measured_run_on_its_systems(monkeypatch):
    """Each warm-up wall runs inside the run_work of a long run, as the measured run does
    (the model's build loads its kernels then), with DDA_SYSTEMS=sparse for the sparse
    one and as it was for the others: the warm-ups used to leave the sparse path's
    kernels (_scatter, _find_slots, the line step, the law's) and the build's to load
    inside the measured run of walls from 30 x 30 up."""
    import dda.bench.run as run
    from dda.blocks import moments_kernel
    from dda.jit import compiled_in_run, numba_enabled

    if not numba_enabled():
        pytest.skip("the kernels are off (DDA_NO_NUMBA)")
    runs = []

    def simulate(scene, **kwargs):
        systems = os.environ.get("DDA_SYSTEMS", "")
        runs.append((len(scene.blocks), systems, compiled_in_run(moments_kernel)))

    monkeypatch.delenv("DDA_SYSTEMS", raising=False)
    monkeypatch.setattr(dda, "simulate", simulate)
    monkeypatch.setattr(run, "pardiso_available", lambda: False)
    run.warm_up_runs("penalty", "unloaded")
    assert runs == [(size * size + 1, systems, True) for size, _, systems in WARM_UPS]
    assert "DDA_SYSTEMS" not in os.environ  # given back as it was


def test_a_run_that_fails_without_a_summary_is_reported_failed_not_timed(monkeypatch):
    """A measured run that stops before any step gives no steps to divide by: its status
    says it failed and the table gives no time a step (it used to divide the run's time
    by the steps asked for)."""
    import dda.bench.run as run

    def simulate(scene, **kwargs):
        raise dda.SimulationError("step 0: no step could be solved")

    monkeypatch.setattr(dda, "simulate", simulate)
    m = run.measure(2, "penalty", steps=50, warm_up=False)
    assert m.status == "failed: step 0: no step could be solved" and m.steps == 0
    assert math.isnan(m.ms_per_step) and math.isnan(m.block_steps_per_second)
    row = table([m]).splitlines()[-1]
    assert "| failed: step 0" in row and "nan" not in row
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    names = [cell.strip() for cell in table([m]).splitlines()[0].strip("|").split("|")]
    assert cells[names.index("ms/step")] == "–"


def test_repeat_keeps_the_fastest_run(monkeypatch, capsys):
    """``--repeat 3``: three runs of each size, the table shows the fastest."""
    import dda.bench.run as run

    seconds = iter([0.3, 0.1, 0.2])
    made = []

    def fake(columns, method, steps, start):
        made.append(columns)
        return Measurement(columns, columns, method, steps, columns**2 + 1, next(seconds), 4, 2)

    monkeypatch.setattr(run, "measure_in_subprocess", fake)
    parser = argparse.ArgumentParser()
    cli.register(parser.add_subparsers())
    args = parser.parse_args(["bench", "--sizes", "2", "--method", "penalty", "--repeat", "3"])
    assert args.func(args) == 0
    assert made == [2, 2, 2]
    out = capsys.readouterr().out
    assert "| 1.00 |" in out  # 0.1 s over 100 steps
    assert "--repeat 3 (fastest of 3 runs)" in out


MEASURED_30 = """
import dda
from dda.bench.run import LONG_RUN_STEPS, warm_up_runs
from dda.bench.scenes import wall_scene
from dda.jit import run_work

warm_up_runs("penalty", "equilibrium")
scene = dda.load_scene(wall_scene(30, steps=3, start="equilibrium"))
print("measured run: start", flush=True)
with run_work(901, LONG_RUN_STEPS):
    dda.simulate(scene)
print("measured run: end", flush=True)
"""


@pytest.mark.slow
def test_no_kernel_loads_inside_the_measured_30_by_30_run():
    """numba's own account (NUMBA_DEBUG_CACHE=1): after the warm-ups, the measured run of
    a 30 x 30 wall (sparse systems) loads and compiles no kernel (it loaded nine)."""
    import subprocess
    import sys

    from dda.jit import numba_enabled

    if not numba_enabled():
        pytest.skip("the kernels are off (DDA_NO_NUMBA)")
    environment = {**os.environ, "NUMBA_DEBUG_CACHE": "1"}
    environment.pop("DDA_SYSTEMS", None)
    out = subprocess.run(
        [sys.executable, "-c", MEASURED_30], env=environment, capture_output=True, text=True,
        check=True,
    ).stdout  # fmt: skip
    measured = out.split("measured run: start")[1].split("measured run: end")[0]
    assert "measured run: end" in out
    assert "data loaded" not in measured and "data saved" not in measured, measured


def test_the_start_cost_gives_the_start_a_step_and_their_ratio_of_a_shipped_case():
    """python -m dda.bench.start_cost's row: the start's seconds and Newton iterations, a
    step's seconds from two run lengths, the start over 20 steps (docs/contact.md)."""
    from dda.bench.start_cost import HEADER, start_cost

    cost = start_cost("jointed_slope_fos", starts=1, runs=1, long=4, short=2, kernels=False)
    assert cost.blocks == 32 and cost.start_newton > 0
    # a step's seconds are the difference of a 4- and a 2-step run: finite here; its sign
    # needs the documented run lengths (120 and 40 steps), two steps being within a loaded
    # machine's noise (-5.6 ms measured while two test suites ran beside it)
    assert cost.start_seconds > 0 and math.isfinite(cost.step_seconds)
    assert cost.in_steps == pytest.approx(cost.start_seconds / (20 * cost.step_seconds))
    assert cost.row().startswith("| `cases/jointed_slope_fos.toml` | 32 | ")
    assert cost.row().count("|") == HEADER.splitlines()[0].count("|")


def test_a_size_whose_process_compiled_kernels_is_measured_again(monkeypatch):
    """A process that compiled kernels keeps the compiler's memory resident (515 MiB
    against 224 for the 5 x 5 wall on an empty numba cache): its size is measured once
    more, in a process that loads them, and that measurement is the one reported."""
    from dda.bench import run

    fields = dict(columns=2, rows=2, method="penalty", steps=1, blocks=5, seconds=0.1,
                  iterations=1, factorisations=1)  # fmt: skip
    replies = [{**fields, "peak_memory_mib": 515.0, run.COMPILED: True},
               {**fields, "peak_memory_mib": 224.0, run.COMPILED: False}]  # fmt: skip
    commands = []

    def measured(cmd):
        commands.append(cmd)
        return replies[len(commands) - 1]

    monkeypatch.setattr(run, "_measured", measured)
    assert run.measure_in_subprocess(2, steps=1).peak_memory_mib == 224.0
    assert len(commands) == 2 and commands[0] == commands[1]
    replies[0][run.COMPILED] = False
    commands.clear()
    assert run.measure_in_subprocess(2, steps=1).peak_memory_mib == 515.0
    assert len(commands) == 1
