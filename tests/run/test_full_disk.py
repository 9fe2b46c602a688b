"""A full disk mid-run: a clean error naming the file, a consistent prefix, a checkpoint
kept, and ``--resume`` finishing the run once space is freed (a small tmpfs, mounted
where the tests may; skipped elsewhere)."""

from __future__ import annotations

import json
import subprocess

from dda.commands.cli import main
from dda.io.pvd import read_pvd
from dda.run.checkpoint import read_checkpoint
from tests.tmpfs import mounted

RUN = ["sliding_block", "-q", "--save-every", "1"]  # 101 frames, about 0.8 MB on a tmpfs


def test_a_full_disk_stops_the_run_cleanly_and_resume_finishes_it(tmp_path, capsys):
    whole = tmp_path / "whole"
    assert main(["run", *RUN, "-o", str(whole)]) == 0
    with mounted(tmp_path / "small", size="256k") as disk:
        out = disk / "run"
        assert main(["run", *RUN, "-o", str(out)]) == 1
        err = capsys.readouterr().err
        assert f"dda run: cannot write {out}/" in err and "No space left on device" in err
        assert f"dda run sliding_block -o {out} --resume" in err and "Traceback" not in err
        summary = json.loads((out / "summary.json").read_text())  # whole, "running" or "failed"
        assert summary["status"] in ("running", "failed") and summary["steps"] < 100
        for index in ("blocks.pvd", "contacts.pvd"):  # the indexes list whole files only
            assert all(path.stat().st_size > 0 for _, path in read_pvd(out / index))
        rows = (out / "history.csv").read_bytes()
        assert rows.endswith(b"\n") and 1 < rows.count(b"\n") < 101 * 2
        assert read_checkpoint(out / "checkpoint.npz").step == 0
        assert not list(out.rglob("*.tmp-*"))
        subprocess.run(["mount", "-o", "remount,size=4m", str(disk)], check=True)
        assert main(["run", *RUN, "-o", str(out), "--resume"]) == 0
        assert json.loads((out / "summary.json").read_text())["status"] == "finished"
        assert (out / "history.csv").read_bytes() == (whole / "history.csv").read_bytes()
        assert not (out / "checkpoint.npz").exists()


def test_a_partial_append_is_cut_back_to_whole_rows(tmp_path, monkeypatch):
    """os.write may write part of the data on a full disk: the writer appends all of it
    or nothing (the file is cut back) and names the file."""
    import errno
    import os

    import pytest

    from dda.io.atomic import append_whole

    path = tmp_path / "h.csv"
    path.write_text("head\n")
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    real_write, calls = os.write, []

    def full_disk(fd, data):
        calls.append(len(data))
        if len(calls) == 1:
            return real_write(fd, bytes(data[:3]))  # a short write
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "write", full_disk)
    with pytest.raises(OSError, match="No space left on device") as caught:
        append_whole(fd, "1,2,3\n4,5,6\n", path)
    monkeypatch.undo()
    os.close(fd)
    assert caught.value.filename == str(path) and path.read_text() == "head\n"


def test_a_disk_too_full_to_start_is_refused_before_anything_is_written(tmp_path, capsys):
    """8 kB free: less than the first frame and checkpoint (dda.io.disk_space)."""
    with mounted(tmp_path / "tiny", size="8k") as disk:
        assert main(["run", *RUN, "-o", str(disk / "run")]) == 2
        assert list(disk.iterdir()) == []
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"dda run: -o {disk}/run: ")
    assert "free on its disk, less than the run writes before its first step" in err[0]


def test_a_disk_too_full_to_start_the_outputs_names_the_file(tmp_path, capsys, monkeypatch):
    """When the estimate lets a run start that the disk cannot hold (another process
    fills it), the write that fails is named."""
    from dda.io import disk_space

    monkeypatch.setattr(disk_space, "check_disk_space", lambda *args: None)
    with mounted(tmp_path / "tiny", size="8k") as disk:
        assert main(["run", *RUN, "-o", str(disk / "run")]) != 0
    err = capsys.readouterr().err
    assert f"{disk}/run/" in err and "No space left on device" in err
    assert "Traceback" not in err


def test_pictures_on_a_full_disk_name_the_file_and_leave_nothing(tmp_path, capsys):
    """The commands that draw (render, plot, movie as GIF and MP4, cut's picture) say
    which file a full disk stopped, exit 1 and leave no file or folder half made: an
    MP4 whose index ffmpeg could not write is not reported as written."""
    from dda.io.movie import mp4_available

    run = tmp_path / "run"  # a scene with [[measure]]: dda plot draws its histories
    assert main(["run", "bolted_block", "-q", "--no-picture", "-o", str(run)]) == 0
    capsys.readouterr()
    with mounted(tmp_path / "tiny", size="8k") as disk:
        commands = {
            "render": (["render", str(run), "-o", str(disk / "r.png")], disk / "r.png"),
            "plot": (["plot", str(run), "-o", str(disk / "plots")], disk / "plots/"),
            "movie": (["movie", str(run), "--every", "50", "-o", str(disk / "m.gif")],
                      disk / "m.gif"),
            "cut": (["cut", "tunnel", "-o", str(disk / "t.toml")], disk / "t.png"),
        }  # fmt: skip
        if mp4_available():
            mp4 = ["movie", str(run), "--every", "50", "-o", str(disk / "m.mp4")]
            commands["movie mp4"] = (mp4, disk / "m.mp4")
        for command, (argv, named) in commands.items():
            assert main(argv) == 1, command
            err = capsys.readouterr().err
            assert str(named).rstrip("/") in err, (command, err)
            assert "No space left on device" in err and "Traceback" not in err, (command, err)
            assert list(disk.iterdir()) == [], (command, list(disk.iterdir()))


def test_plots_into_new_nested_folders_on_a_full_disk_leave_no_folder(tmp_path, capsys):
    """dda plot -o a/b/plots made a, b and plots: a full disk removes all three."""
    run = tmp_path / "run"
    assert main(["run", "bolted_block", "-q", "--no-picture", "-o", str(run)]) == 0
    with mounted(tmp_path / "tiny", size="8k") as disk:
        assert main(["plot", str(run), "-o", str(disk / "a" / "b" / "plots")]) == 1
        assert list(disk.iterdir()) == []
    assert "No space left on device" in capsys.readouterr().err
