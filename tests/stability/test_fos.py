"""Factor of safety by strength reduction (``dda fos``, :mod:`dda.stability`).

Expectations are limit-equilibrium closed forms for a rigid block on a plane at θ
(weight W, base length L, joint friction φ and cohesion c):

    FoS = (c L + W cos θ tan φ) / (W sin θ),

tan φ / tan θ without cohesion. The search runs with its default tolerance (0.01);
the issue asks for ±0.02.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest
import tomli_w

import dda
from dda.commands import cli
from dda.stability.fos import factor_of_safety
from dda.stability.search import bracket, next_factors, outcome
from dda.stability.strength_reduction import brittle_note, reduce_strengths, reduced_angle
from tests.helpers import G
from tests.standing.incline import ROCK_1E9, incline_scene

ROOT = Path(__file__).resolve().parents[2]

TOLERANCE = 0.02  # on FoS (issue 39, acceptance 1 and 2)
WEIGHT = ROCK_1E9["density"] * G * 1.0  # every block here has 1 m² (per unit thickness)


def block_on_plane(
    theta: float,
    phi: float,
    cohesion: float = 0.0,
    length: float = 1.0,
    ductile: bool = False,
    penalty_factor: float = 10.0,
) -> dict:
    """A block of base ``length`` and area 1 m² on the slab at θ; Δt = 0.05 s and a 0.5 s
    trial (a block that stands is at rest at any Δt; one that slides moves by the closed
    form). ``ductile``: its contacts keep their cohesion as they slip (residual = peak);
    ``penalty_factor``: the contact penalty over Young's modulus."""
    scene = incline_scene(
        1.0, 0.05, 0.5, theta=theta, width=length, height=1.0 / length,
        penalty_factor=penalty_factor,
    )  # fmt: skip
    scene["joints"]["default"] = {"friction_angle": phi, "cohesion": cohesion}
    if ductile:
        scene["joints"]["default"]["residual_cohesion"] = cohesion
    return scene


def limit_equilibrium(theta: float, phi: float, cohesion: float = 0.0, length: float = 1.0):
    th = math.radians(theta)
    resisting = cohesion * length + WEIGHT * math.cos(th) * math.tan(math.radians(phi))
    return resisting / (WEIGHT * math.sin(th))


def phi_for(theta: float, fos: float) -> float:
    """φ (degrees) with tan φ / tan θ = ``fos``."""
    return math.degrees(math.atan(fos * math.tan(math.radians(theta))))


def cohesion_for(theta: float, phi: float, fos: float, length: float) -> float:
    th = math.radians(theta)
    return WEIGHT * (fos * math.sin(th) - math.cos(th) * math.tan(math.radians(phi))) / length


# ----------------------------------------------------------------- the search itself


def test_the_search_brackets_and_bisects():
    """A model that fails above 1.2345: bounds first, then halves to the tolerance."""
    known: dict[float, bool] = {}
    while factors := next_factors(known, 0.25, 4.0, 0.01, 1):
        known.update({f: f > 1.2345 for f in factors})
    answer = outcome(known)
    assert answer.verdict == "found"
    assert answer.stands <= 1.2345 < answer.fails
    assert answer.fails - answer.stands <= 0.01
    assert len(known) == 2 + math.ceil(math.log2(3.75 / 0.01))


def test_three_workers_cut_the_bracket_in_four():
    assert next_factors({1.0: False, 2.0: True}, 1.0, 2.0, 0.01, 3) == [1.25, 1.5, 1.75]


def test_a_bracket_as_narrow_as_the_factors_decimals_ends_the_search():
    """A tolerance below the trial factors' rounding (9 decimals) asked for the factor it
    already had, for ever (`dda fos --tolerance 1e-10`: 1.77 million reused trials in 60 s):
    the search ends where no new factor is left, and such a tolerance is refused."""
    known: dict[float, bool] = {}
    rounds = 0
    while factors := next_factors(known, 0.25, 4.0, 1e-12, 1):
        known.update({f: f > 1.2345 for f in factors})
        rounds += 1
        assert rounds < 100
    stands, fails = bracket(known)
    assert fails - stands == pytest.approx(1e-9, rel=1e-3)


