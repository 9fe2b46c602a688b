"""Measurement points (dda/run/measure.py): their values, history_points.csv and `dda plot`."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import dda
from dda.commands import cli
from tests.helpers import ROCK, G, rectangle, slope_scene


def measured_slope() -> dict:
    scene = slope_scene(20.0, duration=0.3)
    scene["analysis"]["save_every"] = 1
    centroid = np.mean(scene["blocks"][1]["vertices"], axis=0).tolist()
    scene["measure"] = [
        {"name": "c", "point": centroid},
        {"name": "base", "blocks": ["slider", "slope"]},
    ]
    return scene


def test_measured_values_are_those_of_the_frames():
    """At the centroid: the block's displacement, velocity and stress; the pair: the sum of
    the normal forces of its contacts, every step from step 0."""
    result = dda.simulate(measured_slope())
    m = result.measurements
    assert list(m)[:5] == ["step", "time", "c.ux", "c.uy", "c.vx"]
    assert len(m["step"]) == result.summary["steps"] + 1
    for frame in result.frames:
        k = frame.step
        point = [m[f"c.{c}"][k] for c in ("ux", "uy", "vx", "vy")]
        np.testing.assert_allclose(point[:2], frame.displacements[1], atol=1e-12)
        np.testing.assert_allclose(point[2:], frame.velocities[1, :2], atol=1e-12)
        stress = [m[f"c.{s}"][k] for s in ("sxx", "syy", "sxy")]
        np.testing.assert_array_equal(stress, frame.stresses[1])
        assert m["base.N"][k] == pytest.approx(frame.contacts.normal_force.sum(), rel=1e-12)


def test_the_contact_force_on_a_block_at_rest_carries_its_weight():
    scene = {
        "analysis": {"mode": "static", "time_step": 0.01, "steps": 20, "gravity": [0.0, -G]},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": [
            {"name": "floor", "material": "rock", "fixed": True,
             "vertices": rectangle(-2, -1, 2, 0)},
            {"name": "b", "material": "rock", "vertices": rectangle(0, 0, 1, 0.5)},
        ],
        "measure": [{"name": "on_b", "blocks": ["b", "floor"]},
                    {"name": "on_floor", "blocks": ["floor", "b"]}],
    }  # fmt: skip
    result = dda.simulate(scene)
    m = result.measurements
    weight = ROCK["density"] * G * result.frames[0].areas[1]  # its mass: ρ S₀
    on_b = [m["on_b.fx"][-1], m["on_b.fy"][-1]]
    np.testing.assert_allclose(on_b, [0, weight], atol=1e-9 * weight)
    np.testing.assert_allclose(m["on_floor.fy"][-1], -weight, rtol=1e-9)
    assert m["on_b.N"][-1] == m["on_floor.N"][-1]


def test_measuring_changes_nothing():
    scene = measured_slope()
    plain = dda.simulate({k: v for k, v in scene.items() if k != "measure"})
    measured = dda.simulate(scene)
    for name in plain.history:
        np.testing.assert_array_equal(plain.history[name], measured.history[name])
    np.testing.assert_array_equal(plain.final.centroids, measured.final.centroids)
    assert "measure" in measured.summary["active_effects"]
    assert "measure" not in plain.summary["active_effects"] and plain.measurements == {}


def test_run_writes_history_points_and_plot_draws_them(tmp_path, capsys):
    import tomli_w

    scene = measured_slope()
    scene["analysis"]["save_every"] = 7
    scene["units"] = {"length": "m", "force": "N", "time": "s"}
    (tmp_path / "s.toml").write_text(tomli_w.dumps(scene))
    out = tmp_path / "out"
    assert cli.main(["run", str(tmp_path / "s.toml"), "-o", str(out), "-q"]) == 0
    with open(out / "history_points.csv") as stream:
        rows = list(csv.reader(stream))
    assert rows[0][:4] == ["step", "time", "c.ux", "c.uy"]
    assert [int(r[0]) for r in rows[1:]] == list(range(31))  # every step, from step 0
    assert cli.main(["plot", str(out)]) == 0
    printed = capsys.readouterr().out.split()
    names = sorted(p.rsplit("/", 1)[-1] for p in printed)
    assert names == ["contact_force.png", "displacement.png", "stress.png", "velocity.png"]
    assert all((out / "plots" / n).stat().st_size > 10_000 for n in names)


def test_plot_without_the_run_summary_labels_by_dimension_and_says_so(
    tmp_path, capsys, caplog, monkeypatch
):
    """history_points.csv without its summary.json: the units are unknown, not SI (a
    run in lb and ft was drawn as kN/m); and the file itself given is pointed to its
    folder (was "no such directory")."""
    import logging

    import dda.io.history_plots as plots

    folder = tmp_path / "alone"
    folder.mkdir()
    (folder / "history_points.csv").write_text("step,time,c.ux\n0,0,0\n1,0.1,2e-3\n")
    seen = {}
    monkeypatch.setattr(plots, "_draw", lambda *args: seen.update(units=args[-1]))
    with caplog.at_level(logging.WARNING):
        assert cli.main(["plot", str(folder)]) == 0
    assert seen["units"] == {"length": "length", "force": "force", "time": "time"}
    assert "summary.json of" in caplog.text and "units are unknown" in caplog.text
    assert cli.main(["plot", str(folder / "history_points.csv")]) == 2
    assert "is a file; give the run's output folder" in capsys.readouterr().err


def test_plot_without_measurements_is_refused_in_one_line(tmp_path, capsys):
    assert cli.main(["plot", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no history_points.csv" in err
    assert cli.main(["plot", str(tmp_path / "none")]) == 2
    assert "no such directory" in capsys.readouterr().err
    (tmp_path / "history_points.csv").write_text("a,b\n1,2\n")
    assert cli.main(["plot", str(tmp_path)]) == 2
    assert "not a history_points.csv" in capsys.readouterr().err
    # nothing to draw: exit 0 with an empty plots/ folder before
    for text, words in [("step,time,foo\n0,0,1\n", "no measurement columns to draw"),
                        ("step,time,c.zz\n0,0,1\n", "no measurement columns to draw"),
                        ("step,time,c.ux\n", "no rows"),
                        ("step,time,c.ux\n0,0,1\n1,0.1,x\n", "line 3 is not numbers")]:  # fmt: skip
        (tmp_path / "history_points.csv").write_text(text)
        assert cli.main(["plot", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, err
        assert not (tmp_path / "plots").exists()


def test_a_static_analysis_measures_no_velocity():
    """Its velocity is 0 at every step: left out of a point's default quantities (dda plot
    drew a flat velocity picture), refused by name when asked for."""
    scene = measured_slope()
    scene["analysis"].update(mode="static", steps=3)
    scene["analysis"].pop("duration")
    m = dda.simulate(scene).measurements
    assert "c.ux" in m and "c.sxx" in m and not any(k.startswith("c.v") for k in m)
    scene["measure"][0]["quantities"] = ["displacement", "velocity"]
    with pytest.raises(dda.SceneError, match=r"measure\[0\]\.quantities: velocity is 0 at every"):
        dda.load_scene(scene)
