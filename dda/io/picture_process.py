"""final.png drawn by a helper process that imports matplotlib while the run steps.

Importing matplotlib and its figure costs about 0.4 s of CPU, a sixth of a small
run's whole process (docs/benchmarks.md, start-up). When the machine has a core that
the other processes leave idle (the solver's thread policy would give two threads:
:mod:`dda.solve.thread_policy`), ``dda run`` starts ``python -m
dda.io.picture_process`` beside the run. The
helper imports matplotlib on that core while the run steps and draws a picture of
two blocks into memory (a first drawing loads fonts and sets up the layout and the
PNG encoder: about 0.2 s more than the next), then reads one request
from its standard input — the pickled ``(frame, path, options)`` of
:func:`dda.io.images.render_frame` — draws it and exits 0 (1 when the drawing failed,
with its error on standard error, whose lines the run logs). Empty input — the run
ended without a picture, or died — ends the helper without drawing. The run draws
in its own process when no core was free, and whenever the helper did not draw.
"""

from __future__ import annotations

import io
import logging
import os
import pickle
import subprocess
import sys
from typing import Any

import numpy as np

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
        command = [sys.executable, "-m", __name__]
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
        """Have the helper draw ``render_frame(frame, path, **options)``; whether it did."""
        request = pickle.dumps((frame, os.fspath(path), options), pickle.HIGHEST_PROTOCOL)
        try:
            _, errors = self.process.communicate(request, timeout=DRAW_SECONDS)
        except subprocess.TimeoutExpired:
            self.cancel()
            logger.warning("the picture helper took over %g s; drawing here", DRAW_SECONDS)
            return False
        drawn = self.process.returncode == 0
        for line in errors.decode(errors="replace").splitlines():
            logger.log(logging.INFO if drawn else logging.DEBUG, "%s", line)
        return drawn

    def cancel(self) -> None:
        """End the helper without a picture."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.communicate()


def serve() -> int:
    """The helper's side: import matplotlib, read one request, draw it."""
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    import matplotlib.backends.backend_agg  # noqa: F401  (the imports this process is for)
    import matplotlib.figure  # noqa: F401

    from dda.io.images import render_frame

    _warm_up()
    data = sys.stdin.buffer.read()
    if not data:
        return 0
    frame, path, options = pickle.loads(data)
    try:
        render_frame(frame, path, **options)
    except Exception:  # the run draws it again and logs why it failed
        logger.exception("the picture helper could not draw %s", path)
        return 1
    return 0


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
    code = serve()
    sys.stderr.flush()
    os._exit(code)  # the picture is written and renamed: skip the interpreter's teardown
