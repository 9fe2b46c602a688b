"""Counts in words, for the lines the commands print."""

from __future__ import annotations

from typing import Any


def counted(count: Any, noun: str) -> str:
    """``"1 run"``, ``"3 runs"`` (and ``"? runs"`` for a count not known)."""
    return f"{count} {noun}" + ("" if count == 1 else "s")
