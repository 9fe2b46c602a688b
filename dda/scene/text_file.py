"""Read a scene file's text (or a file it names): UTF-8, with or without a byte-order
mark; others explained.

TOML is UTF-8. Windows Notepad may write a byte-order mark before it (EF BB BF),
which tomllib takes for text ("Invalid statement at line 1, column 1"): it is
dropped. A file saved as UTF-16 or in a one-byte code page (Latin-1,
Windows-1252) is refused with the reason and the fix, not a codec error; a binary file
(a picture, a drawing given as the scene) is refused as such.
"""

from __future__ import annotations

import codecs
from pathlib import Path

from dda.errors import SceneError

HINT = "save it as UTF-8 (in Notepad: Save As, Encoding: UTF-8)"
SNIFFED = 256  # the bytes at the file's start that tell UTF-16 and binary data apart


def _utf16(data: bytes) -> bool:
    """True for UTF-16 text: a UTF-16 byte-order mark, or (without one) text whose
    characters are ASCII, every other byte of the file's start zero."""
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return True
    head = data[: SNIFFED - SNIFFED % 2]
    if len(head) < 2:
        return False
    high, low = head[1::2], head[0::2]  # little-endian ASCII: the high bytes zero
    return (not any(high) and all(low)) or (not any(low) and all(high))


def check_scene_file(path: Path) -> None:
    """Raise a SceneError (key ``<file>``) unless ``path`` is a regular file: a folder,
    a missing file and a device or pipe (``/dev/null``) each say so."""
    if path.is_dir():
        raise SceneError(str(path), "<file>", "is a directory, not a scene file")
    if not path.exists():
        raise SceneError(str(path), "<file>", "no such file")
    if not path.is_file():
        raise SceneError(str(path), "<file>", "is not a regular file (a scene is a TOML file)")


def read_scene_text(path: Path) -> str:
    """The text of the scene file ``path``.

    Raises
    ------
    SceneError
        Key ``<file>``: the file cannot be read, or is not UTF-8 (with the fix).
    """
    try:
        return read_text(path, "a scene is TOML text")
    except UnreadableText as exc:
        raise SceneError(str(path), "<file>", str(exc)) from None


class UnreadableText(ValueError):
    """A text file that cannot be read, or is not UTF-8 text: the reason and the fix."""


def read_text(path: Path, expected: str) -> str:
    """The UTF-8 text of ``path`` (a byte-order mark dropped); ``expected`` says what the
    file should hold, for a binary one ("a scene is TOML text").

    Raises
    ------
    UnreadableText
        The file cannot be read, is UTF-16 or in a one-byte code page, or is binary.
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise UnreadableText(f"cannot read: {exc.strerror or exc}") from None
    data = data.removeprefix(codecs.BOM_UTF8)
    if _utf16(data):
        raise UnreadableText(f"is UTF-16 text, not UTF-8; {HINT}")
    if b"\x00" in data[:SNIFFED]:
        raise UnreadableText(f"is not a text file (binary data): {expected}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise UnreadableText(
            f"is not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}: Latin-1 or "
            f"Windows-1252?); {HINT}"
        ) from None
