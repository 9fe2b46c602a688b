"""What ``fos.json`` says of the criterion: the blocks a trial watches, named, never an
empty list standing for "every free block"."""

from __future__ import annotations

import dda
from dda.stability.criterion import SpeedWatch, criterion_of, criterion_record
from dda.stability.trial import trial_scene
from tests.standing.incline import incline_scene

END = 0.5  # s, the scene's run: a stage at 0.25 s comes before the trials


def two_blocks(**fos) -> dict:
    """b0 on the fixed slope, b1 on b0 (they stand: tan θ / tan φ = 0.5)."""
    scene = incline_scene(0.5, 0.025, END, stack=2)
    if fos:
        scene["fos"] = fos
    return scene


def test_every_free_block_is_named_by_default():
    scene = dda.load_scene(two_blocks())
    record = criterion_record(criterion_of(scene), scene)
    assert record["blocks"] == ["b0", "b1"]  # not the fixed slope
    assert record["watched"] == "every free block"
    assert record["start"] == 0.0 and record["duration"] == END and record["window"] == 0.2


def test_the_fos_blocks_are_named_as_given():
    scene = dda.load_scene(two_blocks(blocks=["b1"]))
    record = criterion_record(criterion_of(scene), scene)
    assert record["blocks"] == ["b1"] and record["watched"] == "[fos] blocks"


def test_a_block_a_stage_removes_is_not_watched_and_the_judge_agrees():
    raw = two_blocks()
    raw["stages"] = [{"time": 0.25, "remove": ["b1"]}]
    scene = dda.load_scene(raw)
    criterion = criterion_of(scene)
    record = criterion_record(criterion, scene)
    assert record["blocks"] == ["b0"] and record["start"] == END
    watch = SpeedWatch(criterion)  # the blocks the trial judges, by name
    dda.simulate(trial_scene(scene, 1.0), on_frame=watch, keep_frames=False)
    assert list(watch.speeds()) == record["blocks"]
