"""A small TOML writer for scenes (tables, arrays of tables, inline arrays).

Enough for what :mod:`tomllib` reads back from a scene: strings, booleans,
integers, floats (including inf and nan), arrays, tables and arrays of
tables. ``tomllib.loads(dumps(d)) == d`` for such data (nan aside).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from typing import Any

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def dumps(data: Mapping[str, Any]) -> str:
    """TOML text for a mapping: scalars first, then tables, then arrays of tables."""
    lines: list[str] = []
    _table(lines, (), data)
    return "\n".join(lines).strip("\n") + "\n"


def _table(lines: list[str], path: tuple[str, ...], table: Mapping[str, Any]) -> None:
    subtables, arrays = [], []
    for key, value in table.items():
        if isinstance(value, Mapping):
            subtables.append((key, value))
        elif _is_table_array(value):
            arrays.append((key, value))
        else:
            lines.append(f"{_key(key)} = {_value(value)}")
    for key, value in subtables:
        if _needs_header(value):
            lines.extend(["", f"[{_path(path + (key,))}]"])
        _table(lines, path + (key,), value)
    for key, items in arrays:
        for item in items:
            lines.extend(["", f"[[{_path(path + (key,))}]]"])
            _table(lines, path + (key,), item)


def _needs_header(table: Mapping[str, Any]) -> bool:
    """A table made only of sub-tables is defined implicitly by their headers."""
    return not table or any(
        not isinstance(v, Mapping) and not _is_table_array(v) for v in table.values()
    )


def _is_table_array(value: Any) -> bool:
    return (
        isinstance(value, list | tuple)
        and len(value) > 0
        and all(isinstance(v, Mapping) for v in value)
    )


def _path(path: tuple[str, ...]) -> str:
    return ".".join(_key(k) for k in path)


def _key(key: str) -> str:
    if not isinstance(key, str):
        raise TypeError(f"TOML keys are strings, got {key!r}")
    return key if _BARE_KEY.fullmatch(key) else _string(key)


def _string(text: str) -> str:
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _float(value)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, Mapping):
        inner = ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items())
        return "{" + inner + "}" if inner else "{}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return _value(value.tolist())
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _float(x: float) -> str:
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    text = repr(x)
    return text if any(c in text for c in ".eE") else text + ".0"
