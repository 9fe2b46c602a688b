"""``dda movie``: a run's frames into one MP4 or GIF, read back (frame count, size)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from dda.commands import cli
from dda.io import RunWriter
from dda.io.frame_files import all_frames, read_found_frame
from dda.io.movie import shared_look
from dda.result import Frame


def falling_frame(step: int) -> Frame:
    """A fixed base and a unit block 0.5 m lower each step."""
    drop = 0.5 * step
    vertices = [
        np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0]]),
        np.array([[1.0, 5.0], [2.0, 5.0], [2.0, 6.0], [1.0, 6.0]]) - [0.0, drop],
    ]
    return Frame(
        time=0.1 * step, step=step, names=("base", "block"), ids=np.array([0, 1]),
        centroids=np.array([[2.0, 0.5], [1.5, 5.5 - drop]]), rotations=np.zeros(2),
        velocities=np.zeros((2, 3)), stresses=np.array([[0.0, 0.0, 0.0], [0.0, -step, 0.0]]),
        displacements=np.array([[0.0, 0.0], [0.0, -drop]]), vertices=vertices,
        areas=np.array([4.0, 1.0]), fixed=np.array([True, False]),
    )  # fmt: skip


@pytest.fixture
def run_folder(tmp_path):
    writer = RunWriter(tmp_path / "run", image=False)
    for step in range(6):
        writer.add_frame(falling_frame(step))
    writer.finish()
    return tmp_path / "run"


def test_a_gif_holds_every_frame_at_the_size_asked(run_folder, tmp_path):
    gif = tmp_path / "fall.gif"
    assert cli.main(["movie", str(run_folder), "-o", str(gif), "--size", "320", "240"]) == 0
    with Image.open(gif) as movie:
        assert (movie.n_frames, movie.size) == (6, (320, 240))


def test_every_second_frame(run_folder, tmp_path):
    gif = tmp_path / "half.gif"
    args = ["movie", str(run_folder), "-o", str(gif), "--size", "320", "240", "--every", "2"]
    assert cli.main(args) == 0
    with Image.open(gif) as movie:
        assert movie.n_frames == 3


def test_a_frame_the_index_lists_but_the_folder_lacks_is_said(run_folder, tmp_path, caplog):
    """An audit: a movie of a run one frame file short was written one frame short,
    unsaid. The frames left are read, and the missing one named."""
    (run_folder / "frames" / "blocks_000002.vtu").unlink()
    gif = tmp_path / "gap.gif"
    assert cli.main(["movie", str(run_folder), "-o", str(gif), "--size", "320", "240"]) == 0
    with Image.open(gif) as movie:
        assert movie.n_frames == 5
    assert "1 frame(s) it lists are missing, left out: blocks_000002.vtu" in caplog.text


def test_an_mp4_by_default_when_imageio_ffmpeg_is_there(run_folder):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    assert cli.main(["movie", str(run_folder), "--size", "320", "240", "--fps", "5"]) == 0
    reader = imageio_ffmpeg.read_frames(str(run_folder / "movie.mp4"))
    meta = next(reader)
    assert tuple(meta["size"]) == (320, 240)
    assert meta["fps"] == pytest.approx(5.0)
    assert sum(1 for _ in reader) == 6


def test_one_view_and_one_colour_range_for_the_whole_movie(run_folder):
    frames = [read_found_frame(f) for f in all_frames(run_folder)]
    assert [f.step for f in frames] == list(range(6))
    look = shared_look(frames, "syy")
    # the block falls from y = 6 to y = 3.5: the view holds its start and its end
    np.testing.assert_allclose(look.view, [[0.0, 0.0], [4.0, 6.0]])
    assert look.clim == (-5.0, 0.0)  # syy of the free block over all frames (fixed: no field)
    assert look.force_max == 0.0  # the frames have no contacts


def spike_frame(step: int, spike_at: int = 3) -> Frame:
    """``falling_frame`` with a steady syy of -0.5 MPa, and -11 MPa at one frame (an
    impact)."""
    frame = falling_frame(step)
    syy = -11e6 if step == spike_at else -0.5e6 - 1e3 * step
    return dataclasses.replace(frame, stresses=np.array([[0.0, 0.0, 0.0], [0.0, syy, 0.0]]))


def test_a_one_frame_spike_does_not_set_the_movies_range():
    """-11 MPa in one frame of eight, about -0.5 MPa steady: the range is the steady one
    and the bar's arrow announces values below it; held two frames, the spike counts."""
    frames = [spike_frame(step) for step in range(8)]
    look = shared_look(frames, "syy")
    assert look.clim == pytest.approx((-0.507e6, -0.5e6))
    assert look.scale.extend == "min"
    held = [*frames[:4], spike_frame(4, spike_at=4), *frames[5:]]  # frames 3 and 4
    assert shared_look(held, "syy").clim[0] == -11e6
    at_the_end = [spike_frame(step, spike_at=7) for step in range(8)]
    assert shared_look(at_the_end, "syy").clim[0] == -11e6  # the last frame's value stays


