"""Exceptions raised by the engine."""

from __future__ import annotations


class SceneError(ValueError):
    """A scene that cannot run: names the file, the key and what is wrong.

    Parameters
    ----------
    source
        The file the scene came from (``"<text>"`` or ``"<dict>"`` otherwise).
    key
        Dotted key path of the offending entry, e.g. ``"blocks[2].vertices"``.
    reason
        What is wrong, in plain words.
    """

    def __init__(self, source: str, key: str, reason: str) -> None:
        self.source = source
        self.key = key
        self.reason = reason
        super().__init__(f"{source}: {key}: {reason}")


class SimulationError(RuntimeError):
    """A run that cannot go on (a step that never settles, a non-finite value).

    The message says at which step and time, and why.
    """
