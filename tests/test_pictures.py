"""What the pictures say: units with prefixes, the contact-force scale, no colour bar of
round-off, whole titles, text in any script without warnings."""

from __future__ import annotations

import dataclasses
import logging
import warnings

import numpy as np
import pytest
from matplotlib.figure import Figure

from dda.io.fields import engineering_scale
from dda.io.images import render_frame
from tests.test_io import make_frame


@pytest.fixture
def drawn(monkeypatch):
    """The figures saved while the test runs (Figure.savefig still writes them)."""
    figures, save = [], Figure.savefig

    def keep(figure, *args, **kwargs):
        figures.append(figure)
        return save(figure, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return figures


def colour_bar(figure):
    axes = figure.axes[-1]  # the colour bar's
    return axes.get_xlabel(), [t.get_text() for t in axes.get_xticklabels()]


def legend(figure) -> list[str]:
    return [t.get_text() for t in figure.legends[0].get_texts()]


@pytest.mark.parametrize(
    ("magnitude", "unit", "expected"),
    [(1.6e6, "Pa", (1e6, "MPa")), (8e5, "Pa", (1e3, "kPa")), (999.0, "Pa", (1.0, "Pa")),
     (3e10, "Pa", (1e9, "GPa")), (4e12, "Pa", (1e9, "GPa")), (5.7e6, "N", (1e6, "MN")),
     (1.6e6, "lb/ft²", (1.0, "lb/ft²")), (float("nan"), "Pa", (1.0, "Pa"))],
)  # fmt: skip
def test_large_si_numbers_take_a_prefix(magnitude, unit, expected):
    assert engineering_scale(magnitude, unit) == expected


def test_stresses_of_megapascals_read_in_mpa(tmp_path, drawn):
    frame = make_frame((4, 4, 4))
    frame = dataclasses.replace(frame, stresses=np.array([[0, -1.6e6, 0], [0, -0.8e6, 0]] * 2)[:3])
    render_frame(frame, tmp_path / "f.png", scalars="syy")
    label, ticks = colour_bar(drawn[-1])
    assert label == "stress yy (MPa)"
    assert "-1.5" in ticks and not any("e+" in t for t in ticks)  # was -1.5e+06 (Pa)


def test_the_contact_marks_have_a_scale_shared_by_the_frames(tmp_path, drawn):
    render_frame(make_frame((4, 4)), tmp_path / "f.png")
    assert "contact normal force (length ∝ force; longest 2 kN)" in legend(drawn[-1])


def test_a_free_blocks_round_off_stress_is_drawn_as_zero(tmp_path, drawn):
    frame = make_frame((4, 4), contacts=False)
    frame = dataclasses.replace(frame, stresses=np.array([[0, 0, 0], [2e-10, -8e-10, 3e-10]]))
    render_frame(frame, tmp_path / "f.png", scalars="syy")
    label, ticks = colour_bar(drawn[-1])
    assert label == "stress yy (Pa)" and "0" in ticks
    assert not any("e-" in t for t in ticks)  # not ±8e-10: a bar of -1..1 Pa


def test_text_in_any_script_draws_without_warnings(tmp_path, drawn, caplog):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a glyph warning would fail the test
        with caplog.at_level(logging.INFO, logger="dda.io.fonts"):
            render_frame(make_frame((4, 4)), tmp_path / "f.png", scene_title="斜面 Hang")
    assert drawn[-1].get_suptitle() == "斜面 Hang"
    from dda.io.fonts import installed_fallbacks

    if installed_fallbacks() == ["DejaVu Sans"]:  # no font with these glyphs here
        assert "no installed font draws" in caplog.text and "Noto Sans CJK" in caplog.text


def test_plot_titles_wrap_and_the_unit_is_said_once(tmp_path, drawn):
    from dda.io.history_plots import _draw

    time = np.linspace(0.0, 1.0, 11)
    curves = {"crown.N": 1.9e5 + 0 * time, "crown.fx": 1.5e5 + 0 * time}
    title = "Circular tunnel excavated in stages, then bolted"
    _draw(tmp_path / "c.png", time, curves, "contact_force", title, None)
    ax = drawn[-1].axes[0]
    assert ax.get_ylabel() == "contact force (kN)"
    lines = ax.get_title().splitlines()
    assert len(lines) > 1 and max(len(line) for line in lines) <= 80
    assert " ".join(lines).startswith(title + ": contact forces between")
    assert max(abs(y) for line in ax.get_lines() for y in line.get_ydata()) == pytest.approx(190)
