"""Stopping a run cleanly on SIGINT (Ctrl-C) or SIGTERM (``timeout``, batch schedulers).

:class:`StopOnSignal` turns the first such signal into a request the time
loop reads before each step (``dda.simulate(..., stop=...)``): the run ends
after the step under way, writes a checkpoint and its outputs with status
``"interrupted"``. A second signal stops at once (``KeyboardInterrupt``);
what is on disk then is what the last frame and checkpoint wrote, and the
caller writes its summary within :meth:`StopOnSignal.ignoring`, where a third
signal changes nothing. SIGKILL cannot be caught: the outputs written per
frame are the record then (:mod:`dda.io.run_writer`).
"""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType

log = logging.getLogger(__name__)

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopOnSignal:
    """A context in which SIGINT and SIGTERM ask the run to stop; call it to ask whether.

    Outside the main thread (where Python cannot set handlers) it installs
    nothing and never asks to stop.

    Parameters
    ----------
    label
        Prefix of the message written to stderr when a signal arrives.
    """

    def __init__(self, label: str = "dda") -> None:
        self.label = label
        self.signal: int | None = None
        self._previous: dict[int, object] = {}

    def __call__(self) -> bool:
        """True once a signal asked the run to stop."""
        return self.signal is not None

    @property
    def exit_code(self) -> int:
        """128 + the signal's number (130 for SIGINT, 143 for SIGTERM), the shell's way."""
        return 128 + int(self.signal or signal.SIGINT)

    @property
    def name(self) -> str:
        return signal.Signals(self.signal).name if self.signal else "none"

    def __enter__(self) -> StopOnSignal:
        if threading.current_thread() is threading.main_thread():
            for number in SIGNALS:
                self._previous[number] = signal.signal(number, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        self._previous.clear()

    @contextlib.contextmanager
    def ignoring(self) -> Iterator[None]:
        """Within the block SIGINT and SIGTERM are ignored (in the main thread): for the
        last few writes after a signal stopped the run at once, which a further
        impatient signal must not cut short."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        handlers = {number: signal.signal(number, signal.SIG_IGN) for number in SIGNALS}
        try:
            yield
        finally:
            for number, handler in handlers.items():
                signal.signal(number, handler)

    def _handle(self, number: int, frame: FrameType | None) -> None:
        if self.signal is not None:
            raise KeyboardInterrupt  # the second signal: stop now
        self.signal = number
        sys.stderr.write(
            f"\n{self.label}: {signal.Signals(number).name}: stopping after this step "
            "(again to stop at once)\n"
        )
        sys.stderr.flush()
