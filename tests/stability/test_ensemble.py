"""Probability of failure over realisations (``dda ensemble``, :mod:`dda.stability`).

The known answer: a block on a plane at θ = 30° whose joint friction angle is drawn
from a normal law N(33°, 3°) (cut to [0°, 90°)) slides exactly when φ < θ, so
P(failure) = P(φ < 30°) = (Φ(−1) − Φ(−11)) / (Φ(19) − Φ(−11)) = 0.158655.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w

import dda
from dda.commands import cli
from dda.scene import Distribution, EnsembleSettings
from dda.stability.ensemble import wilson
from dda.stability.sampling import draw, drawn_values, realise
from tests.standing.incline import incline_scene

CASES = Path(__file__).resolve().parents[2] / "cases"
THETA, MEAN, STD = 30.0, 33.0, 3.0


def phi_normal(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


EXACT = (phi_normal((THETA - MEAN) / STD) - phi_normal(-MEAN / STD)) / (
    phi_normal((90.0 - MEAN) / STD) - phi_normal(-MEAN / STD)
)


def slope_ensemble(realisations: int, seed: int = 2026) -> dict:
    scene = incline_scene(1.0, 0.1, 0.5, theta=THETA)
    scene["joints"]["default"] = {"friction_angle": MEAN}
    scene["ensemble"] = {
        "seed": seed,
        "realisations": realisations,
        "vary": [
            {"key": "joints.default.friction_angle", "distribution": "normal",
             "mean": MEAN, "std": STD},
        ],
    }  # fmt: skip
    return scene


def write_scene(path: Path, scene: dict) -> Path:
    path.write_bytes(tomli_w.dumps(scene).encode())
    return path


# ----------------------------------------------------------------- pieces


def test_wilson_interval():
    """Closed forms: 0 of n gives [0, z²/(n + z²)]; the interval holds p̂; it shrinks as
    1/√n for a fixed fraction."""
    z2 = 1.959963984540054**2
    p, low, high = wilson(0, 10)
    assert (p, low) == (0.0, 0.0) and high == pytest.approx(z2 / (10 + z2), rel=1e-12)
    for n in (2, 3, 7):  # 0 of 3 gave a low end of 5.6e-17; all of n, a high of 1 - 1e-16
        assert wilson(0, n)[1] == 0.0 and wilson(n, n)[2] == 1.0
    p, low, high = wilson(16, 100)
    assert low < p < high
    widths = [np.subtract(*wilson(k, n)[:0:-1]) for k, n in ((160, 1000), (16000, 100000))]
    assert widths[0] / widths[1] == pytest.approx(10.0, rel=0.01)


def test_draws_are_reproducible_and_cut():
    ensemble = EnsembleSettings(
        vary=(
            Distribution("joints.a.friction_angle", "normal", mean=30.0, std=20.0, low=0.0,
                         high=40.0),
            Distribution("joint_sets[0].spacing", "lognormal", mean=2.0, std=0.5, low=0.0),
            Distribution("joint_sets[0].offset", "uniform", low=-1.0, high=1.0),
        ),
        seed=11,
    )  # fmt: skip
    first = [drawn_values(ensemble, k) for k in range(200)]
    assert first[7] == drawn_values(ensemble, 7)  # from (seed, k) alone
    phi = np.array([d["joints.a.friction_angle"] for d in first])
    assert phi.min() >= 0.0 and phi.max() <= 40.0
    spacing = np.array([d["joint_sets[0].spacing"] for d in first])
    assert spacing.mean() == pytest.approx(2.0, abs=3 * 0.5 / 20)
    assert spacing.std() == pytest.approx(0.5, rel=0.15)
    offset = np.array([d["joint_sets[0].offset"] for d in first])
    assert -1.0 <= offset.min() and offset.max() <= 1.0
    # von Mises of large κ: nearly normal with σ = 1/√κ (radians) about its mean
    dip = Distribution("joint_sets[0].dip", "von_mises", mean=35.0, kappa=400.0)
    sigma = math.degrees(1 / math.sqrt(400.0))
    assert draw(dip, 0.5) == pytest.approx(35.0, abs=1e-9)
    assert draw(dip, phi_normal(1.0)) - 35.0 == pytest.approx(sigma, rel=0.01)
    # the inverse CDF at its ends gives the cut ends
    assert draw(ensemble.vary[0], 0.0) == pytest.approx(0.0, abs=1e-9)
    assert draw(ensemble.vary[0], 1.0) == pytest.approx(40.0, abs=1e-9)


def test_a_drawn_joint_set_cuts_another_rock_mass():
    raw = tomllib.loads((CASES / "jointed_slope_fos.toml").read_text())
    raw["ensemble"] = {
        "vary": [{"key": "joint_sets[0].spacing", "distribution": "uniform", "low": 2.0,
                  "high": 4.0}]
    }  # fmt: skip
    scene = dda.load_scene(raw)
    counts = set()
    for k in range(3):
        realised, values = realise(raw, scene.ensemble, k)
        assert realised["joint_sets"][0]["spacing"] == values["joint_sets[0].spacing"]
        counts.add(len(dda.load_scene(realised).blocks))
    assert len(counts) > 1
    assert raw["joint_sets"][0]["spacing"] == 3.0  # the scene itself is unchanged


# ----------------------------------------------------------------- acceptance 4


def run_ensemble(tmp_path: Path, capsys, realisations: int, outdir: str = "out") -> dict:
    write_scene(tmp_path / "slope.toml", slope_ensemble(realisations))
    assert cli.main(["ensemble", "slope.toml", "-o", outdir, "--serial"]) == 0
    captured = capsys.readouterr()
    summary = json.loads((tmp_path / outdir / "ensemble.json").read_text())
    assert "P(failure) = " in captured.out
    summary["stderr"] = captured.err
    return summary


def check_against_the_closed_form(tmp_path: Path, summary: dict, realisations: int) -> None:
    low, high = summary["interval_95"]
    assert summary["judged"] == realisations and summary["refused"] == 0
    assert low <= EXACT <= high, (summary, EXACT)
    rows = (tmp_path / "out/ensemble.csv").read_text().splitlines()
    assert len(rows) == realisations + 1
    # every outcome is the closed form's: fails exactly when the drawn φ < θ
    table = [r.split(",") for r in rows[1:]]
    assert all((float(r[2]) < THETA) == (r[3] == "True") for r in table)


def test_every_realisation_is_judged_by_the_closed_form(tmp_path, capsys, monkeypatch):
    """N = 30: each realisation fails exactly when its φ < θ, and the exact P lies in
    the reported 95 % interval; the pictures are written."""
    monkeypatch.chdir(tmp_path)
    summary = run_ensemble(tmp_path, capsys, 30)
    check_against_the_closed_form(tmp_path, summary, 30)
    assert (tmp_path / "out/ensemble.png").stat().st_size > 0
    pictures = min(3, summary["failures"])
    assert pictures >= 1
    rows = [r.split(",") for r in (tmp_path / "out/ensemble.csv").read_text().splitlines()[1:]]
    failing = sorted(int(r[0]) for r in rows if r[3] == "True")[:pictures]
    drawn = sorted(int(p.stem.split("_")[1]) for p in (tmp_path / "out").glob("failing_*.png"))
    assert drawn == failing  # named by the realisation's index, as in ensemble.csv


def test_the_ensemble_picture_counts_whole_realisations_and_marks_f_1(tmp_path, monkeypatch):
    """Integer ticks on the histogram's count axis (a count of 1.25 means nothing), and
    with factors of safety a line at F = 1 on the CDF."""
    from matplotlib.figure import Figure

    from dda.stability.report import ensemble_plot

    figures, save = [], Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda f, *a, **k: (figures.append(f), save(f, *a, **k)))
    values, failed = [0.8, 1.1, 1.3, 1.35, 2.0], [True, False, False, False, False]
    ensemble_plot(values, failed, "factor of safety", tmp_path / "e.png", "t", True)
    histogram, cdf = figures[-1].axes[:2]
    assert all(float(t).is_integer() for t in histogram.get_yticks())
    assert any(list(line.get_xdata()) == [1.0, 1.0] for line in cdf.get_lines())
    assert "F = 1 (fraction below: 0.2)" in [t.get_text() for t in cdf.get_legend().get_texts()]
    # two realisations below the search's bounds and one above, of eight: the CDF starts at
    # 2/8 and ends at 7/8, and 3 of 8 lie below F = 1 (it read 1 of the 5 drawn: 0.2;
    # an audit's 2 of 6 failing read 0)
    ensemble_plot(values, failed, "factor of safety", tmp_path / "o.png", "t", True, (2, 1))
    cdf = figures[-1].axes[1]
    steps = next(line for line in cdf.get_lines() if len(line.get_ydata()) == 6)
    assert steps.get_ydata()[0] == 2 / 8 and steps.get_ydata()[-1] == 7 / 8
    assert "F = 1 (fraction below: 0.375)" in [t.get_text() for t in cdf.get_legend().get_texts()]


@pytest.mark.slow
def test_interval_narrows_as_one_over_root_n(tmp_path, capsys, monkeypatch):
    """N = 100 then 400 in the same folder (acceptance 4): the first 100 are reused, the
    exact answer is inside both intervals, and the interval narrows as 1/√N: its width
    times √N / √(p̂ (1 − p̂)) is the same within 5 % (Wilson's z²/N terms: 3.8 % at
    N = 100). The width itself also follows p̂, which moves by ±0.037 (1 sd) at N = 100:
    this seed gives p̂ = 0.09 at 100 and 0.1575 at 400, widths 0.114 and 0.071."""
    monkeypatch.chdir(tmp_path)
    small = run_ensemble(tmp_path, capsys, 100)
    check_against_the_closed_form(tmp_path, small, 100)
    large = run_ensemble(tmp_path, capsys, 400)
    check_against_the_closed_form(tmp_path, large, 400)
    assert "(seed 2026; 100 reused)" in large["stderr"]
    scaled = []
    for summary in (small, large):
        low, high = summary["interval_95"]
        p = summary["p_failure"]
        scaled.append((high - low) * math.sqrt(summary["judged"] / (p * (1 - p))))
    assert scaled[1] / scaled[0] == pytest.approx(1.0, rel=0.05), scaled
    assert large["interval_95"][1] - large["interval_95"][0] < (
        small["interval_95"][1] - small["interval_95"][0]
    )


def test_a_stopped_ensemble_resumes(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first = run_ensemble(tmp_path, capsys, 4)
    again = run_ensemble(tmp_path, capsys, 6)
    assert "(seed 2026; 4 reused)" in again["stderr"]
    assert again["stderr"].count("] realisation ") == 2  # two more run
    assert first["realisations"] == 4 and again["realisations"] == 6


def test_a_damaged_row_is_run_again_and_another_seed_s_pictures_go(tmp_path, capsys, monkeypatch):
    """A row of ensemble.csv whose outcome is no outcome ("maybe") was read as refused and
    changed P with no word; it is run again, and said. An ensemble of another seed into
    the same folder drops the rows (said) and the failing_K.png of the earlier seed that
    its own failing realisations do not draw anew."""
    monkeypatch.chdir(tmp_path)
    first = run_ensemble(tmp_path, capsys, 6)
    table = tmp_path / "out/ensemble.csv"
    lines = table.read_text().splitlines()
    cells = lines[2].split(",")
    cells[3] = "maybe"  # the "failed" column
    table.write_text("\n".join([*lines[:2], ",".join(cells), *lines[3:]]) + "\n")
    again = run_ensemble(tmp_path, capsys, 6)
    assert "ensemble.csv: 1 damaged row(s) run again" in again["stderr"]
    assert "(seed 2026; 5 reused)" in again["stderr"]
    assert (again["failures"], again["judged"]) == (first["failures"], first["judged"])
    rows = [r.split(",") for r in table.read_text().splitlines()[1:]]
    assert len(rows) == 6 and all(r[3] in ("True", "False") for r in rows)
    stale = tmp_path / "out" / "failing_99.png"  # as an earlier seed's picture
    stale.write_bytes(b"png")
    write_scene(tmp_path / "slope.toml", slope_ensemble(6, seed=7))
    kept = table.read_text()
    assert cli.main(["ensemble", "slope.toml", "-o", "out", "--serial"]) == 2  # not unasked
    assert "holds 6 realisation(s) of another scene, seed or option" in capsys.readouterr().err
    assert table.read_text() == kept and stale.exists()
    assert cli.main(["ensemble", "slope.toml", "-o", "out", "--serial", "--overwrite"]) == 0
    err = capsys.readouterr().err
    assert "ensemble.csv: 6 row(s) of another scene, seed or option dropped" in err
    assert not stale.exists()


# ----------------------------------------------------------------- acceptance 6


def negative_spacing(raw: dict) -> dict:
    raw["ensemble"] = {
        "vary": [{"key": "joint_sets[0].spacing", "distribution": "uniform", "low": -1.0,
                  "high": 3.0}]
    }  # fmt: skip
    return raw


def lognormal_of_mean_zero(raw: dict) -> dict:  # divided by zero in the sampling
    raw["ensemble"] = {
        "vary": [{"key": "joints.default.cohesion", "distribution": "lognormal", "mean": 0.0,
                  "std": 3.0}]
    }  # fmt: skip
    return raw


def jrc_of_a_coulomb_joint(raw: dict) -> dict:  # refused by every realisation, once
    raw["ensemble"] = {
        "vary": [{"key": "joints.default.jrc", "distribution": "uniform", "low": 5.0,
                  "high": 10.0}]
    }  # fmt: skip
    return raw


def flat_normal(raw: dict) -> dict:  # drew its mean alone, every realisation
    raw["ensemble"] = {
        "vary": [{"key": "joints.default.friction_angle", "distribution": "normal",
                  "mean": 31.0, "std": 1e30}]
    }  # fmt: skip
    return raw


def nothing_drawn(raw: dict) -> dict:
    raw.pop("ensemble", None)
    return raw


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (negative_spacing, "ensemble.vary[0].low: joint_sets[0].spacing must be > 0, got -1"),
        (nothing_drawn, "ensemble.vary: the scene draws no value"),
        (flat_normal, "ensemble.vary[0].std: 1e+30 is over 1e+06 times the range 0 to 90"),
        (
            jrc_of_a_coulomb_joint,
            "ensemble.vary[0].key: jrc is a key of model = 'barton-bandis'; joints.default is "
            "'coulomb'",
        ),
        (
            lognormal_of_mean_zero,
            "ensemble.vary[0].mean: a lognormal distribution's mean must be > 0, got 0",
        ),
    ],
)
def test_bad_ensembles_are_refused(tmp_path, capsys, monkeypatch, change, message):
    monkeypatch.chdir(tmp_path)
    raw = change(tomllib.loads((CASES / "jointed_slope_fos.toml").read_text()))
    write_scene(tmp_path / "slope.toml", raw)
    assert cli.main(["ensemble", "slope.toml", "-o", "out", "--serial"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("dda ensemble: slope.toml: ") and message in err
    assert not (tmp_path / "out").exists()


def test_each_realisation_gets_its_own_fos(tmp_path, capsys, monkeypatch):
    """--fos: every realisation's factor of safety is tan φ / tan θ of its own φ."""
    monkeypatch.chdir(tmp_path)
    write_scene(tmp_path / "slope.toml", slope_ensemble(3))
    assert cli.main(["ensemble", "slope.toml", "-o", "out", "--serial", "--fos"]) == 0
    capsys.readouterr()
    rows = (tmp_path / "out/ensemble.csv").read_text().splitlines()
    header = rows[0].split(",")
    for line in rows[1:]:
        row = dict(zip(header, line.split(","), strict=True))
        phi = float(row["joints.default.friction_angle"])
        exact = math.tan(math.radians(phi)) / math.tan(math.radians(THETA))
        assert abs(float(row["fos"]) - exact) <= 0.02, (row, exact)
        assert (row["failed"] == "True") == (exact < 1.0)


