"""A second Ctrl-C stops ``dda run`` at once, yet its summary still says "interrupted" and
the command that continues the run is printed (docs/runs.md, "Stopping a run")."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dda.commands import cli
from tests.commands.test_cli import SMALL_SCENE


def _status(folder: Path) -> str | None:
    try:
        return json.loads((folder / "summary.json").read_text())["status"]
    except (OSError, ValueError, KeyError):
        return None


@pytest.mark.parametrize("pause", [0.0, 0.05], ids=["together", "50 ms apart"])
def test_two_quick_ctrl_c_during_the_tunnel_leave_it_interrupted(tmp_path, pause):
    """The shipped tunnel, SIGINT twice while it steps: exit 130, "interrupted", the
    resume command on stderr. (The numpy path, no kernels to compile first, with SuperLU:
    PARDISO called from the numpy path stops this process with a segmentation fault in
    the equilibrium start, a fault of dda.solve reported apart.)"""
    env = {**os.environ, "DDA_NO_NUMBA": "1", "DDA_SOLVER": "superlu"}
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    command = [sys.executable, "-m", "dda", "run", "tunnel", "-o", "out"]
    process = subprocess.Popen(
        command, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    deadline, out = time.monotonic() + 120, tmp_path / "out"
    while not (_status(out) == "running" and (out / "checkpoint.npz").is_file()):
        assert time.monotonic() < deadline
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    time.sleep(pause)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err
    assert _status(tmp_path / "out") == "interrupted"
    assert "continue with: dda run tunnel -o out --resume" in err
    assert "Traceback" not in err


def test_a_second_ctrl_c_while_the_picture_is_drawn(tmp_path, monkeypatch, capsys):
    """Both signals as final.png is drawn (the run has ended): the summary keeps the run's
    status without the picture, and the command exits 130, saying how to draw it."""
    from dda.io import run_writer

    def interrupted_twice(self, frame, summary):
        os.kill(os.getpid(), signal.SIGINT)  # the first: asks the run to stop
        os.kill(os.getpid(), signal.SIGINT)  # the second: at once
        raise AssertionError("the second signal did not stop the drawing")

    monkeypatch.setattr(run_writer.RunWriter, "_render_final", interrupted_twice)
    monkeypatch.chdir(tmp_path)
    Path("ok.toml").write_text(SMALL_SCENE)
    assert cli.main(["run", "ok.toml", "-o", "out", "-q"]) == 130
    summary = json.loads(Path("out/summary.json").read_text())
    assert summary["status"] == "finished" and "image" not in summary
    assert "dda render out draws it" in capsys.readouterr().err
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored


def test_a_second_ctrl_c_while_the_run_steps_in_process(tmp_path, monkeypatch, capsys):
    """Both signals between two frames: the summary says "interrupted", the checkpoint is
    kept and the resume command printed."""
    import dda

    real = dda.simulate

    def signalled(scene, **options):
        on_frame = options["on_frame"]

        def frame_then_signals(frame):
            on_frame(frame)
            if frame.step == 3:
                os.kill(os.getpid(), signal.SIGINT)
                os.kill(os.getpid(), signal.SIGINT)

        return real(scene, **{**options, "on_frame": frame_then_signals})

    monkeypatch.setattr(dda, "simulate", signalled)
    monkeypatch.chdir(tmp_path)
    Path("ok.toml").write_text(SMALL_SCENE)
    assert cli.main(["run", "ok.toml", "-o", "out", "-q", "--checkpoint-every", "1"]) == 130
    assert json.loads(Path("out/summary.json").read_text())["status"] == "interrupted"
    err = capsys.readouterr().err
    assert "continue with: dda run ok.toml -o out --resume" in err
    monkeypatch.setattr(dda, "simulate", real)
    assert cli.main(["run", "ok.toml", "-o", "out", "-q", "--resume"]) == 0
    assert json.loads(Path("out/summary.json").read_text())["status"] == "finished"
