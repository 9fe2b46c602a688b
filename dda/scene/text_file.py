"""Read a scene file's text: UTF-8, with or without a byte-order mark; others explained.

TOML is UTF-8. Windows Notepad may write a byte-order mark before it (EF BB BF),
which tomllib takes for text ("Invalid statement at line 1, column 1"): it is
dropped. A file saved as UTF-16 or in a one-byte code page (Latin-1,
Windows-1252) is refused with the reason and the fix, not a codec error.
"""

from __future__ import annotations

import codecs
from pathlib import Path

from dda.errors import SceneError

HINT = "save it as UTF-8 (in Notepad: Save As, Encoding: UTF-8)"


def read_scene_text(path: Path) -> str:
    """The text of the scene file ``path``.

    Raises
    ------
    SceneError
        Key ``<file>``: the file cannot be read, or is not UTF-8 (with the fix).
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(str(path), "<file>", f"cannot read: {exc.strerror or exc}") from None
    data = data.removeprefix(codecs.BOM_UTF8)
    if data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)) or b"\x00" in data[:256]:
        raise SceneError(str(path), "<file>", f"is UTF-16 text, not UTF-8; {HINT}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        reason = (
            f"is not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}: Latin-1 or "
            f"Windows-1252?); {HINT}"
        )
        raise SceneError(str(path), "<file>", reason) from None
