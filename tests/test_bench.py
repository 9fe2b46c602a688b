"""The benchmark package: the wall scene, one measurement, the command line."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

import dda
from dda.bench import cli
from dda.bench.report import growth_exponent, table
from dda.bench.run import Measurement, measure
from dda.bench.scenes import wall_scene


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
    m = measure(3, method, steps=3, warm_up=False)
    assert m.status == "finished" and m.steps == 3 and m.blocks == 10
    assert m.iterations >= 3 and m.factorisations >= 1
    assert {"contact_search", "assembly", "solve"} <= set(m.stage_seconds)
    assert m.peak_memory_mib > 0
    assert 0 < m.first_step_seconds < m.seconds  # the first step, timed apart
    assert m.ms_per_later_step == pytest.approx(1000 * (m.seconds - m.first_step_seconds) / 2)
    assert "3x3" in table([m]) and "after step 1" in table([m])


def test_growth_exponent():
    small = Measurement(10, 10, "penalty", 10, 100, 1.0, 10, 1)
    large = Measurement(20, 20, "penalty", 10, 400, 4.0, 10, 1)
    assert growth_exponent(small, large) == pytest.approx(1.0)


def test_bench_command_registers():
    parser = argparse.ArgumentParser()
    cli.register(parser.add_subparsers())
    args = parser.parse_args(["bench", "--sizes", "2", "--method", "penalty", "--steps", "2"])
    assert args.sizes == [2] and args.method == "penalty" and args.func is cli.run_command


def test_state_band_experiment_is_undone_after_the_run():
    from dda import model as engine_model

    kept = engine_model.STATE_BAND
    m = measure(2, "penalty", steps=2, warm_up=False, state_band=1e-9)
    assert m.status == "finished" and engine_model.STATE_BAND == kept


def test_stage_table_runs_on_a_tiny_wall():
    from dda.bench.stages import stage_rows

    rows = stage_rows(2)
    names = [name for name, _ in rows]
    assert "assemble K, scatter kernel" in names and all(t >= 0 for _, t in rows)


def test_a_wider_state_band_from_the_scene_costs_fewer_solves():
    """``[contact] state_band``: on the 10 x 10 wall, 1e-7 of the model size instead of
    1e-9 takes 3.0 solves per step instead of 5.6 (measured, docs/benchmarks.md); the
    top row settles the same to 0.5 % (-1.0447e-3 and -1.0466e-3 m after 50 steps)."""
    runs = {}
    for band in (None, 1e-7):
        raw = wall_scene(10, 10, "penalty")
        raw["analysis"]["steps"] = 50
        if band is not None:
            raw["contact"]["state_band"] = band
        runs[band] = dda.simulate(dda.load_scene(raw))
    default, wide = runs[None], runs[1e-7]
    assert wide.summary["iterations_per_step"] < 0.75 * default.summary["iterations_per_step"]
    settle = [r.final.displacements[-10:, 1].mean() for r in (default, wide)]
    assert settle[1] == pytest.approx(settle[0], rel=5e-3)


def test_machine_line_names_the_solver_threads_and_mkl_reproducibility(monkeypatch):
    from dda.bench.report import machine_line

    monkeypatch.setenv("DDA_THREADS", "2")
    monkeypatch.delenv("MKL_CBWR", raising=False)
    assert machine_line().endswith("2 solver threads (DDA_THREADS)")
    monkeypatch.setenv("MKL_CBWR", "AUTO")
    assert machine_line().endswith("2 solver threads (DDA_THREADS), MKL_CBWR=AUTO")
