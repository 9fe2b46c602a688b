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
        super().__init__(message(source, key, reason))


def message(source: str, key: str, reason: str) -> str:
    """``"source: key: reason"`` as a user reads it. A key in angle brackets stands for the
    whole file (``<file>``, ``<toml>``, ``<scene>``) and is left out; a source in them
    (``<text>``, ``<dict>``: no file) reads ``scene text``, ``scene dict``.

    >>> message("slope.toml", "<file>", "no such file")
    'slope.toml: no such file'
    >>> message("<dict>", "blocks[0].vertices", "fewer than 3 points")
    'scene dict: blocks[0].vertices: fewer than 3 points'
    """
    where = f"scene {source[1:-1]}" if _placeholder(source) else source
    return f"{where}: {reason}" if _placeholder(key) or not key else f"{where}: {key}: {reason}"


def _placeholder(name: str) -> bool:
    return len(name) > 2 and name.startswith("<") and name.endswith(">")


class SimulationError(RuntimeError):
    """A run that cannot go on (a step that never settles, a non-finite value).

    The message says at which step and time, and why.
    """
