"""Every command refuses an output place it cannot write before any work: exit 2 within
2 s, one line naming the path as given, nothing computed, nothing written. A write that
fails later names the file asked for, never a temporary one; ffmpeg's failure is one line.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from dda.commands import cli
from dda.io import RunWriter
from tests.io.test_movie import falling_frame

NOWHERE = "/proc/dda-no-such-place"  # /proc takes no new files, not even from root
pytestmark = pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")

# every command that writes, with its output option pointed at NOWHERE
COMMANDS = {
    "run": ["run", "sliding_block", "-o", f"{NOWHERE}/run"],
    "cut -o": ["cut", "tunnel", "-o", f"{NOWHERE}/blocks.toml"],
    "cut --png": ["cut", "tunnel", "-o", "blocks.toml", "--png", f"{NOWHERE}/blocks.png"],
    "fos": ["fos", "jointed_slope_fos", "-o", f"{NOWHERE}/fos", "--serial"],
    "ensemble": ["ensemble", "jointed_slope_ensemble", "-o", f"{NOWHERE}/e", "--serial"],
    "tradeoff": ["tradeoff", "sliding_block", "-o", f"{NOWHERE}/tr", "--serial"],
    "render": ["render", "run", "-o", f"{NOWHERE}/frame.png"],
    "plot": ["plot", "run", "-o", f"{NOWHERE}/plots"],
    "movie": ["movie", "run", "-o", f"{NOWHERE}/movie.gif"],
    "verify": ["verify", "self_weight", "-o", f"{NOWHERE}/verify"],
}
# what each command computes; called, the test fails ("nothing computed")
WORK = [
    "dda.simulate",
    "dda.commands.cli.load_with_progress",
    "dda.scene.rockmass.expand.cut_rock_mass",
    "dda.tradeoff.runner.sweep",
    "dda.io.frame_files.read_found_frame",
    "dda.io.history_plots.plot_histories",
    "verify.harness.cases.run_case",
    "verify.harness.cases.Case.load",
]


@pytest.fixture
def workdir(tmp_path, monkeypatch) -> Path:
    """A folder with a written run (two frames and a measurement) as the working folder;
    the commands' work replaced by a failure."""
    monkeypatch.chdir(tmp_path)
    writer = RunWriter("run", image=False)
    for step in range(2):
        writer.add_frame(falling_frame(step))
    writer.finish()
    Path("run/history_points.csv").write_text("step,time,p.ux\n0,0.0,0.0\n1,0.1,0.0\n")

    def computed(*args, **kwargs):
        raise AssertionError("the command computed before checking its output")

    for target in WORK:
        monkeypatch.setattr(target, computed)
    return tmp_path


def _listing(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in sorted(root.rglob("*"))}


@pytest.mark.parametrize("argv", COMMANDS.values(), ids=COMMANDS.keys())
def test_an_unwritable_output_is_refused_before_any_work(workdir, capsys, argv):
    before = _listing(workdir)
    start = time.perf_counter()
    code = cli.main(argv)
    seconds = time.perf_counter() - start
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert seconds < 2.0
    assert len(lines) == 1 and NOWHERE in lines[0] and "Traceback" not in err
    assert ".tmp-" not in lines[0]
    assert _listing(workdir) == before  # nothing written, nothing removed


def test_a_failed_write_names_the_file_asked_for_not_a_temporary(tmp_path):
    from dda.io.atomic import atomic_path

    target = tmp_path / "gone" / "final.png"  # its folder vanished after the checks
    with pytest.raises(FileNotFoundError) as caught, atomic_path(target) as tmp:
        tmp.write_bytes(b"png")
    assert caught.value.filename == str(target)
    assert ".tmp-" not in str(caught.value)


def test_ffmpeg_failing_is_one_line_without_its_output(workdir, tmp_path, capfd, monkeypatch):
    """An ffmpeg that refuses (here a stand-in that prints and exits 1) gives one line that
    ends with ffmpeg's last message: no ffmpeg output on the terminal, no traceback, no
    broken pipe; nothing written."""
    pytest.importorskip("imageio_ffmpeg")
    monkeypatch.undo()  # the real reading of frames
    monkeypatch.chdir(workdir)
    fake = tmp_path / "ffmpeg"
    fake.write_text(
        "#!/bin/sh\n"
        'if [ "$1" = "-version" ]; then echo "ffmpeg version 9"; exit 0; fi\n'
        'echo "ffmpeg chatter" >&2\necho "Unknown encoder \'libx264\'" >&2\nexit 1\n'
    )
    fake.chmod(0o755)
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", str(fake))
    capfd.readouterr()
    assert cli.main(["movie", "run", "-o", "clip.mp4", "--size", "320", "240"]) == 1
    err = capfd.readouterr().err
    assert err.strip().splitlines() == [
        "dda movie: clip.mp4: ffmpeg could not write the movie (Unknown encoder 'libx264')"
    ]
    assert not any(p.name.startswith("clip") for p in workdir.iterdir())
    assert os.listdir(workdir / "run").count("movie.mp4") == 0
