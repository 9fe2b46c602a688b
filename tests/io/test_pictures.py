"""What the pictures say: units with prefixes, forces per metre, the contact-force scale, no
colour bar of round-off, a field of one value in one colour, a range given, whole titles,
text in any script without warnings."""

from __future__ import annotations

import dataclasses
import logging
import warnings

import numpy as np
import pytest
from matplotlib.figure import Figure

from dda.io.fields import engineering_scale
from dda.io.images import render_frame
from tests.io.test_io import make_frame


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
     (1.6e6, "lb/ft²", (1.0, "lb/ft²")), (float("nan"), "Pa", (1.0, "Pa")),
     (5.45e3, "N/m", (1e3, "kN/m")), (3.2e3, "lb/ft", (1.0, "lb/ft"))],
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
    assert "contact normal force (length ∝ force; longest 2 kN/m)" in legend(drawn[-1])


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
    assert ax.get_ylabel() == "contact force (kN/m)"  # 2-D: per metre of thickness
    lines = ax.get_title().splitlines()
    assert len(lines) > 1 and max(len(line) for line in lines) <= 80
    assert " ".join(lines).startswith(title + ": contact forces between")
    assert max(abs(y) for line in ax.get_lines() for y in line.get_ydata()) == pytest.approx(190)


def _two_free_blocks(syy: tuple[float, float]):
    frame = make_frame((4, 4, 4))  # block 0 fixed, 1 and 2 free
    stresses = np.zeros((3, 3))
    stresses[1:, 1] = syy
    return dataclasses.replace(frame, stresses=stresses)


def _block_colours(figure) -> np.ndarray:
    """The face colours of the coloured blocks (the first collection of the axes)."""
    return figure.axes[0].collections[0].get_facecolors()[:, :3]


def test_a_field_of_one_value_to_round_off_is_one_colour_with_the_value_stated(tmp_path, drawn):
    """The wet slope's two blocks, syy -7.4975503 and -7.4975613 kPa (1.5e-6 of the value
    apart): one colour, the value on the bar, not full purple against full yellow."""
    render_frame(_two_free_blocks((-7497.5503, -7497.5613)), tmp_path / "f.png", scalars="syy")
    figure = drawn[-1]
    colours = _block_colours(figure)
    assert len(colours) == 2 and np.array_equal(colours[0], colours[1])
    label, ticks = colour_bar(figure)
    assert label == "stress yy (kPa), one value: the blocks differ by less than 1e-4 of it"
    assert ticks == ["-7.497556"]
    import matplotlib.image  # the picture itself: one colour at both blocks' middles

    image = matplotlib.image.imread(tmp_path / "f.png")[..., :3]
    middles = figure.axes[0].transData.transform(make_frame((4, 4, 4)).centroids[1:])
    rows, columns = (image.shape[0] - middles[:, 1]).astype(int), middles[:, 0].astype(int)
    left, right = image[rows, columns]
    assert np.array_equal(left, right) and not np.all(left > 0.95)  # one colour, not white


def test_a_field_that_varies_still_spans_the_map(tmp_path, drawn):
    render_frame(_two_free_blocks((-7497.0, -7000.0)), tmp_path / "f.png", scalars="syy")
    colours = _block_colours(drawn[-1])
    assert np.abs(colours[0] - colours[1]).max() > 0.5  # the map's two ends
    assert len(colour_bar(drawn[-1])[1]) > 2


def test_one_block_is_one_colour_with_its_value(tmp_path, drawn):
    frame = make_frame((4, 4))  # one free block
    frame = dataclasses.replace(frame, stresses=np.array([[0, 0, 0], [0, -322.35, 0]]))
    render_frame(frame, tmp_path / "f.png", units={"length": "ft", "force": "lb"})
    assert colour_bar(drawn[-1]) == ("stress yy (lb/ft²)", ["-322.35"])


def test_a_range_given_is_kept_and_values_beyond_it_are_announced(tmp_path, drawn):
    frame = _two_free_blocks((-9000.0, -7000.0))
    render_frame(frame, tmp_path / "f.png", scalars="syy", clim=(-8000.0, -7500.0))
    figure = drawn[-1]
    blocks = figure.axes[0].collections[0]
    assert blocks.get_clim() == (-8000.0, -7500.0)
    assert blocks.colorbar.extend == "both"  # arrows: values below and above the range


