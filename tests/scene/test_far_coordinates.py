"""A scene far from the origin gives the numbers it gives at the origin: the engine works
about the model's centre (dda.scene.local_frame) and writes the scene's coordinates."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import dda
import dda.cases
from dda.scene.local_frame import local_origin
from tests.run.test_runs import engineering_scene

SHIFTS = [1e6, 1e8, 1e9]


def moved(raw: dict, d: float) -> dict:
    """The raw scene with every position moved by (d, d) (as a file written there would be)."""
    raw = copy.deepcopy(raw)

    def point(p):
        return [p[0] + d, p[1] + d]

    for block in raw["blocks"]:
        block["vertices"] = [point(p) for p in block["vertices"]]
        if "fixed_points" in block:
            block["fixed_points"] = [point(p) for p in block["fixed_points"]]
    for load in raw.get("loads", []):
        load["point"] = point(load["point"])
    bolts = raw.get("bolts", []) + [b for s in raw.get("stages", []) for b in s.get("bolts", [])]
    for bolt in bolts:
        bolt["start"], bolt["end"] = point(bolt["start"]), point(bolt["end"])
    if "water" in raw:
        raw["water"]["table"] = [point(p) for p in raw["water"]["table"]]
    for entry in raw.get("measure", []):
        if "point" in entry:
            entry["point"] = point(entry["point"])
    return raw


def sliding_block() -> dict:
    raw = tomllib.loads(dda.cases.folder().joinpath("sliding_block.toml").read_text())
    raw["analysis"].pop("duration")
    raw["analysis"]["steps"] = 10
    return raw


def loaded_engineering_scene() -> dict:
    """Bolts (one staged), water, seismic input, measurements, a point load, fixed points."""
    raw = engineering_scene(25)  # the staged bolt (at 0.2 s) within the run
    raw["loads"] = [{"block": "b1", "point": [0.9, 1.9], "force": [2e3, -1e3]}]
    raw["blocks"].append(
        {"name": "post", "material": "rock", "vertices": [[3, 0], [3.5, 0], [3.5, 1], [3, 1]],
         "fixed_points": [[3.1, 0.1], [3.4, 0.1]]}
    )  # fmt: skip
    return raw


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


CASES = [(loaded_engineering_scene, d) for d in SHIFTS] + [(sliding_block, d) for d in SHIFTS[:2]]


@pytest.mark.parametrize(("make", "d"), CASES)
def test_a_scene_moved_far_away_gives_the_numbers_of_the_scene_moved_back(make, d):
    """Both scenes carry the input's rounding at d (the one at the origin is moved there
    and back); displacements, velocities and stresses agree to 1e-9: they are the same to
    the bit (computing about (0, 0) they differed by up to 4e-5 at 1e8 for the bolted,
    flooded, shaken stack, 2e-5 for the sliding block). The sliding block's slope has
    irrational corners: at 1e9 (spacing of doubles 1.2e-7 m) their rounding makes the
    block overlap the slope by 1.8e-8 m², and the scene is refused (next test)."""
    far = dda.load_scene(moved(make(), d))
    back = dda.load_scene(moved(moved(make(), d), -d))
    assert local_origin(far) == (d, d) and local_origin(back) == (0.0, 0.0)
    a, b = dda.simulate(far), dda.simulate(back)
    for name in ("displacements", "velocities", "stresses"):
        x, y = getattr(a.final, name), getattr(b.final, name)
        assert relative(x, y) <= 1e-9, name
        assert np.abs(y).max() > 0.0
    assert np.abs(a.final.centroids - d - b.final.centroids).max() <= 4 * np.spacing(d)
    for u, v in zip(a.final.vertices, b.final.vertices, strict=True):
        assert np.abs(u - d - v).max() <= 4 * np.spacing(d)
    for name, values in b.measurements.items():
        if name not in ("step", "time"):
            assert relative(a.measurements[name], values) <= 1e-9, name


# shipped cases drawn where they are in the ground: a tunnel 300 m down, its section
# 40 m across (its in-situ field is given in the scene's y, docs/engineering.md)
AT_DEPTH = {"tunnel_deep": (0.0, -320.0)}


def test_a_scene_near_the_origin_is_not_moved():
    for name in dda.cases.names():
        scene = dda.load_scene(dda.cases.folder().joinpath(f"{name}.toml"))
        assert local_origin(scene) == AT_DEPTH.get(name, (0.0, 0.0)), name


def test_a_scene_whose_rounding_at_1e9_makes_blocks_overlap_is_refused():
    with pytest.raises(dda.SceneError, match=r"blocks\[1\].vertices: \(block 'slider'\) overlaps"):
        dda.load_scene(moved(sliding_block(), 1e9))


def test_a_far_run_stopped_and_resumed_through_dda_run(tmp_path, monkeypatch, capsys):
    """The checkpoint holds the local frame; --resume of the far scene accepts it and
    writes the uninterrupted history.csv (in the scene's coordinates)."""
    import os
    import signal

    import tomli_w

    from dda.commands import cli
    from dda.io.run_writer import RunWriter

    monkeypatch.setenv("DDA_SOLVER", "superlu")
    monkeypatch.chdir(tmp_path)
    Path("far.toml").write_text(tomli_w.dumps(moved(loaded_engineering_scene(), 1e8)))
    assert cli.main(["run", "far.toml", "-q", "-o", "whole"]) == 0
    add_frame = RunWriter.add_frame

    def add_and_signal(writer, frame):
        add_frame(writer, frame)
        if frame.step == 7:
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(RunWriter, "add_frame", add_and_signal)
    assert cli.main(["run", "far.toml", "-q", "-o", "out"]) == 143
    monkeypatch.setattr(RunWriter, "add_frame", add_frame)
    assert cli.main(["run", "far.toml", "-q", "-o", "out", "--resume"]) == 0
    assert Path("out/history.csv").read_bytes() == Path("whole/history.csv").read_bytes()
    x = float(Path("whole/history.csv").read_text().splitlines()[1].split(",")[4])
    assert abs(x - 1e8) < 10.0  # positions written in the scene's coordinates
