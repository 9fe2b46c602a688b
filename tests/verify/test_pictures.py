"""The verification pictures' scales read true: tick labels that tell the ticks apart,
near-equal fields in one colour."""

from __future__ import annotations

import numpy as np
import pytest

from verify.pictures.field_layout import round_ticks
from verify.pictures.field_pictures import stress_range


@pytest.mark.parametrize(
    "clim",
    [
        (-1.0003e6, -0.9999e6),
        (-2.1e6, -1.9e6),
        (-1050220.0, -950180.0),
        (0.0, 100.0),
        (0.0, 2.5e-3),
        (12, 12.5),
    ],
)
def test_colour_bar_labels_print_each_tick_as_it_is(clim):
    """A narrow range about a large value printed -1e+06 at every tick."""
    ticks, fmt = round_ticks(clim)
    labels = [fmt % t for t in ticks]
    assert len(set(labels)) == len(ticks) >= 3 and len("".join(labels)) <= 40
    np.testing.assert_allclose([float(label) for label in labels], ticks, rtol=1e-12)
    assert "e" not in "".join(labels) or max(abs(ticks)) >= 1e5 or max(abs(ticks)) < 1e-3


def test_a_uniform_field_and_its_near_twin_take_one_colour():
    """DDA 4e-4 off a uniform FEM field was drawn yellow against purple."""
    low, high = stress_range(np.full(10, -1e6), np.full(4, -1.0004e6))
    assert high - low >= 0.1 * 1e6
    fraction = (-1e6 - low) / (high - low), (-1.0004e6 - low) / (high - low)
    assert abs(fraction[0] - fraction[1]) < 0.01
    assert stress_range(np.zeros(3), np.zeros(2)) == (-1.0, 1.0)