def test_a_failing_realisations_picture_names_its_drawn_values_with_their_units():
    from dda.commands.ensemble import _drawn
    from dda.scene import Units

    keys = ["joints.bedding.friction_angle", "joints.bedding.cohesion", "joint_sets[0].spacing"]
    row = dict(zip(keys, (28.123, 2388.2, 2.8351), strict=True))
    drawn = _drawn(row, keys, Units())
    assert drawn == "friction_angle = 28.12°, cohesion = 2388 Pa, spacing = 2.835 m"
    feet = _drawn(row, keys[1:], Units(length="ft", force="lbf"))
    assert feet == "cohesion = 2388 lbf/ft², spacing = 2.835 ft"


def test_an_ensemble_whose_every_realisation_is_refused_gives_no_answer(
    tmp_path, capsys, monkeypatch
):
    """Spacings that cut more blocks than cutting.max_blocks refuse each realisation as it
    comes: no probability of failure, exit 1 and the first reason (it said
    P(failure) = nan with exit 0)."""
    monkeypatch.chdir(tmp_path)
    raw = tomllib.loads((CASES / "jointed_slope_fos.toml").read_text())
    raw["ensemble"] = {
        "realisations": 2,
        "vary": [{"key": "joint_sets[0].spacing", "distribution": "uniform", "low": 0.001,
                  "high": 0.002}],
    }  # fmt: skip
    write_scene(tmp_path / "slope.toml", raw)
    assert cli.main(["ensemble", "slope.toml", "-o", "out", "--serial"]) == 1
    err = capsys.readouterr().err
    assert "every realisation was refused (realisation 0: refused: joint_sets[0].spacing" in err
    assert "Traceback" not in err
    summary = json.loads((tmp_path / "out" / "ensemble.json").read_text())  # strict JSON
    assert summary["p_failure"] is None and summary["refused"] == 2


