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