def test_outside_the_bounds():
    assert outcome({0.25: True, 4.0: True}).verdict == "below"
    assert outcome({0.25: False, 4.0: False}).verdict == "above"
    assert next_factors({0.25: True, 4.0: True}, 0.25, 4.0, 0.01, 1) == []
    assert bracket({1.0: False, 2.0: True, 3.0: False}) == (1.0, 2.0)


def test_strengths_are_divided_by_the_factor():
    scene = dda.load_scene(block_on_plane(30.0, 40.0, cohesion=1000.0))
    reduced = reduce_strengths(scene, 2.0)
    joint = reduced.joints["default"]
    assert math.tan(math.radians(joint.friction_angle)) == pytest.approx(
        math.tan(math.radians(40.0)) / 2.0, rel=1e-12
    )
    assert joint.cohesion == 500.0
    assert scene.joints["default"].cohesion == 1000.0  # the scene itself is unchanged
    assert reduced_angle(45.0, 1.0) == pytest.approx(45.0, rel=1e-12)
    assert reduced.materials == scene.materials  # intact rock only when asked


def test_intact_rock_is_reduced_when_asked():
    raw = block_on_plane(30.0, 40.0)
    raw["materials"]["rock"].update(cohesion=1e6, friction_angle=50.0, tensile_strength=2e5)
    scene = dda.load_scene(raw)
    rock = reduce_strengths(scene, 4.0, intact=True).materials["rock"]
    assert (rock.cohesion, rock.tensile_strength) == (2.5e5, 5e4)
    assert math.tan(math.radians(rock.friction_angle)) == pytest.approx(
        math.tan(math.radians(50.0)) / 4.0, rel=1e-12
    )
    assert rock.young == scene.materials["rock"].young


# ----------------------------------------------------------------- acceptance 1 and 2


@pytest.mark.parametrize(("theta", "fos"), [(30.0, 0.8), (30.0, 1.3), (35.0, 2.0)])
def test_planar_sliding_without_cohesion(theta, fos):
    """FoS = tan φ / tan θ within ±0.02 (acceptance 1)."""
    phi = phi_for(theta, fos)
    answer, rows = factor_of_safety(block_on_plane(theta, phi))
    exact = limit_equilibrium(theta, phi)
    assert exact == pytest.approx(fos, rel=1e-12)
    assert answer.verdict == "found"
    assert abs(answer.fos - exact) <= TOLERANCE, (answer, exact)
    assert answer.stands <= exact <= answer.fails  # the bracket holds the closed form
    assert answer.fails - answer.stands <= 0.01
    assert all(r["status"] == "ran" for r in rows)


# (θ, φ, FoS, base length): a 1 x 1 m block at 30°, a 4 x 0.25 m slab at 40°
COHESIVE = [(30.0, 20.0, 1.3, 1.0), (40.0, 25.0, 1.5, 4.0)]


@pytest.mark.parametrize("penalty_factor", [10.0, 200.0])
@pytest.mark.parametrize(("theta", "phi", "fos", "length"), COHESIVE)
def test_planar_sliding_with_cohesion(theta, phi, fos, length, penalty_factor):
    """FoS = (c L + W cos θ tan φ) / (W sin θ) within ±0.02 and inside the bracket
    (acceptance 2), at the default penalty and at 20 times it.

    Limit equilibrium mobilises the cohesion along the whole base at once and keeps it as
    the block slides: a ductile joint (residual cohesion = peak). The brittle joint's
    answer is below (test_a_brittle_joint_fails_no_later_than_limit_equilibrium)."""
    cohesion = cohesion_for(theta, phi, fos, length)
    scene = block_on_plane(theta, phi, cohesion, length, True, penalty_factor)
    answer, _ = factor_of_safety(scene)
    exact = limit_equilibrium(theta, phi, cohesion, length)
    assert exact == pytest.approx(fos, rel=1e-12)
    assert abs(answer.fos - exact) <= TOLERANCE, (answer, exact, cohesion)
    assert answer.stands <= exact <= answer.fails