def test_a_fos_outside_the_bounds_is_counted_not_dropped(tmp_path, capsys, monkeypatch):
    """--fos with --upper 1.1: a realisation whose FoS is above the search's bounds has no
    number; the mean is of those found, and the summary, the answer and the picture's
    title say how many are left out (the title said n = 8 over 7 drawn)."""
    monkeypatch.chdir(tmp_path)
    write_scene(tmp_path / "slope.toml", slope_ensemble(4))
    argv = ["ensemble", "slope.toml", "-o", "out", "--serial", "--fos", "--upper", "1.1"]
    assert cli.main(argv) == 0
    said = capsys.readouterr().out
    rows = (tmp_path / "out/ensemble.csv").read_text().splitlines()
    header = rows[0].split(",")
    fos = [float(dict(zip(header, r.split(","), strict=True))["fos"]) for r in rows[1:]]
    outside = sum(math.isnan(f) for f in fos)
    assert 0 < outside < len(fos)  # φ drawn about 33° on a 30° plane: FoS 0.9 to 1.3
    summary = json.loads((tmp_path / "out/ensemble.json").read_text())
    assert summary["fos_outside_bounds"] == outside
    assert summary["fos_found"] == len(fos) - outside
    found = [f for f in fos if not math.isnan(f)]
    assert summary["fos_mean"] == pytest.approx(sum(found) / len(found))
    assert f"{outside} with FoS outside the search's bounds" in said


def test_a_refused_scene_value_is_refused_though_an_option_replaces_it(
    tmp_path, capsys, monkeypatch
):
    """`[ensemble] realisations = 0`, which dda run refuses, ran with --realisations 2."""
    monkeypatch.chdir(tmp_path)
    write_scene(tmp_path / "slope.toml", slope_ensemble(0))
    options = ["ensemble", "slope.toml", "-o", "out", "--serial", "--realisations", "2"]
    assert cli.main(options) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ensemble.realisations: must be a positive integer" in err
    assert not (tmp_path / "out").exists()
