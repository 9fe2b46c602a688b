"""The pictures of a strength-reduction search and of an ensemble."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dda.io.atomic import atomic_path
from dda.stability.search import Outcome

# speeds below this fraction of the limit (blocks at rest: 0) are drawn on it, marked as
# such: the log axis then spans the decades that judge the trials, not sixteen
BELOW_LIMIT = 1e-6


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fos_plot(
    rows: Sequence[dict], outcome: Outcome, limit: float, path: Path, title: str, speed_unit: str
) -> Path:
    """The criterion (largest mean speed over the judged window) against F, the limit and the
    bracket marked; standing trials as circles, failing ones as crosses, and trials slower
    than :data:`BELOW_LIMIT` x the limit (at rest: 0) as triangles on that line."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    floor = BELOW_LIMIT * limit if limit > 0 else 1e-16
    at_rest = [float(r["speed"]) < floor for r in rows]  # False for NaN: an error ended it
    low = [r for r, rest in zip(rows, at_rest, strict=True) if rest]
    shown = [r for r, rest in zip(rows, at_rest, strict=True) if not rest]
    for failed, marker, label in ((False, "o", "stands"), (True, "x", "fails")):
        pick = [r for r in shown if bool(r["failed"]) == failed]
        speeds = [min(float(r["speed"]), 1e300) for r in pick]
        shown_label = label if pick else "_nolegend_"  # no legend entry without a point
        ax.scatter([float(r["factor"]) for r in pick], speeds, marker=marker, label=shown_label)
    if low:
        label = f"speed below {floor:.1g} {speed_unit} (at rest: 0)"
        factors = [float(r["factor"]) for r in low]
        ax.scatter(factors, [floor] * len(low), marker="v", color="C2", label=label)
    ax.axhline(limit, color="k", lw=0.8, ls="--", label=f"limit {limit:.3g} {speed_unit}")
    if outcome.stands is not None and outcome.fails is not None:
        ax.axvspan(outcome.stands, outcome.fails, color="C3", alpha=0.25, label="bracket")
    ax.set_yscale("log")
    ax.set_xlabel("strength reduction factor F")
    ax.set_ylabel(f"largest mean speed over the judged window ({speed_unit})")
    ax.set_title(f"{title}\n{outcome.describe()}" if title else outcome.describe(), fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return path


def ensemble_plot(
    values: Sequence[float],
    failed: Sequence[bool],
    label: str,
    path: Path,
    title: str,
    factor_of_safety: bool = False,
    outside: tuple[int, int] = (0, 0),
) -> Path:
    """Histogram of a drawn value (standing and failing realisations stacked; whole
    realisations on the count axis) and its empirical CDF; ``factor_of_safety``: the values
    are the realisations' factors of safety, and the CDF marks F = 1 (below it a
    realisation fails). ``outside``: how many realisations have a factor of safety below
    and above the search's bounds (not in ``values``): the CDF counts them, starting at the
    fraction below and ending short of 1 by the fraction above."""
    from matplotlib.ticker import MaxNLocator

    plt = _pyplot()
    values, failed = np.asarray(values, float), np.asarray(failed, bool)
    fig, (ax, cdf) = plt.subplots(1, 2, figsize=(9.6, 4.0), dpi=120)
    bins = np.histogram_bin_edges(values, bins="auto")
    ax.hist([values[~failed], values[failed]], bins=bins, stacked=True,
            label=["stands", "fails"], color=["C0", "C3"])  # fmt: skip
    ax.set_xlabel(label)
    ax.set_ylabel("realisations")
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: 1, 2, 3, never 1.25
    ax.legend(fontsize=8)
    order = np.sort(values)
    below_bounds, above_bounds = outside
    total = len(order) + below_bounds + above_bounds
    if len(order):  # from 0 at the smallest value up (an audit: drawn from 1/n, it misread)
        fractions = (below_bounds + np.arange(len(order) + 1)) / total
        cdf.step(np.concatenate([order[:1], order]), fractions, where="post")
    cdf.set_ylim(0.0, 1.02)
    if factor_of_safety:
        below = (below_bounds + int(np.count_nonzero(values < 1.0))) / total
        cdf.axvline(1.0, color="C3", lw=1.0, ls="--", label=f"F = 1 (fraction below: {below:.3g})")
        cdf.legend(fontsize=8, loc="lower right")
    cdf.set_xlabel(label)
    cdf.set_ylabel("fraction of realisations ≤ value")
    for a in (ax, cdf):
        a.grid(True, alpha=0.3)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    return path
