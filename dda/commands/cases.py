"""``dda cases``: the shipped cases, one line each: name, blocks, simulated time, title.

Registered as an entry point of ``dda.commands`` (pyproject.toml). Every case is loaded
(a rock mass is cut) to count its blocks: about 0.3 s for all of them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

EXIT_OK = 0


def register(subparsers: Any) -> None:
    """Add the ``cases`` sub-command (entry point of group ``dda.commands``)."""
    p = subparsers.add_parser(
        "cases",
        help="list the shipped cases (name, blocks, duration, what it shows)",
        description="List the scene files shipped with dda, one line each: the name "
        "(dda run NAME runs it from any folder), the number of blocks (a rock mass cut), "
        "the simulated time and the scene's title.",
    )
    p.set_defaults(func=cases_command)


def cases_command(args: argparse.Namespace) -> int:
    """Print one line per shipped case; 0."""
    import dda.cases

    rows = [case_row(name) for name in dda.cases.names()]
    name, blocks, duration = (max(len(row[k]) for row in rows) for k in range(3))
    for row in rows:
        print(f"{row[0]:<{name}}  {row[1]:>{blocks}}  {row[2]:>{duration}}  {row[3]}")
    print("dda run NAME runs one (docs/api.md); dda cut NAME writes its blocks", file=sys.stderr)
    return EXIT_OK


def case_row(name: str) -> tuple[str, str, str, str]:
    """(name, ``"265 blocks"``, ``"1 s"``, title) of the shipped case ``name``; a case
    that does not load says why in place of its title."""
    import dda
    import dda.cases

    try:  # by path: a scene may name files beside it (a drawing)
        scene = dda.load_scene(Path(str(dda.cases.folder().joinpath(f"{name}.toml"))))
    except dda.SceneError as exc:
        return name, "?", "?", f"(refused: {exc})"
    duration = scene.analysis.run_length
    blocks = f"{len(scene.blocks)} block{'s' if len(scene.blocks) != 1 else ''}"
    return name, blocks, f"{duration:g} {scene.units.time}", scene.title
