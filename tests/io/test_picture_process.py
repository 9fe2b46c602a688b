"""final.png drawn by the helper process: the same picture, and the run's own drawing
whenever the helper does not draw."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from dda.io.images import render_frame
from dda.io.picture_process import PictureProcess
from dda.io.run_writer import RunWriter
from tests.io.test_io import make_frame

OPTIONS = {"scalars": "syy", "scene_title": "Two blocks", "units": {"length": "ft"}}


def test_the_helpers_picture_is_the_one_drawn_here_byte_for_byte(tmp_path):
    frame = make_frame((4, 5, 4))
    helper = PictureProcess.start()
    assert helper is not None
    assert helper.draw(frame, tmp_path / "helper.png", **OPTIONS)
    render_frame(frame, tmp_path / "here.png", **OPTIONS)
    drawn = (tmp_path / "helper.png").read_bytes()
    assert len(drawn) > 1000 and drawn == (tmp_path / "here.png").read_bytes()
    assert helper.process.returncode == 0


def test_a_helper_with_nothing_to_draw_ends_and_writes_nothing(tmp_path):
    helper = PictureProcess.start()
    helper.process.stdin.close()  # the run ended without a picture (or died)
    assert helper.process.wait(timeout=60) == 0
    cancelled = PictureProcess.start()
    cancelled.cancel()
    assert cancelled.process.returncode is not None
    assert list(tmp_path.iterdir()) == []


def test_a_helper_that_cannot_draw_says_so(tmp_path, caplog):
    helper = PictureProcess.start()
    with caplog.at_level("DEBUG", logger="dda.io.picture_process"):
        assert not helper.draw(make_frame(), tmp_path / "no such folder" / "final.png")
    assert helper.process.returncode == 1
    assert "could not draw" in caplog.text


def test_the_helper_imports_no_module_of_the_users_folder(tmp_path, monkeypatch):
    """A script of the user's called like a library (matplotlib.py, random.py, ...)
    must not run in the helper (``python -P``)."""
    folder = tmp_path / "project"
    folder.mkdir()
    marker = tmp_path / "ran"
    for name in ("matplotlib", "random", "dda"):
        (folder / f"{name}.py").write_text(f"open({str(marker)!r}, 'a').write('{name} ')\n")
    monkeypatch.chdir(folder)
    helper = PictureProcess.start()
    assert helper.draw(make_frame(), tmp_path / "final.png", **OPTIONS)
    assert not marker.exists() and (tmp_path / "final.png").stat().st_size > 1000


DIES_AFTER_ASKING = """
import os, pickle, sys
from dda.io.picture_process import PictureProcess
from tests.io.test_io import make_frame
helper = PictureProcess.start()
helper.process.stdin.write(pickle.dumps((make_frame(), sys.argv[1], {})))
helper.process.stdin.close()
print(helper.process.pid, flush=True)
os._exit(0)  # the run dies while the helper draws
"""


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="watches the helper through /proc")
def test_a_run_that_died_while_its_helper_drew_gets_no_picture(tmp_path):
    path = tmp_path / "final.png"
    out = subprocess.run(
        [sys.executable, "-c", DIES_AFTER_ASKING, str(path)], capture_output=True, text=True
    )
    helper = int(out.stdout)
    for _ in range(600):  # the helper ends after its drawing (a minute at most)
        if not _alive(helper):
            break
        time.sleep(0.1)
    assert not _alive(helper)
    assert list(tmp_path.iterdir()) == []  # neither final.png nor its temporary file


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_a_helper_that_did_not_draw_leaves_no_temporary_file(tmp_path):
    stray = tmp_path / "final.tmp-0badc0de.png"  # as a helper killed mid-write leaves it
    stray.write_bytes(b"half a picture")
    helper = PictureProcess.start()
    assert not helper.draw(make_frame(), tmp_path / "final.png", scalars="no such field")
    assert list(tmp_path.iterdir()) == []


class _Helper:
    """A stand-in helper: whether it draws, what was asked of it."""

    def __init__(self, draws: bool) -> None:
        self.draws, self.asked, self.cancelled = draws, [], False

    def draw(self, frame, path, **options) -> bool:
        self.asked.append((frame.step, path.name, options["scalars"]))
        return self.draws

    def cancel(self) -> None:
        self.cancelled = True


def test_the_run_draws_its_picture_when_the_helper_did_not(tmp_path):
    helper = _Helper(draws=False)
    writer = RunWriter(tmp_path / "run", picture=helper)
    writer.add_frame(make_frame(step=3))
    summary = writer.finish()
    assert helper.asked == [(3, "final.png", "syy")]
    assert summary["image"] == "final.png"
    assert (tmp_path / "run" / "final.png").stat().st_size > 1000


def test_a_picture_that_cannot_be_drawn_is_one_line_and_the_run_goes_on(tmp_path, caplog):
    writer = RunWriter(tmp_path / "run", picture=_Helper(draws=False))
    writer.add_frame(make_frame(step=3))
    (tmp_path / "run" / "final.png").mkdir()  # no picture can be moved there
    with caplog.at_level("INFO"):
        summary = writer.finish()
    assert summary["image"] is None and (tmp_path / "run" / "summary.json").is_file()
    errors = [r for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 1 and errors[0].exc_info is None
    assert "could not draw" in errors[0].getMessage() and "final.png" in errors[0].getMessage()


def test_a_helper_that_drew_leaves_the_picture_to_it(tmp_path):
    helper = _Helper(draws=True)
    writer = RunWriter(tmp_path / "run", picture=helper)
    writer.add_frame(make_frame(step=3))
    assert writer.finish()["image"] == "final.png"
    assert not (tmp_path / "run" / "final.png").exists()  # the stand-in draws nothing


def test_a_run_without_a_picture_ends_its_helper(tmp_path):
    helper = _Helper(draws=True)
    writer = RunWriter(tmp_path / "run", picture=helper)
    writer.add_frame(make_frame(step=3))
    writer.image = False  # as after a failed write (a full disk)
    writer.finish()
    assert helper.cancelled and helper.asked == []
