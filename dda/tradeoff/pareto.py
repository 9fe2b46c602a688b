"""Pareto fronts: the runs no other run beats in both error and time."""

from __future__ import annotations

import math


def pareto_front(rows: list[dict]) -> list[dict]:
    """Rows not dominated in (error, seconds), sorted by seconds.

    Row a dominates row b when a.error ≤ b.error and a.seconds ≤ b.seconds
    with one of them strict. Rows without an error (failed runs) are left out.
    Sorted by time, the front's error decreases strictly.
    """
    usable = [r for r in rows if not math.isnan(r["error"])]
    usable.sort(key=lambda r: (r["seconds"], r["error"]))
    front, best = [], math.inf
    for row in usable:
        if row["error"] < best:
            front.append(row)
            best = row["error"]
    return front


def fronts_by_method(rows: list[dict]) -> dict[str, list[dict]]:
    """One front per contact method."""
    methods = sorted({r["method"] for r in rows})
    return {m: pareto_front([r for r in rows if r["method"] == m]) for m in methods}


def cheapest_within(rows: list[dict], error: float) -> dict | None:
    """The fastest run whose error is at most ``error`` (None if there is none)."""
    ok = [r for r in rows if not math.isnan(r["error"]) and r["error"] <= error]
    return min(ok, key=lambda r: r["seconds"]) if ok else None
