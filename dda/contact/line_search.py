"""Exact line search on the step's potential along a Newton direction.

Along D(α) = D + α ΔD the potential is π(α) = Π(D + α ΔD): the quadratic
part of the blocks plus the contact terms of :mod:`dda.contact.potential`.
Its derivative

    π'(α) = a + c α + Σ N_k(g_k + α δg_k) δg_k + Σ F_k(s_k + α δs_k) δs_k

(a = ΔDᵀ(K₀ D − F₀), c = ΔDᵀ K₀ ΔD > 0, δg = ∇g·ΔD, δs = ∇s·ΔD) is
continuous, non-decreasing and piecewise linear: its slope changes by
± p δg² (± ps δs²) where a contact's force reaches or leaves the tension it
holds (the friction bound). The minimiser is the root of π': sort those
breakpoints, follow π' from one to the next, and solve the linear piece where
it changes sign. O(m log m) for m contacts, with no solve of K. Since
π'' ≥ c, the root is at most −π'(0)/c: breakpoints beyond that are not sorted.
Large runs use a compiled twin of the same steps (one pass over the contacts,
a stable sort of the breakpoints that matter, one walk); it sums and orders ties
in another order, so the two agree to rounding.
"""

from __future__ import annotations

import numpy as np

from dda.contact.formulas import normal_force, normal_trial, shear_force, shear_trial
from dda.contact.potential import ContactTerms
from dda.jit import compiled, formula, kernel, select


@formula
def normal_break(trial, penalty, tension, dg):
    """(α, slope change, kept) where the normal trial λn + p g (``trial`` at α = 0)
    crosses −T along the line: α = (−T − trial) / (p δg), the slope changing by
    sign(δg) p δg² (entering the elastic piece when g grows); kept where p δg ≠ 0 and α
    is positive and finite."""
    rate = penalty * dg
    alpha = (-tension - trial) / select(rate != 0.0, rate, 1.0)
    jump = np.sign(dg) * penalty * dg * dg
    return alpha, jump, (rate != 0.0) & (alpha > 0.0) & np.isfinite(alpha)


@formula
def shear_breaks(trial, shear_penalty, bound, ds):
    """(α up, α down, slope change, live) where the shear trial λt + ps s (``trial`` at
    α = 0) reaches +b (leaving the stuck piece when δs > 0: the slope falls by
    sign(δs) ps δs²) and −b (δs < 0: it rises by as much), for a contact with a shear
    term and a bound (b > 0) that moves (ps δs ≠ 0)."""
    rate = shear_penalty * ds
    live = (shear_penalty > 0.0) & (bound > 0.0) & (rate != 0.0)
    divisor = select(rate != 0.0, rate, 1.0)
    jump = np.sign(ds) * shear_penalty * ds * ds
    return (bound - trial) / divisor, (-bound - trial) / divisor, jump, live


@formula
def normal_spring_after_start(trial, penalty, tension, dg):
    """p δg² where the normal term is elastic just after α = 0 (its trial λn + p g > −T,
    or = −T and rising), else 0."""
    elastic = (trial > -tension) | ((trial == -tension) & (dg > 0.0))
    return select(elastic, penalty * dg * dg, 0.0)


@formula
def shear_spring_after_start(trial, shear_penalty, bound, ds):
    """ps δs² where the shear term is stuck just after α = 0 (its trial |λt + ps s| < b,
    or at ±b and turning back) and there is one (ps > 0, b > 0), else 0."""
    inside = np.abs(trial) < bound
    inside = inside | ((trial == bound) & (ds < 0.0)) | ((trial == -bound) & (ds > 0.0))
    stuck = inside & (shear_penalty > 0.0) & (bound > 0.0)
    return select(stuck, shear_penalty * ds * ds, 0.0)