def test_render_takes_a_range(tmp_path, monkeypatch, capsys, drawn):
    from dda.commands import cli
    from dda.io import RunWriter

    monkeypatch.chdir(tmp_path)
    writer = RunWriter("run", image=False)
    writer.add_frame(_two_free_blocks((-9000.0, -7000.0)))
    writer.finish()
    assert cli.main(["render", "run", "-o", "r.png", "--range", "-8000", "-7500"]) == 0
    assert drawn[-1].axes[0].collections[0].get_clim() == (-8000.0, -7500.0)
    assert cli.main(["render", "run", "-o", "bad.png", "--range", "1", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["dda render: --range 1 1: the first number must be below the second"]
    assert not (tmp_path / "bad.png").exists()


def test_the_phreatic_line_is_drawn_within_the_view(tmp_path, drawn):
    """The wet slope's picture showed no water table; it must not widen the view either."""
    frame = make_frame((4, 4))
    render_frame(frame, tmp_path / "dry.png")
    dry = drawn[-1].axes[0]
    table = [[-100.0, 0.3], [100.0, 0.6]]  # far wider than the blocks
    render_frame(frame, tmp_path / "wet.png", water_table=table)
    wet = drawn[-1].axes[0]
    for limits in (wet.get_xlim(), wet.get_ylim(), dry.get_xlim(), dry.get_ylim()):
        assert max(abs(x) for x in limits) < 10.0  # the blocks' view, not the line's ±100
    line = wet.get_lines()[-1]
    np.testing.assert_array_equal(line.get_xydata()[1:-1], table)  # level beyond its ends
    assert "phreatic line" in legend(drawn[-1]) and "phreatic line" not in legend(drawn[-2])
    level = [[-1.0, 5.0], [1.0, 5.0]]  # a short line, extended across the view
    render_frame(frame, tmp_path / "level.png", water_table=level)
    ax = drawn[-1].axes[0]
    xy = ax.get_lines()[-1].get_xydata()
    assert xy[0, 0] <= ax.get_xlim()[0] and xy[-1, 0] >= ax.get_xlim()[1]
    assert set(xy[:, 1]) == {5.0}


def test_a_run_with_water_keeps_its_table_for_the_pictures_drawn_later(tmp_path):
    import json

    from dda.commands import cli

    assert cli.main(["run", "wet_slope", "-o", str(tmp_path / "ws"), "-q", "--no-picture"]) == 0
    summary = json.loads((tmp_path / "ws" / "summary.json").read_text())
    assert summary["water_table"][0] == [-17.470508075689, -9.740192378865]


def test_the_water_table_is_drawn_where_the_ground_has_carried_it():
    """With [seismic] the run moves the phreatic line with the ground: a picture of a
    frame whose ground block moved (0.19, 0.05) draws it moved so (it drew it at t = 0);
    without followers, where the scene gives it."""
    import matplotlib.pyplot as plt

    from dda.io.images import WATER_COLOUR, compose

    frame = make_frame((4, 4))
    frame = dataclasses.replace(frame, displacements=np.array([[0.19, 0.05], [0.3, -0.2]]))
    table = [[0.0, 0.5], [2.0, 0.7]]

    def line(follows):
        figure = compose([frame], [None], "syy", water_table=table, water_follows=follows)
        (drawn,) = [ln for ln in figure.axes[0].get_lines() if ln.get_color() == WATER_COLOUR]
        xy = np.column_stack(drawn.get_data())
        plt.close(figure)
        return xy[1:-1]  # the table's own points (the ends run on level)

    assert np.allclose(line(["block0"]), np.array(table) + [0.19, 0.05])
    assert np.allclose(line(()), table)


def test_lines_thin_and_contact_marks_stay_among_the_blocks_of_a_large_model():
    """Up to 400 blocks the outlines and contact marks keep their widths; 10,000 blocks
    draw them at a fifth (a smear of black outlines and magenta marks before). The
    largest force's mark is 6 % of the model's size, at most two median blocks across:
    a 100 × 100 grid of 1 m blocks draws it 2 m long, not 6 m."""
    from dda.io.images import line_scale, longest_contact_mark

    assert line_scale(1) == line_scale(400) == 1.0
    assert line_scale(10_000) == pytest.approx(0.2)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    grid = [square + [i, j] for i in range(100) for j in range(100)]
    frame = dataclasses.replace(make_frame(), vertices=grid, areas=np.ones(len(grid)))
    assert longest_contact_mark(frame) == pytest.approx(2.0)
    few = dataclasses.replace(frame, vertices=grid[:2], areas=np.ones(2))
    assert longest_contact_mark(few) == pytest.approx(0.06 * 2.0)


@pytest.mark.parametrize(
    ("name", "clim", "message"),
    [
        ("x.jpg", None, "a picture is written as .png"),  # was PNG data in x.jpg
        ("x.png", (5.0, 1.0), "must be below the second"),  # a colour bar without numbers
        ("x.png", (0.0, float("inf")), "give finite numbers"),
    ],
)
def test_render_frame_refuses_what_dda_render_refuses(tmp_path, name, clim, message):
    with pytest.raises(ValueError, match=message):
        render_frame(make_frame(), tmp_path / name, clim=clim)
    assert list(tmp_path.iterdir()) == []


def test_the_pictures_of_fos_and_ensemble_take_the_scenes_look():
    """failure.png and failing_K.png left out the phreatic line that final.png draws: both
    commands now draw with :func:`dda.io.images.scene_look`."""
    import inspect

    import dda
    import dda.commands.ensemble as ensemble
    import dda.commands.fos as fos
    from dda.io.images import scene_look

    wet = scene_look(dda.load_scene("cases/wet_slope.toml"))
    assert wet["water_table"][0] == [-17.470508075689, -9.740192378865]
    assert wet["water_follows"] == () and wet["units"]["length"] == "m"
    dry = scene_look(dda.load_scene("cases/jointed_slope_fos.toml"))
    assert "water_table" not in dry and dry["scene_title"]
    for module in (fos, ensemble):
        assert "**scene_look(scene)" in inspect.getsource(module)


def test_a_view_zooms_and_its_colours_follow_the_blocks_in_it(tmp_path, drawn):
    """`dda render` had no zoom: a tunnel's opening was a few pixels of a section tens of
    times wider. With ``view`` the axes show that part (with a 5 % margin), and the
    colour range is that of the blocks reaching into it."""
    frame = make_frame((4, 4, 4, 4))  # blocks at x 0-1, 1.2-2.2, 2.4-3.4, 3.6-4.6
    stresses = np.zeros((4, 3))
    stresses[:, 1] = [0.0, -1.0e6, -2.0e6, -8.0e6]  # block 0 is fixed (grey)
    frame = dataclasses.replace(frame, stresses=stresses)
    render_frame(frame, tmp_path / "all.png", scalars="syy")
    render_frame(frame, tmp_path / "zoom.png", scalars="syy", view=[[1.0, 0.0], [3.0, 1.0]])
    whole, zoom = drawn[-2].axes[0], drawn[-1].axes[0]
    assert whole.get_xlim()[1] > 4.6 and zoom.get_xlim()[1] < 3.2  # the fourth block cut off
    low, high = zoom.collections[0].get_clim()
    assert (low, high) == pytest.approx((-2.0e6, -1.0e6))  # not the -8e6 outside the view


def test_render_takes_a_view_and_refuses_one_that_holds_no_block(
    tmp_path, monkeypatch, capsys, drawn
):
    from dda.commands import cli
    from dda.io import RunWriter

    monkeypatch.chdir(tmp_path)
    writer = RunWriter("run", image=False)
    writer.add_frame(make_frame((4, 4, 4)))
    writer.finish()
    assert cli.main(["render", "run", "-o", "z.png", "--view", "1", "0", "2.5", "1"]) == 0
    assert drawn[-1].axes[0].get_xlim()[1] < 3.0
    for view, message in (
        (["9", "9", "10", "10"], "--view 9 9 10 10: holds no block (the blocks lie in x 0"),
        (["1", "0", "0", "1"], "--view 1 0 0 1: give XMIN YMIN XMAX YMAX, finite, each minimum"),
    ):
        assert cli.main(["render", "run", "-o", "bad.png", "--view", *view]) == 2
        assert capsys.readouterr().err.startswith(f"dda render: {message}")
        assert not (tmp_path / "bad.png").exists()