def test_the_movie_takes_a_range(run_folder, tmp_path, capsys):
    frames = [read_found_frame(f) for f in all_frames(run_folder)]
    assert shared_look(frames, "syy", (-2.0, 0.0)).clim == (-2.0, 0.0)
    gif = tmp_path / "ranged.gif"
    args = ["movie", str(run_folder), "-o", str(gif), "--size", "320", "240"]
    assert cli.main([*args, "--range", "-2", "0"]) == 0 and gif.is_file()
    assert cli.main([*args, "--range", "0", "-2"]) == 2
    assert "--range 0 -2: the first number must be below the second" in capsys.readouterr().err
    # the help's own example, a negative number in scientific notation (was: "expected 2
    # arguments", argparse taking -2e6 for an option)
    assert cli.main([*args, "--range", "-2e6", "-1.5E-3"]) == 0
    assert cli.main([*args, "--range", "-1.5E-3", "-2e6"]) == 2
    assert "--range -0.0015 -2e+06: the first number must be below" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["-o", "fall.avi"], "a movie is .mp4 or .gif"),
        (["--size", "321", "240"], "even numbers"),
    ],
)
def test_bad_requests_are_refused_before_drawing(run_folder, tmp_path, monkeypatch, capsys,
                                                 extra, message):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    assert cli.main(["movie", str(run_folder), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "Traceback" not in err and len(err.splitlines()) == 1
    assert not list(tmp_path.glob("fall.*")) and not list(run_folder.glob("movie*"))


def test_a_folder_without_frames_is_refused(tmp_path, capsys):
    assert cli.main(["movie", str(tmp_path)]) == 2
    assert "no written frame" in capsys.readouterr().err
    assert cli.main(["movie", str(tmp_path / "absent")]) == 2
    assert capsys.readouterr().err == f"dda movie: {tmp_path / 'absent'}: no such directory\n"
    assert not list(tmp_path.iterdir())


def test_without_imageio_ffmpeg_a_gif_and_a_clear_refusal_of_mp4(monkeypatch):
    from dda.io import movie

    monkeypatch.setattr(movie, "mp4_available", lambda: False)
    assert movie.movie_format(None) == ".gif"
    with pytest.raises(movie.MovieError, match=r"MP4 needs imageio-ffmpeg.*dda-rock\[movie\]"):
        movie.movie_format("run.mp4")


@pytest.mark.slow
def test_the_rock_slope_movie_is_playable(tmp_path):
    """The issue's acceptance: `dda movie` on the shipped rock slope, read back."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "slope"
    assert cli.main(["run", "rock_slope", "-o", str(out), "--quiet"]) == 0
    written = len(all_frames(out))
    assert cli.main(["movie", str(out)]) == 0
    reader = imageio_ffmpeg.read_frames(str(out / "movie.mp4"))
    assert tuple(next(reader)["size"]) == (960, 720)
    assert sum(1 for _ in reader) == written > 10
