"""The colour range of a picture: what values map to which colour, so that colours read true.

A signed quantity whose values straddle zero (beyond round-off) gets a range symmetric
about zero and a diverging map (white at zero); anything else its own range and a
sequential map. A
field whose values differ by less than a colour can show (:data:`NEAR_CONSTANT` of their
largest magnitude: two blocks' syy of -7.4975503 and -7.4975613 kPa) is one value: the
blocks are drawn in one colour and the bar states the value, instead of stretching the
map over the noise (full purple against full yellow). A range given by the caller
(``--range``, a movie's shared range) is kept as given, and values beyond it are drawn
in the end colours, which the bar's arrows announce.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# values whose spread is at most this fraction of their largest magnitude are one value:
# a map's 256 colours resolve 4e-3 of its range, and a picture is read to about 1e-3 of a
# value; the wet slope's two blocks differ by 1.5e-6 of their syy (a solve's tolerance),
# a block's rotation of +2.3e-5 rad beside -0.61 is no sign change worth a diverging map
NEAR_CONSTANT = 1e-4
ONE_VALUE_PAD = 1e-3  # half-width of a one-value bar, as a fraction of the value (or 1)


@dataclass(frozen=True)
class ColourScale:
    """How values map to colours.

    Attributes
    ----------
    low, high
        The range of the map.
    cmap
        The matplotlib colour map's name.
    constant
        The value of every block when they differ by less than ``NEAR_CONSTANT`` (drawn in one
        colour, the map's middle), else None.
    extend
        Values beyond a given range: ``"neither"``, ``"min"``, ``"max"`` or ``"both"``
        (the colour bar's arrows).
    """

    low: float
    high: float
    cmap: str
    constant: float | None = None
    extend: str = "neither"

    @property
    def clim(self) -> tuple[float, float]:
        """``(low, high)``."""
        return (self.low, self.high)


def colour_scale(
    values: np.ndarray, signed: bool, clim: tuple[float, float] | None = None
) -> ColourScale:
    """The :class:`ColourScale` of ``values`` (NaN: blocks without a field, left out).

    Parameters
    ----------
    values
        All values that share the range.
    signed
        Whether the quantity has a meaningful sign (stress components).
    clim
        A range chosen by the caller, kept as given.
    """
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    if clim is not None:
        low, high = float(clim[0]), float(clim[1])
        cmap = "coolwarm" if signed and low < 0.0 < high else "viridis"
        return ColourScale(low, high, cmap, extend=_beyond(finite, low, high))
    if not finite.size:
        return ColourScale(0.0, 1.0, "viridis")
    low, high = float(finite.min()), float(finite.max())
    if near_constant(finite):
        value = float(np.mean(finite))
        pad = abs(value) * ONE_VALUE_PAD if value else 1.0
        return ColourScale(value - pad, value + pad, "viridis", constant=value)
    if signed and _straddles_zero(low, high):
        bound = max(-low, high)
        return ColourScale(-bound, bound, "coolwarm")
    return ColourScale(low, high, "viridis")


def _straddles_zero(low: float, high: float) -> bool:
    """Whether values from ``low`` to ``high`` have both signs beyond round-off
    (:data:`NEAR_CONSTANT` of the largest magnitude): a compressive field with one
    stress-free block at +1.5e-12 Pa beside −22 MPa, or rotations of −0.61 rad to
    +2.3e-5 rad, is one-signed, and keeps its own range
    and a sequential map, not half of a ±22 MPa diverging one."""
    noise = NEAR_CONSTANT * max(-low, high)
    return low < -noise and high > noise


def near_constant(finite: np.ndarray) -> bool:
    """Whether the values differ by less than :data:`NEAR_CONSTANT` of the largest; all
    zero is."""
    largest = float(np.abs(finite).max())
    return float(np.ptp(finite)) <= NEAR_CONSTANT * largest


def color_range(
    values: np.ndarray, signed: bool, clim: tuple[float, float] | None = None
) -> tuple[tuple[float, float], str]:
    """``((low, high), colour map name)`` of :func:`colour_scale`."""
    scale = colour_scale(values, signed, clim)
    return scale.clim, scale.cmap


def _beyond(finite: np.ndarray, low: float, high: float) -> str:
    """Which ends of ``[low, high]`` some values pass: the colour bar's ``extend``."""
    under = bool(finite.size and finite.min() < low)
    over = bool(finite.size and finite.max() > high)
    return {(False, False): "neither", (True, False): "min", (False, True): "max"}.get(
        (under, over), "both"
    )
