"""A small progress bar for long runs, written to standard error.

On a terminal the bar is redrawn in place (``"\\r"``) at most ten times a
second; otherwise (a log file, a CI job) one line is written each time
progress passes another 5 %, so logs stay short. No third-party dependency.

Examples
--------
>>> bar = ProgressBar(total=1.0, label="run")  # doctest: +SKIP
>>> for step in range(1000):  # doctest: +SKIP
...     bar.update((step + 1) / 1000, step=step + 1, contacts=12)
>>> bar.close()  # doctest: +SKIP
"""

from __future__ import annotations

import shutil
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

WIDTH = 28  # characters of the bar itself
TTY_INTERVAL = 0.1  # seconds between redraws on a terminal
LINE_FRACTION = 0.05  # progress between lines when not on a terminal


class ProgressBar:
    """Progress of a quantity from 0 to ``total`` (steps, simulated seconds, ...).

    Parameters
    ----------
    total
        The value at completion (> 0).
    label
        Text in front of the bar.
    stream
        Where to write; default ``sys.stderr`` (looked up when the bar is made).
    aside
        A clock of seconds spent on something else than the work (a run's compiling of
        kernels, :func:`dda.jit.compile_seconds`): what it counts while the bar is shown
        is left out of the rate the ETA comes from, as it will not come again.
    """

    def __init__(
        self,
        total: float,
        label: str = "",
        stream: TextIO | None = None,
        aside: Callable[[], float] | None = None,
    ) -> None:
        self.total = float(total) if total and total > 0 else 1.0
        self._aside = aside
        self._aside_start = aside() if aside is not None else 0.0
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.value = 0.0
        self.info: dict[str, Any] = {}
        self._start = time.perf_counter()
        self._tty = _is_tty(self.stream)
        self._last_draw = -float("inf")
        self._line_bucket = -1  # last 5 % bucket written as a line (not a TTY)
        self._width = 0  # length of the last line drawn in place
        self._closed = False

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        if kind is None:
            self.close()
        else:  # an error ends the bar: no last line before its message
            self.abandon()

    def abandon(self) -> None:
        """End the bar without drawing it again (the line drawn in place is ended)."""
        if not self._closed and self._tty and self._width:
            self.stream.write("\n")
            self.stream.flush()
        self._closed = True

    @property
    def fraction(self) -> float:
        """Progress in ``[0, 1]``."""
        return min(max(self.value / self.total, 0.0), 1.0)

    def update(self, value: float, **info: Any) -> None:
        """Set the current value and extra ``name=value`` fields shown after the bar.

        Parameters
        ----------
        value
            Current progress, in the units of ``total``.
        **info
            Shown as ``name=value`` (floats with 4 significant digits); a value of None
            removes the field.
        """
        if self._closed:
            return
        self.value = float(value)
        for name, shown in info.items():
            if shown is None:
                self.info.pop(name, None)
            else:
                self.info[name] = shown
        if self._tty:
            now = time.perf_counter()
            if now - self._last_draw >= TTY_INTERVAL or self.fraction >= 1.0:
                self._last_draw = now
                self._draw_in_place()
        elif self._bucket() > self._line_bucket:
            self._write_line()

    def close(self) -> None:
        """Draw the final state and end the line. Further updates are ignored."""
        if self._closed:
            return
        if self._tty:
            self._draw_in_place()
            self.stream.write("\n")
        elif self._bucket() > self._line_bucket or self.fraction < 1.0:
            self._write_line()
        self.stream.flush()
        self._closed = True

    def text(self) -> str:
        """The current line, without control characters."""
        filled = int(round(self.fraction * WIDTH))
        bar = "#" * filled + "-" * (WIDTH - filled)
        elapsed = time.perf_counter() - self._start
        parts = [f"{self.label} [{bar}] {100 * self.fraction:5.1f}%", _duration(elapsed)]
        if 0.0 < self.fraction < 1.0:
            working = elapsed - self.aside_seconds()
            parts.append("eta " + _duration(working * (1.0 - self.fraction) / self.fraction))
        parts += [f"{name}={_format(value)}" for name, value in self.info.items()]
        return " ".join(parts).strip()

    def aside_seconds(self) -> float:
        """Seconds counted by ``aside`` since the bar was made (0 without it)."""
        if self._aside is None:
            return 0.0
        return max(self._aside() - self._aside_start, 0.0)

    def _draw_in_place(self) -> None:
        # cut to the terminal's width: a longer line wraps, and "\r" then redraws only
        # its last row, leaving a trail of rows behind
        line = self.text()[: max(shutil.get_terminal_size().columns - 1, 20)]
        padding = " " * max(self._width - len(line), 0)  # wipe a longer previous line
        self._width = len(line)
        self.stream.write("\r" + line + padding)
        self.stream.flush()

    def _write_line(self) -> None:
        self.stream.write(self.text() + "\n")
        self.stream.flush()
        self._line_bucket = self._bucket()

    def _bucket(self) -> int:
        return int(self.fraction / LINE_FRACTION + 1e-9)


def _is_tty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _format(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _duration(seconds: float) -> str:
    seconds = max(seconds, 0.0)
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, seconds = divmod(int(seconds), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{seconds:02d}" if hours else f"{minutes}:{seconds:02d}"