@pytest.mark.parametrize("penalty_factor", [10.0, 50.0, 200.0])
def test_a_brittle_joint_fails_no_later_than_limit_equilibrium(penalty_factor):
    """A contact that slips loses its bond for good (docs/contact.md): the least loaded
    (uphill) contact of the 1 x 1 m block slips first, at a share of the shear that
    follows the penalty over E, and the block then fails below limit equilibrium's 1.3
    (measured: 1.2937, 1.1912 and 1.1692 at 10, 50 and 200 E; the bound, not the numbers,
    is the physics: a joint that loses strength cannot hold more)."""
    theta, phi, fos, length = COHESIVE[0]
    cohesion = cohesion_for(theta, phi, fos, length)
    answer, _ = factor_of_safety(
        block_on_plane(theta, phi, cohesion, length, False, penalty_factor)
    )
    assert answer.verdict == "found"
    assert answer.stands <= limit_equilibrium(theta, phi, cohesion, length)


# ----------------------------------------------------------------- the command


def write_scene(path: Path, scene: dict) -> Path:
    path.write_bytes(tomli_w.dumps(scene).encode())
    return path


def test_dda_fos_writes_and_reuses(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = block_on_plane(30.0, phi_for(30.0, 1.3))
    write_scene(tmp_path / "slope.toml", scene)
    args = ["fos", "slope.toml", "-o", "out", "--serial", "--lower", "0.5", "--upper", "2.5"]
    assert cli.main(args) == 0
    first = capsys.readouterr()
    summary = json.loads((tmp_path / "out/fos.json").read_text())
    assert abs(summary["fos"] - 1.3) <= TOLERANCE
    assert f"FoS = {summary['fos']:.4g}" in first.out
    for name in ("fos.csv", "fos.png", "failure.png"):
        assert (tmp_path / "out" / name).stat().st_size > 0
    lines = (tmp_path / "out/fos.csv").read_text().splitlines()
    assert lines[0].startswith("factor,failed,speed,limit,steps,seconds,host,status")
    trials = len(lines) - 1
    assert first.err.count("[trial ") == trials == summary["trials"]
    # a rerun reuses every trial and gives the same answer
    assert cli.main(args) == 0
    again = capsys.readouterr()
    assert again.err.count("reused") == trials
    assert len((tmp_path / "out/fos.csv").read_text().splitlines()) == trials + 1
    rerun = json.loads((tmp_path / "out/fos.json").read_text())
    assert rerun["fos"] == summary["fos"]
    # ... the same file by its absolute path too (an audit: refused as another scene)
    assert cli.main(["fos", str(tmp_path / "slope.toml"), *args[2:]]) == 0
    assert capsys.readouterr().err.count("reused") == trials
    # the block that moves at the first failing F, faster than the limit (a reused trial
    # is run again for it)
    [moving] = summary["moving_blocks"]
    assert moving["name"] == "b0" and moving["speed"] > summary["criterion"]["velocity"]
    assert summary["criterion"]["blocks"] == ["b0"]  # the free block, watched by default
    assert rerun["moving_blocks"] == summary["moving_blocks"]
    # another scene in the same folder is refused (its trials were dropped, with a warning
    # only, and fos.json replaced), unless --overwrite: it then starts afresh
    scene["joints"]["default"]["friction_angle"] = phi_for(30.0, 1.6)
    write_scene(tmp_path / "slope.toml", scene)
    kept = (tmp_path / "out/fos.csv").read_text()
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"holds {trials} trial(s) of another scene" in err
    assert "--overwrite replaces them" in err
    assert (tmp_path / "out/fos.csv").read_text() == kept
    assert cli.main([*args, "--overwrite"]) == 0
    assert "reused" not in capsys.readouterr().err
    assert abs(json.loads((tmp_path / "out/fos.json").read_text())["fos"] - 1.6) <= TOLERANCE


# ----------------------------------------------------------------- acceptance 6


def frictionless(scene: dict) -> dict:
    scene["joints"]["default"] = {"friction_angle": 0.0}
    return scene


def static(scene: dict) -> dict:
    scene["analysis"]["mode"] = "static"
    return scene


def all_fixed_watched(scene: dict) -> dict:
    scene["fos"] = {"blocks": ["slope"]}
    return scene


def none_watched(scene: dict) -> dict:  # was taken for every free block, silently
    scene["fos"] = {"blocks": []}
    return scene


def no_gravity(scene: dict) -> dict:
    scene["analysis"]["gravity"] = [0.0, 0.0]
    return scene


def bad_lower(scene: dict) -> dict:
    scene.setdefault("fos", {})["lower"] = -1.0
    return scene


REFUSED = [
    # the scene's own value, which dda run refuses, was hidden by the option that replaced it
    (bad_lower, ["--lower", "0.5"], "fos.lower: must be > 0, got -1"),
    (frictionless, [], "joints: nothing can fail by strength reduction"),
    (all_fixed_watched, [], "fos.blocks: every watched block is fixed: a trial could never fail"),
    (none_watched, [], "fos.blocks: is empty: list at least one (an empty list would do"),
    # nothing to weaken: --intact did nothing, silently
    (None, ["--intact"], "argument --intact: no block's material is breakable"),
    (static, [], "analysis.mode: a strength-reduction trial needs a dynamic run"),
    (no_gravity, [], "fos.velocity: is required without gravity"),
    (None, ["--lower", "2", "--upper", "1"], "argument --upper: must exceed fos.lower (2), got 1"),
    (None, ["--window", "0"], "argument --window: must be in (0, 1], got 0"),
    (None, ["--blocks", ""], "argument --blocks: is empty: list at least one"),
    (None, ["--velocity", "-1"], "argument --velocity: must be > 0, got -1"),
    (None, ["--tolerance", "5"], "argument --tolerance: must be below upper - lower"),
    (None, ["--tolerance", "1e-10"], "argument --tolerance: must be at least 1e-06 (the search"),
    (None, ["--blocks", "nope"], "argument --blocks: unknown block or group 'nope'"),
    # checked before a trial runs (was a SceneError after fos.csv was begun, exit 1)
    (None, ["--duration", "1e9"], "analysis.duration: 1e+09 s at time_step"),
]


@pytest.mark.parametrize(("change", "options", "message"), REFUSED)
def test_bad_input_is_one_line_exit_2_nothing_written(
    tmp_path, capsys, monkeypatch, change, options, message
):
    monkeypatch.chdir(tmp_path)
    scene = block_on_plane(30.0, 35.0)
    write_scene(tmp_path / "slope.toml", change(scene) if change else scene)
    assert cli.main(["fos", "slope.toml", "-o", "out", "--serial", *options]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    # the file named for its own values, the option for the values it gave (an audit: the
    # file was blamed for --upper)
    prefix = "argument --" if message.startswith("argument --") else "slope.toml: "
    assert err.startswith(f"dda fos: {prefix}")
    assert message in err
    assert not (tmp_path / "out").exists()


def test_the_plot_draws_trials_at_rest_on_a_marked_line_near_the_limit(tmp_path, monkeypatch):
    """A trial whose blocks did not move (speed 0) is drawn at 1e-6 of the limit, as a
    triangle with its own legend entry, not at 1e-16: the log axis keeps to the decades
    that judge the trials. A run stopped by an error (NaN speed) is not drawn."""
    from matplotlib.axes import Axes

    from dda.stability.report import BELOW_LIMIT, fos_plot

    drawn = []
    scatter = Axes.scatter

    def recorded(self, x, y, **kwargs):
        drawn.append((list(x), list(y), kwargs.get("marker"), kwargs.get("label")))
        return scatter(self, x, y, **kwargs)

    monkeypatch.setattr(Axes, "scatter", recorded)
    rows = [
        {"factor": 1.0, "failed": False, "speed": 0.0},
        {"factor": 1.5, "failed": False, "speed": 2e-4},
        {"factor": 2.0, "failed": True, "speed": 0.5},
        {"factor": 3.0, "failed": True, "speed": math.nan},
    ]
    known = {float(r["factor"]): bool(r["failed"]) for r in rows}
    path = fos_plot(rows, outcome(known), 1e-3, tmp_path / "fos.png", "slope", "m/s")
    assert path.stat().st_size > 1000
    stands, fails, at_rest = drawn
    assert stands[:3] == ([1.5], [2e-4], "o") and fails[:3] == ([2.0, 3.0], [0.5, math.nan], "x")
    assert at_rest[:3] == ([1.0], [BELOW_LIMIT * 1e-3], "v") and "below 1e-09 m/s" in at_rest[3]
    # every standing trial at rest: no "stands" entry in the legend without a circle
    drawn.clear()
    resting = [dict(rows[0]), dict(rows[2])]
    known = {float(r["factor"]): bool(r["failed"]) for r in resting}
    fos_plot(resting, outcome(known), 1e-3, tmp_path / "fos.png", "slope", "m/s")
    assert drawn[0][:2] == ([], []) and drawn[0][3].startswith("_")


def test_brittle_joints_are_named_before_a_search():
    """A joint that loses its cohesion when it slips (the default residual cohesion 0)
    can give F below limit equilibrium's; `dda fos` names it, a ductile one it does not."""
    brittle = dda.load_scene(ROOT / "cases" / "jointed_slope_fos.toml")
    note = brittle_note(brittle)
    assert note is not None and "'bedding' (cohesion)" in note
    joints = {
        name: dataclasses.replace(j, residual_cohesion=j.cohesion)
        for name, j in brittle.joints.items()
    }
    assert brittle_note(dataclasses.replace(brittle, joints=joints)) is None
    # a residual friction angle below the peak loses strength too (F 1.360 against 1.453
    # for φ = 40°, φ_r = 30° on a 30° plane, without a word)
    softening = {
        name: dataclasses.replace(j, residual_cohesion=j.cohesion, residual_friction_angle=10.0)
        for name, j in brittle.joints.items()
    }
    note = brittle_note(dataclasses.replace(brittle, joints=softening))
    assert note is not None and "(friction)" in note


def test_a_stored_trial_whose_outcome_is_damaged_is_run_again(tmp_path):
    """fos.csv's "failed" column read "maybe" as False: a damaged row stood. Rows that do
    not read back whole are left out of the file (run again) and counted."""
    from dda.stability.store import RowStore, flag

    store = RowStore(tmp_path / "fos.csv", ["factor", "failed"], "abc")
    store.open(dict)
    for factor, failed in ((1.0, True), (1.5, "maybe"), (2.0, False)):
        store.append({"factor": factor, "failed": failed})
    other = RowStore(tmp_path / "fos.csv", ["factor", "failed"], "other")  # another scene
    other.append({"factor": 3.0, "failed": True})

    def parse(row):
        return float(row["factor"]), flag(row["failed"])

    again = RowStore(tmp_path / "fos.csv", ["factor", "failed"], "abc")
    assert again.open(parse) == [(1.0, True), (2.0, False)]
    assert again.notes() == [
        "fos.csv: 1 row(s) of another scene, seed or option dropped",
        "fos.csv: 1 damaged row(s) run again",
    ]
    assert len((tmp_path / "fos.csv").read_text().splitlines()) == 3  # the header and two
    with pytest.raises(ValueError):
        flag("None")  # a refused trial only where trials may be refused
    assert flag("None", refused=True) is None


# ----------------------------------------------------------------- criteria that cannot judge


def _criterion_error(tmp_path: Path, scene: dict, capsys) -> str:
    """The one line ``dda fos`` refuses ``scene`` with (exit 2, nothing written)."""
    (tmp_path / "s.toml").write_bytes(tomli_w.dumps(scene).encode())
    assert cli.main(["fos", str(tmp_path / "s.toml"), "-o", str(tmp_path / "out"), "--serial"]) == 2
    assert not (tmp_path / "out").exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    return err[0]


def test_a_judged_window_shorter_than_a_time_step_is_refused(tmp_path, capsys):
    """A 0.2 s trial's window of 0.04 s holds one frame at Δt = 0.05 s: every block's speed
    was 0 and every trial stood ("FoS > 4" for a block of FoS 1.21), exit 0."""
    scene = block_on_plane(30.0, 35.0)
    scene["fos"] = {"duration": 0.2}
    said = _criterion_error(tmp_path, scene, capsys)
    assert "fos.window: the judged window, 0.2 of the trial's 0.2 s = 0.04 s, is shorter " \
           "than a time step (0.05 s)" in said  # fmt: skip
    scene["fos"] = {"duration": 0.25}  # 0.05 s: two frames
    (tmp_path / "s.toml").write_bytes(tomli_w.dumps(scene).encode())
    from dda.stability.criterion import criterion_of

    assert criterion_of(dda.load_scene(tmp_path / "s.toml")).window == 0.2


def _shaken(scene: dict, record: list) -> dict:
    scene["seismic"] = {"acceleration": record, "blocks": ["slope"]}
    return scene


def test_a_window_inside_the_seismic_record_is_refused(tmp_path, capsys):
    """A block sliding ±1 cm a cycle on a ground shaken by a sine whose period the window
    spans moved by 2e-7 m net over it and stood: a trial judged while the ground shakes
    is refused, with the duration that judges it after the record."""
    record = [[0.0, 0.0], [0.25, 2.0], [0.5, -2.0], [0.75, 0.0]]
    said = _criterion_error(tmp_path, _shaken(block_on_plane(30.0, 35.0), record), capsys)
    assert "fos.duration: the judged window starts at 0.4 s, before the seismic record ends " \
           "at 0.75 s" in said and "of at least 0.9375 s" in said  # fmt: skip
    scene = _shaken(block_on_plane(30.0, 35.0), record)
    scene["fos"] = {"duration": 0.9375}
    (tmp_path / "s.toml").write_bytes(tomli_w.dumps(scene).encode())
    from dda.stability.criterion import criterion_of

    assert criterion_of(dda.load_scene(tmp_path / "s.toml")).judged_from == pytest.approx(0.75)


def test_a_record_that_plays_before_the_reduction_is_refused(tmp_path, capsys):
    """With stages, the strengths are reduced at the end of the staged run: a record that
    shook the ground before was played at full strength and its FoS was the static one
    (1.924 for the shipped seismic slope's 1.137), without a word."""
    scene = _shaken(block_on_plane(30.0, 35.0), [[0.0, 0.0], [0.1, 2.0], [0.2, 0.0]])
    spare = [[50.0, 50.0], [51.0, 50.0], [51.0, 51.0], [50.0, 51.0]]
    scene["blocks"].append({"name": "spare", "material": "rock", "vertices": spare})
    scene["stages"] = [{"time": 0.25, "remove": ["spare"]}]
    scene["fos"] = {"duration": 1.0}
    said = _criterion_error(tmp_path, scene, capsys)
    assert "seismic: the record shakes the ground from 0 s, before the strengths are " \
           "reduced at 0.5 s (the end of the staged run)" in said  # fmt: skip


def test_the_record_shakes_from_the_row_before_its_first_acceleration(tmp_path, capsys):
    """Linear between rows: [[0, 0], [0.4, 0], [0.6, 2], ...] accelerates the ground from
    0.4 s, before a reduction at 0.5 s (it was accepted: the check began at 0.6 s); and to
    the row after its last: trailing zero rows (to 5 s) do not ask for a 6 s trial."""
    scene = _shaken(block_on_plane(30.0, 35.0), [[0.0, 0.0], [0.4, 0.0], [0.6, 2.0], [0.8, 0.0]])
    spare = [[50.0, 50.0], [51.0, 50.0], [51.0, 51.0], [50.0, 51.0]]
    scene["blocks"].append({"name": "spare", "material": "rock", "vertices": spare})
    scene["stages"] = [{"time": 0.25, "remove": ["spare"]}]
    scene["fos"] = {"duration": 2.0}
    said = _criterion_error(tmp_path, scene, capsys)
    assert "the record shakes the ground from 0.4 s, before the strengths are reduced" in said
    padded = [[0.0, 0.0], [0.25, 2.0], [0.5, -2.0], [0.75, 0.0], [5.0, 0.0]]
    said = _criterion_error(tmp_path, _shaken(block_on_plane(30.0, 35.0), padded), capsys)
    assert "before the seismic record ends at 0.75 s" in said


def test_a_whole_trial_window_inside_the_record_is_refused(tmp_path, capsys):
    """fos.window = 1 with a record: the window is the whole trial, which no duration moves
    after the record (the refusal divided by 1 − window: ZeroDivisionError, exit 1)."""
    scene = _shaken(block_on_plane(30.0, 35.0), [[0.0, 0.0], [0.25, 2.0], [0.5, 0.0]])
    scene["fos"] = {"window": 1.0, "duration": 2.0}
    said = _criterion_error(tmp_path, scene, capsys)
    assert "fos.window: is 1: the judged window is the whole trial" in said
