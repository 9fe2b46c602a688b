"""A scene without [[bolts]], [seismic], [water], [[measure]] or [[stages]] builds none of
their code and runs exactly as it did before they existed."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda import model
from dda.effects import bolts, seismic, water
from dda.run import measure, simulation
from dda.scene import stage_plan
from tests.test_cases import CASES

NEW = ("bolts", "seismic", "water", "measure", "stages")


def refuse(*args, **kwargs):
    raise AssertionError("code of an absent section ran")


@pytest.fixture
def nothing_new(monkeypatch):
    """Every entry point of the new sections raises if it is reached."""
    for cls in (bolts.RockBolts, seismic.GroundMotion, water.WaterPressure, measure.Probes):
        monkeypatch.setattr(cls, "__init__", refuse)
    monkeypatch.setattr(simulation, "apply_due_stages", refuse)
    monkeypatch.setattr(stage_plan, "StagePlan", refuse)


def test_an_old_scene_builds_and_runs_none_of_the_new_code(nothing_new):
    """The numbers are those of the engine without these sections (commits 30fa935 and
    6cee15a were the same to the bit; the dense LAPACK solve of two blocks: rel 1e-12
    across machines). Re-measured when the run began to start loaded, with material
    damping and conserved mass (one solve a step since: 100, not 201), and when small
    systems came to be held dense (dda.solve.dense_system: K's terms summed in another
    order; K's condition number reaches 2e9 in this run, penalty spring against mass,
    so the displacements moved by 5.7e-10 relative, the energy by 4.8e-11). Across
    machines the stored numbers hold to the round-off of that conditioning, not to the
    bit: OpenBLAS picks its kernels by processor, and its SkylakeX kernels give
    displacements 9.8e-10 and an energy 6.9e-11 relative from its Haswell ones on one
    machine (OPENBLAS_CORETYPE), well within κ ε = 4e-7."""
    result = dda.simulate(CASES / "sliding_block.toml")
    assert not set(result.summary["active_effects"]) & set(NEW)
    assert not {"bolt_events", "stages_done", "excavated_energy"} & set(result.summary)
    assert result.bolt_events == [] and result.measurements == {}
    assert all(f.measured is None for f in result.frames)
    np.testing.assert_allclose(
        result.final.displacements[1], [-0.7849718007117032, -0.4532036804471802], rtol=1e-8
    )
    assert result.summary["iterations"] == 100
    assert result.history["total_energy"][-1] == pytest.approx(40350.634988128695, rel=1e-9)
    built = model.build(dda.load_scene(CASES / "paper_two_blocks.toml"))
    assert (built.bolts, built.ground, built.stages) == (None, None, None)


def test_empty_sections_are_no_sections():
    """``bolts = []``, ``measure = []`` and ``stages = []`` build nothing either: the same
    run to the bit."""
    import tomllib

    raw = tomllib.loads((CASES / "sliding_block.toml").read_text())
    plain = dda.simulate(raw)
    empty = dda.simulate({**raw, "bolts": [], "measure": [], "stages": []})
    assert empty.summary["active_effects"] == plain.summary["active_effects"]
    for name in plain.history:
        np.testing.assert_array_equal(plain.history[name], empty.history[name])
