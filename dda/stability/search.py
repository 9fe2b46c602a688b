"""The search for the factor of safety: bracket, then cut the bracket into equal parts.

With the outcomes known so far (F -> failed?), the bracket is [F_s, F_f]: F_f the
smallest failing F, F_s the largest standing F below it. The first round tries the
bounds ``lower`` and ``upper``; while F_f − F_s exceeds the tolerance, each round
tries ``width`` factors evenly inside the bracket (bisection for one worker; the
bracket shrinks by width + 1 per round). The factor of safety is the bracket's middle,
within half the tolerance of the F at which the model first fails. A model that fails
at ``lower`` has FoS < lower; one that stands at ``upper`` has FoS > upper.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from dda.scene.stability import DIGITS  # trial factors' decimals


@dataclass(frozen=True)
class Outcome:
    """The search's answer: FoS (None outside the bounds) and its bracket."""

    fos: float | None
    stands: float | None  # largest standing F below the smallest failing one
    fails: float | None  # smallest failing F
    verdict: str  # "found", "below" (fails at lower), "above" (stands at upper)

    def describe(self) -> str:
        if self.verdict == "below":
            return f"FoS < {self.fails:g}: the model fails at the lower bound"
        if self.verdict == "above":
            return f"FoS > {self.stands:g}: the model stands at the upper bound"
        return f"FoS = {self.fos:.4g} (stands at F = {self.stands:.6g}, fails at {self.fails:.6g})"


def bracket(known: Mapping[float, bool]) -> tuple[float | None, float | None]:
    """(F_s, F_f) of the outcomes ``known``; None where there is none."""
    fails = min((f for f, failed in known.items() if failed), default=None)
    stands = max(
        (f for f, failed in known.items() if not failed and (fails is None or f < fails)),
        default=None,
    )
    return stands, fails


def next_factors(
    known: Mapping[float, bool], lower: float, upper: float, tolerance: float, width: int
) -> list[float]:
    """The factors of the next round (empty when the search is over)."""
    missing = [f for f in (round(lower, DIGITS), round(upper, DIGITS)) if f not in known]
    if missing:
        return missing
    stands, fails = bracket(known)
    if stands is None or fails is None or fails - stands <= tolerance:
        return []
    step = (fails - stands) / (width + 1)
    inside = {round(stands + step * k, DIGITS) for k in range(1, width + 1)}
    return sorted(f for f in inside if f not in known)  # none: as narrow as DIGITS allow


def outcome(known: Mapping[float, bool]) -> Outcome:
    """The answer of a finished search."""
    stands, fails = bracket(known)
    if stands is None:
        return Outcome(None, None, fails, "below")
    if fails is None:
        return Outcome(None, stands, None, "above")
    return Outcome(0.5 * (stands + fails), stands, fails, "found")


def search(
    run: Callable[[list[float]], Iterable[tuple[float, bool]]],
    lower: float,
    upper: float,
    tolerance: float,
    width: int = 1,
) -> Outcome:
    """Run rounds of trials until the bracket is within ``tolerance``.

    ``run(factors)`` runs the trials of one round and yields (F, failed) as they finish.
    """
    known: dict[float, bool] = {}
    while factors := next_factors(known, lower, upper, tolerance, width):
        for factor, failed in run(factors):
            known[round(factor, DIGITS)] = failed
    return outcome(known)
