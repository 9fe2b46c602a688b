"""dda.simulate's options of the wrong type are refused before any work, naming the
option (a string for ``on_frame`` failed after the equilibrium start had run; one for
``checkpoints`` or ``resume`` as an AttributeError; ``keep_frames="no"`` kept every
frame), and a checkpoint plan of a step count that is no positive whole number is
refused (-1 wrote a checkpoint after every step)."""

from __future__ import annotations

import pytest

import dda
from dda.run.checkpoint import CheckpointPlan
from tests.standing.incline import incline_scene


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("on_frame", "x", "on_frame: expected None or a callable(frame), got str 'x'"),
        ("keep_frames", "no", "keep_frames: expected True or False, got str 'no'"),
        ("stop", 3, "stop: expected None or a callable() -> bool, got int 3"),
        ("checkpoints", "x.npz", "checkpoints: expected None or a dda.run.checkpoint."),
        ("resume", "x.npz", "resume: expected None or a checkpoint (dda.run.checkpoint."),
        ("progress", "yes", "progress: expected True, False or a callable(fraction, info)"),
    ],
)
def test_an_option_of_the_wrong_type_is_refused_before_any_work(monkeypatch, option, value,
                                                                message):  # fmt: skip
    import dda.run.simulation as simulation

    scene = dda.load_scene(incline_scene(0.5, 1e-3, 1e-3))
    monkeypatch.setattr(simulation, "build", lambda *a: pytest.fail("work began"))
    with pytest.raises(TypeError) as caught:
        dda.simulate(scene, **{option: value})
    assert str(caught.value).startswith(message)


@pytest.mark.parametrize(
    ("steps", "seconds"), [(-1, None), (0, None), (2.5, None), (True, None), (None, 0.0)]
)
def test_a_checkpoint_plan_of_no_positive_count_is_refused(tmp_path, steps, seconds):
    with pytest.raises(ValueError, match="every_steps|every_seconds"):
        CheckpointPlan(tmp_path / "c.npz", every_steps=steps, every_seconds=seconds)
    assert CheckpointPlan(tmp_path / "c.npz", every_steps=3).every_steps == 3
