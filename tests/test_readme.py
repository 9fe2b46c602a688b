"""The README is right about the tree and about what a new user meets: every path its
"What is where" table names exists; it states the suite's time as measured and that a
finished output folder is kept."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXTENSIONS = (".py", ".md", ".toml", ".png", ".dxf")


def table_paths() -> list[tuple[str, str]]:
    """(token, folder of its row) for every path in backticks in the table under "## What
    is where": a token that ends in ``/`` or one of :data:`EXTENSIONS`, or holds a ``/``
    (module names such as ``dda.cases`` and words such as ``Scene`` are not paths)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## What is where", 1)[1].split("\n## ", 1)[0]
    found = []
    for row in (line for line in section.splitlines() if line.startswith("| `")):
        tokens = re.findall(r"`([^`\s]+)`", row)
        folder = next((t for t in tokens if t.endswith("/")), "")
        for token in tokens:
            if token.endswith("/") or token.endswith(EXTENSIONS) or "/" in token:
                found.append((token, folder))
    return found


def test_every_path_in_the_readme_table_exists():
    """A path is found from the repository's root, or (a file of a folder's row, such as
    ``format.py`` in the row of ``dda/scene/``) in the folder its row names first."""
    paths = table_paths()
    assert len(paths) > 40  # the table was read
    missing = [
        t for t, folder in paths if not (ROOT / t).exists() and not (ROOT / folder / t).exists()
    ]
    assert not missing, f"README.md names paths that do not exist: {missing}"


def test_the_readme_states_the_test_time_and_that_a_finished_run_is_kept():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert re.search(r"measured: \d+ min \d+ s", text)  # the suite's time, as measured
    assert "exits 2" in text and "--overwrite" in text  # a second run into the folder
