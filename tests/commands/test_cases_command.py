"""``dda cases``: one line per shipped case with its name, blocks, duration and title."""

from __future__ import annotations

import dda.cases
from dda.commands import cli


def test_dda_cases_lists_every_shipped_case_one_line_each(capsys):
    assert cli.main(["cases"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == dda.cases.names()
    tunnel = next(line for line in lines if line.startswith("tunnel "))
    assert tunnel.split()[1:4] == ["265", "blocks", "1"]  # cut from its joint sets
    assert tunnel.endswith("s  Circular tunnel in rock cut by three joint sets")
    projectile = next(line for line in lines if line.startswith("projectile "))
    assert " 1 block " in projectile and "Projectile: a free block" in projectile
    assert len({line.index(" blocks") for line in lines if " blocks" in line}) == 1  # aligned
