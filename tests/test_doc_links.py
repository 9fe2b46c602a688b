"""Every relative link and every cited file in the docs and the docstrings exists.

Scanned: README.md, docs/*.md, and the Python sources of dda/,
verify/, cases/ and bench/. A citation is a path under one of the project's
folders (``docs/theory.md``, ``dda/jit/__init__.py``, ``cases/verify/node.toml``) or a
Markdown file name (``contact.md``, ``DESIGN.md``); it must name a file or
folder of the repository, from the root, from the citing file's folder or in
docs/. Patterns and placeholders (``frames/*.vtu``, ``cases/verify/NAME.toml``)
and the names of files the commands write are not citations.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = (".ci", "cases", "dda", "docs", "tests", "verify")
CITATION = re.compile(
    r"(?<![\w/.\-])((?:" + "|".join(re.escape(f) for f in FOLDERS) + r")/[\w./\-]*[\w\-]"
    r"|[\w\-]+\.md)\b"
)
LINK = re.compile(r"\]\(([^)\s]+)\)")
PLACEHOLDERS = {"NAME", "CASE", "OUTDIR", "DIR", "FILE", "SCENE"}  # NAME.toml, CASE.md, ...
WRITTEN = {"report.md"}  # written by `dda verify`, not part of the repository


def sources() -> list[Path]:
    files = [ROOT / "README.md", *sorted(ROOT.glob("docs/*.md"))]
    for folder in ("dda", "verify", "cases"):
        files += sorted((ROOT / folder).rglob("*.py"))
    return files


def exists(target: str, citing: Path) -> bool:
    return any((base / target).exists() for base in (ROOT, citing.parent, ROOT / "docs"))


def missing_targets(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    missing = []
    for match in LINK.finditer(text):
        target = match.group(1).split("#")[0]
        if not target or "://" in target or "{" in target or target.startswith("mailto:"):
            continue
        if not (path.parent / target).exists():
            missing.append(f"link {target}")
    for match in CITATION.finditer(text):
        target = match.group(1)
        if any(c in target for c in "*<>{}") or target in WRITTEN:
            continue
        if any(part.split(".")[0] in PLACEHOLDERS for part in target.split("/")):
            continue
        if not exists(target, path):
            missing.append(f"cites {target}")
    return missing


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_links_and_cited_files_exist(path):
    assert missing_targets(path) == []


def test_the_check_finds_a_missing_file(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "See THEORY.md, docs/nowhere.md, [x](gone.png) and `cases/verify/NAME.toml`; "
        "dda run writes frames/*.vtu and report.md. dda/jit/__init__.py exists."
    )
    assert missing_targets(page) == ["link gone.png", "cites THEORY.md", "cites docs/nowhere.md"]
