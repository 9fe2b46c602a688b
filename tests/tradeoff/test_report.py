"""The study's outputs: the CSV keeps the measured values to the last bit, and the
Pareto picture fits its title and legend and says where errors of 0 are drawn."""

from __future__ import annotations

import csv

import numpy as np

from dda.tradeoff.cases import get_case
from dda.tradeoff.report import write_csv
from dda.tradeoff.runner import add_errors


def run_row(value: float, seconds: float = 0.2, method: str = "penalty") -> dict:
    """A finished run's row as run_task gives it."""
    setting = {"method": method, "penalty": 1.0, "tolerance": 1e-4, "time_step": 0.02}
    return {**setting, "ratio": 0.01, "case": "sliding_block", "status": "finished",
            "seconds": seconds, "seconds_all": [seconds] * 3, "repeats": 3, "threads": 1,
            "host": "here", "steps": 50, "max_penetration": 0.0, "value": [value]}  # fmt: skip


def test_the_csv_values_recompute_the_errors_of_the_sliding_block(tmp_path):
    """Its errors are ~1e-9 of the value: 8 digits (as written before) lost them."""
    case = get_case("sliding_block")
    exact = float(case.reference[0])
    rows = [run_row(exact * (1 + 1.234567e-9)), run_row(exact * (1 - 3.3e-10), seconds=0.3)]
    add_errors(rows, case, case.reference)
    write_csv(rows, tmp_path / "study.csv")
    with (tmp_path / "study.csv").open() as stream:
        read = list(csv.DictReader(stream))
    for row, line in zip(rows, read, strict=True):
        assert float(line["value"]) == row["value"][0]
        assert float(line["reference"]) == exact
        again = abs(float(line["value"]) - float(line["reference"])) / abs(exact)
        assert np.isclose(again, row["error"], rtol=1e-6, atol=0)

    # an audit: the penalty method's rows gave the grid's tolerance, which they ignore
    add_errors(mixed := [run_row(exact), run_row(exact, method="augmented-lagrangian")],
               case, case.reference)  # fmt: skip
    write_csv(mixed, tmp_path / "mixed.csv")
    with (tmp_path / "mixed.csv").open() as stream:
        tolerances = {line["method"]: line["tolerance"] for line in csv.DictReader(stream)}
    assert tolerances == {"penalty": "", "augmented-lagrangian": "0.0001"}


WALL_TITLE = (
    "wall: block displacements at 0.1 s (error / largest displacement), against a "
    "converged fine run"
)


def drawn_figure(rows: list[dict]):
    """The Pareto figure of ``rows`` with the wall's title, drawn (its layout done)."""
    from dda.tradeoff.report import pareto_figure

    fig = pareto_figure(rows, WALL_TITLE)
    fig.canvas.draw()
    return fig


def inside(box, outer) -> bool:
    return box.x0 >= outer.x0 and box.x1 <= outer.x1 and box.y0 >= outer.y0 and box.y1 <= outer.y1


def test_the_pareto_title_and_legend_fit_the_picture_and_do_not_overlap(tmp_path):
    """The wall's title was clipped at the left edge: the legend sat right of the plot
    and the title, centred over the narrowed plot, ran off the picture."""
    import matplotlib.pyplot as plt

    from dda.tradeoff.report import pareto_plot

    rows = [
        {"method": "augmented-lagrangian", "seconds": 0.5, "error": 1e-3},
        {"method": "augmented-lagrangian", "seconds": 1.0, "error": 1e-5},
        {"method": "penalty", "seconds": 0.4, "error": 1e-2},
        {"method": "penalty", "seconds": 0.8, "error": 1e-4},
    ]
    fig = drawn_figure(rows)
    renderer = fig.canvas.get_renderer()
    picture = fig.bbox
    title = fig._suptitle.get_window_extent(renderer)
    (legend,) = fig.legends
    legend_box = legend.get_window_extent(renderer)
    axes = fig.axes[0].get_window_extent(renderer)
    plt.close(fig)
    assert inside(title, picture) and inside(legend_box, picture)
    assert not title.overlaps(legend_box) and not axes.overlaps(legend_box)
    assert "(error / largest displacement)" in fig._suptitle.get_text().replace("\n", " ")
    assert pareto_plot(rows, tmp_path / "pareto.png").stat().st_size > 1000


def test_errors_of_exactly_zero_are_drawn_on_a_floor_the_legend_names():
    """Runs with error 0 (the stack's) used to be drawn at 1e-16 without a word."""
    import matplotlib.pyplot as plt

    from dda.tradeoff.report import zero_floor

    rows = [
        {"method": "penalty", "seconds": 0.4, "error": 3e-6},
        {"method": "penalty", "seconds": 0.8, "error": 0.0},
    ]
    assert zero_floor([3e-6, 0.0]) == 1e-7 and zero_floor([0.0]) == 1e-16
    fig = drawn_figure(rows)
    labels = [text.get_text() for text in fig.legends[0].get_texts()]
    lowest = min(min(line.get_ydata()) for line in fig.axes[0].get_lines())
    plt.close(fig)
    assert "error exactly 0, drawn at 1e-07" in labels
    assert lowest == 1e-7
    no_zero = drawn_figure(rows[:1])
    assert not any("exactly 0" in t.get_text() for t in no_zero.legends[0].get_texts())
    plt.close(no_zero)
