"""final.png drawn by a helper process that imports matplotlib while the run steps.

Importing matplotlib and its figure costs about 0.4 s of CPU, a sixth of a small
run's whole process (docs/benchmarks.md, start-up). When the machine has a core that
the other processes leave idle (the solver's thread policy would give two threads:
:mod:`dda.solve.thread_policy`), ``dda run`` starts ``python -P -m
dda.io.picture_process`` beside the run (``-P``: no module of the user's current
folder is imported in place of a library's). The helper imports matplotlib on that
core while the run steps and, unless the run's request has come already, draws two
blocks into memory (a process's first drawing loads fonts and sets up the layout and
the PNG encoder: about 0.2 s more than the next). The request is one pickled
``(frame, path, options)`` of :func:`dda.io.images.render_frame` on its standard
input; the helper draws it beside ``path`` and moves it there only while the run that
asked is alive, then exits 0 (1 when the drawing failed, with its error on standard
error, whose lines the run logs). Standard input closed without a request — the run
ended without a picture, or died — ends the helper at once, whatever it is doing.
The run draws in its own process when no core was free, and whenever the helper did
not draw.
"""

from __future__ import annotations

import io
import logging
import os
import pickle
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from dda.io.atomic import TEMP_MARK, temp_path_for
from dda.result import Frame

logger = logging.getLogger(__name__)

DRAW_SECONDS = 600.0  # the longest wait for the helper's picture before drawing here


class PictureProcess:
    """A started helper, waiting for its one picture."""

    def __init__(self, process: subprocess.Popen) -> None:
        self.process = process

    @classmethod
    def start(cls) -> PictureProcess | None:
        """The helper, started (None if it cannot start)."""
        if not sys.executable:  # an embedded interpreter: no Python to start
            return None
        command = [sys.executable, "-P", "-m", __name__, str(os.getpid())]
        try:
            process = subprocess.Popen(
                command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE, start_new_session=True,  # a Ctrl-C is the run's
            )  # fmt: skip
        except OSError as exc:
            logger.debug("no picture helper: %s", exc)
            return None
        return cls(process)

    def draw(self, frame: Frame, path: str | os.PathLike[str], **options: Any) -> bool:
        """Have the helper draw ``render_frame(frame, path, **options)``; whether it did
        (if not, its stray temporary files beside ``path`` are removed)."""
        request = pickle.dumps((frame, os.fspath(path), options), pickle.HIGHEST_PROTOCOL)
        try:
            _, errors = self.process.communicate(request, timeout=DRAW_SECONDS)
        except subprocess.TimeoutExpired:
            self.cancel()
            logger.warning("the picture helper took over %g s; drawing here", DRAW_SECONDS)
            errors = b""
        drawn = self.process.returncode == 0
        lines = errors.decode(errors="replace").splitlines()
        for line in lines:
            logger.log(logging.INFO if drawn else logging.DEBUG, "%s", line)
        if not drawn:
            reason = lines[-1] if lines else f"exit {self.process.returncode}"
            logger.info("the picture helper did not draw %s (%s); drawing here", path, reason)
            _remove_temporaries(Path(path))
        return drawn

    def cancel(self) -> None:
        """End the helper without a picture (nothing if it has ended)."""
        if self.process.returncode is not None:
            return
        if self.process.poll() is None:
            self.process.kill()
        self.process.communicate()


def serve(parent: int) -> int:
    """The helper's side: import matplotlib, warm up, draw the one request of the run
    whose process id is ``parent``."""
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    request = _Request()
    import matplotlib.backends.backend_agg  # noqa: F401  (the imports this process is for)
    import matplotlib.figure  # noqa: F401

    from dda.io.images import render_frame

    if not request.came.is_set():
        _warm_up()
    request.came.wait()
    frame, path, options = pickle.loads(request.data)
    path = Path(path)
    drawing = temp_path_for(path)
    try:
        render_frame(frame, drawing, **options)
    except Exception:  # the run draws it again and logs why it failed
        logger.exception("the picture helper could not draw %s", path)
        return 1
    if os.getppid() != parent:  # the run died while this drew: it wrote no picture
        drawing.unlink(missing_ok=True)
        return 1
    os.replace(drawing, path)
    return 0


class _Request:
    """Standard input, read on a thread of its own: ``came`` is set when the request
    is in; input closed without one ends the process at once."""

    def __init__(self) -> None:
        self.data = b""
        self.came = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        self.data = sys.stdin.buffer.read()
        if not self.data:
            os._exit(0)  # nothing is being written: the warm-up draws into memory
        self.came.set()


def _remove_temporaries(path: Path) -> None:
    """The temporary files a helper stopped mid-write leaves beside ``path``."""
    for stray in path.parent.glob(f"{path.stem}{TEMP_MARK}*{path.suffix}"):
        stray.unlink(missing_ok=True)


def _warm_up() -> None:
    """Draw two blocks into memory, as a run's picture is drawn."""
    from dda.io.fonts import unicode_text
    from dda.io.images import compose

    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    frame = Frame(
        time=0.0, step=0, names=("a", "b"), ids=np.arange(2),
        centroids=np.array([[0.5, 0.5], [0.5, 1.5]]), rotations=np.zeros(2),
        velocities=np.zeros((2, 3)), stresses=np.array([[0.0, -1.0, 0.0], [0.0, -2.0, 0.0]]),
        displacements=np.zeros((2, 2)), vertices=[square, square + [0.0, 1.0]],
        areas=np.ones(2), fixed=np.array([True, False]),
    )  # fmt: skip
    figure = compose([frame], [None], scene_title="warm-up")
    with unicode_text():
        figure.savefig(io.BytesIO(), format="png")


if __name__ == "__main__":
    code = serve(int(sys.argv[1]))
    sys.stderr.flush()
    os._exit(code)  # the picture is written and renamed: skip the interpreter's teardown