def _normal_breaks(terms: ContactTerms, g, dg):
    """(α, slope change) where λn + p g crosses −T along the line (α > 0 only)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha, jump, keep = normal_break(terms.normal_trial(g), terms.penalty, terms.tension, dg)
    return alpha[keep], jump[keep]


def _shear_breaks(terms: ContactTerms, s, ds):
    """(α, slope change) where λt + ps s crosses ±b along the line (α > 0 only)."""
    with np.errstate(over="ignore"):  # a bound not known yet (dda.contact.law.UNBOUNDED)
        up, down, jump, live = shear_breaks(
            terms.shear_trial(s), terms.shear_penalty, terms.bound, ds
        )
    alpha = np.concatenate([up[live], down[live]])
    jump = np.concatenate([-jump[live], jump[live]])
    keep = (alpha > 0.0) & np.isfinite(alpha)
    return alpha[keep], jump[keep]


def _slope_at_start(terms: ContactTerms, g, dg, s, ds) -> float:
    """Σ of the contact springs active just after α = 0 (weighted by δ²)."""
    t = terms
    normal = normal_spring_after_start(t.normal_trial(g), t.penalty, t.tension, dg)
    shear = shear_spring_after_start(t.shear_trial(s), t.shear_penalty, t.bound, ds)
    return float(np.sum(normal)) + float(np.sum(shear))


def line_minimum(
    terms: ContactTerms,
    gradient: float,
    curvature: float,
    g: np.ndarray,
    dg: np.ndarray,
    s: np.ndarray,
    ds: np.ndarray,
) -> tuple[float, bool]:
    """The α ≥ 0 that minimises π(α), and whether any contact changes piece before it.

    Parameters
    ----------
    terms : the contacts' frozen potential data
    gradient, curvature : a and c of the blocks' quadratic part (module docstring)
    g, dg, s, ds : (m,) penetration and shear motion at α = 0, and their rates along ΔD
    """
    if compiled(_line_minimum_kernel):
        t = terms
        arrays = (t.normal_base, t.penalty, t.tension, t.shear_base, t.shear_penalty, t.bound)
        arrays += (g, dg, s, ds)
        contiguous = (np.ascontiguousarray(x, dtype=np.float64) for x in arrays)
        return _line_minimum_kernel(*contiguous, float(gradient), float(curvature))
    slope0 = gradient + float(np.dot(terms.normal_force(g), dg) + np.dot(terms.shear_force(s), ds))
    if not slope0 < 0.0:
        return 0.0, False  # no descent along ΔD (already at the minimum)
    alpha_n, jump_n = _normal_breaks(terms, g, dg)
    alpha_t, jump_t = _shear_breaks(terms, s, ds)
    alphas = np.concatenate([alpha_n, alpha_t])
    jumps = np.concatenate([jump_n, jump_t])
    if curvature > 0.0:  # π' ≥ π'(0) + c α: the root is at most −π'(0)/c, later breaks
        reach = alphas <= -slope0 / curvature  # do not matter (and need no sorting)
        alphas, jumps = alphas[reach], jumps[reach]
    order = np.argsort(alphas, kind="stable")
    alphas, jumps = alphas[order], jumps[order]
    slope = curvature + _slope_at_start(terms, g, dg, s, ds)
    # slopes of π' on [0, α1], [α1, α2], ... and π' at each breakpoint
    slopes = slope + np.concatenate([[0.0], np.cumsum(jumps)])
    starts = np.concatenate([[0.0], alphas])
    with np.errstate(over="ignore", invalid="ignore"):  # breakpoints of UNBOUNDED bounds,
        rises = slopes[:-1] * np.diff(starts)  # ~1e300 away: π' there is +inf, past the root
        values = slope0 + np.concatenate([[0.0], np.cumsum(rises)])  # π'(starts)
    crossing = np.flatnonzero(values[1:] >= 0.0)
    k = int(crossing[0]) if len(crossing) else len(alphas)  # root on [starts[k], starts[k+1]]
    if slopes[k] <= 0.0:  # flat piece with π' < 0: cannot happen with c > 0
        return float(starts[min(k + 1, len(alphas))]), k > 0
    alpha = float(starts[k] - values[k] / slopes[k])
    return alpha, k > 0


# breakpoints the compiled line search sorts and walks: more are first halved around the
# root by π' at their median (sorting 100,000 breakpoints costs ~10 ms, a pass ~0.1 ms)
NARROWED = 256


def _line_minimum(lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, gradient, curvature):
    """Compiled :func:`line_minimum`: the same breakpoints; more than ``NARROWED`` of them
    are first halved around the root (π' at a sample median, summed over the breakpoints
    still kept), then the rest are sorted and walked as in the numpy path."""
    m = g.shape[0]
    slope0 = _derivative(lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, 0.0, gradient)
    if not slope0 < 0.0:
        return 0.0, False
    reach = -slope0 / curvature if curvature > 0.0 else np.inf
    alphas, jumps = np.empty(3 * m), np.empty(3 * m)
    count = 0
    slope = curvature
    for c in range(m):  # the formulas' work only where a contact has a spring or a break
        trial_n = normal_trial(lam_n[c], p[c], g[c])
        slope += normal_spring_after_start(trial_n, p[c], tension[c], dg[c])
        if p[c] * dg[c] != 0.0:  # (else normal_break keeps nothing)
            alpha, jump, kept = normal_break(trial_n, p[c], tension[c], dg[c])
            if kept and alpha <= reach:
                alphas[count], jumps[count] = alpha, jump
                count += 1
        if not (ps[c] > 0.0 and bound[c] > 0.0):
            continue  # no shear term: no spring, no break
        trial_t = shear_trial(lam_t[c], ps[c], s[c])
        slope += shear_spring_after_start(trial_t, ps[c], bound[c], ds[c])
        if ps[c] * ds[c] == 0.0:
            continue
        up, down, jump, _ = shear_breaks(trial_t, ps[c], bound[c], ds[c])
        if up > 0.0 and np.isfinite(up) and up <= reach:
            alphas[count], jumps[count] = up, -jump
            count += 1
        if down > 0.0 and np.isfinite(down) and down <= reach:
            alphas[count], jumps[count] = down, jump
            count += 1
    first = alphas[:count].min() if count else np.inf  # a contact changes piece before the
    # root when the root lies beyond the first breakpoint (π' < 0 there)
    start, value, kept = 0.0, slope0, count
    while kept > NARROWED:  # halve the breakpoints around the root: O(kept), no sort
        pivot = np.median(alphas[: kept : kept // 63 + 1])  # of a sample: about halves
        # π'(pivot) from the breakpoints: π' is linear between them, its slope growing
        # by each jump passed
        at_pivot = value + slope * (pivot - start)
        for i in range(kept):
            if alphas[i] < pivot:
                at_pivot += jumps[i] * (pivot - alphas[i])
        if not np.isfinite(at_pivot):
            break  # far breakpoints (bounds not known yet): the plain walk below
        below = at_pivot >= 0.0  # root on (start, pivot]: keep the breakpoints before it
        left = 0
        for i in range(kept):  # compact the kept ones in place
            if (alphas[i] < pivot) if below else (alphas[i] > pivot):
                alphas[left], jumps[left] = alphas[i], jumps[i]
                left += 1
            elif not below:  # passed on the way to the root: it changes the slope
                slope += jumps[i]
        if not below:
            start, value = pivot, at_pivot
        if left == kept:
            break
        kept = left
    order = np.argsort(alphas[:kept], kind="mergesort")
    for i in range(kept):
        at = alphas[order[i]]
        reached = value + slope * (at - start)
        if reached >= 0.0:  # the root lies on [start, at]
            if slope <= 0.0:
                return at, at > first
            root = start - value / slope
            return root, root > first
        value, start = reached, at
        slope += jumps[order[i]]
    if slope <= 0.0:
        return start, start > first
    root = start - value / slope
    return root, root > first


def _derivative(lam_n, p, tension, lam_t, ps, bound, g, dg, s, ds, alpha, total):
    """``total`` + Σ N(g + α δg) δg + Σ F(s + α δs) δs: the contacts' part of π'(α)."""
    for c in range(g.shape[0]):
        normal = normal_force(lam_n[c], p[c], tension[c], g[c] + alpha * dg[c])
        shear = shear_force(lam_t[c], ps[c], bound[c], s[c] + alpha * ds[c])
        total += normal * dg[c] + shear * ds[c]
    return total


_derivative = kernel(_derivative) or _derivative  # the compiled kernel calls compiled twins
_line_minimum_kernel = kernel(_line_minimum)
