"""A study's files in its output folder, and the rule that a folder holds one study of a case.

A study of CASE writes ``CASE.csv``, ``CASE.md`` and ``pareto_CASE.png``; one
interrupted by Ctrl-C writes the settings it finished to ``CASE_partial.csv`` and
its table (``.md``). As for ``dda run`` (docs/runs.md), a folder that holds either
refuses a new study of the same case unless it is asked to replace it
(``--overwrite``): a finished study is never replaced unasked. When it is, the earlier
study's files go as the new study writes its own, so a partial study never stays
beside a later whole one, nor a whole one beside a later partial one. Studies of
other cases in the same folder are left alone.
"""

from __future__ import annotations

from pathlib import Path

from dda.io.output_paths import OutputError

WHOLE_NAMES = ("{}.csv", "{}.md", "pareto_{}.png")
PARTIAL_NAMES = tuple("{}_partial" + suffix for suffix in (".csv", ".md"))


def study_files(outdir: Path, case: str) -> list[Path]:
    """The files of a study of ``case`` in ``outdir`` that exist (whole, then partial)."""
    names = (*WHOLE_NAMES, *PARTIAL_NAMES)
    return [path for name in names if (path := outdir / name.format(case)).is_file()]


def check_study_folder(outdir: Path, case: str, overwrite: bool) -> None:
    """Refuse ``outdir`` when it holds a study of ``case`` and ``overwrite`` is not given.

    Raises
    ------
    OutputError
        Naming the folder, the study found (whole or interrupted) and its files.
    """
    found = study_files(outdir, case)
    if not found or overwrite:
        return
    whole = {name.format(case) for name in WHOLE_NAMES}
    kind = "a study" if any(p.name in whole for p in found) else "an interrupted study"
    files = ", ".join(p.name for p in found)
    raise OutputError(outdir, f"holds {kind} of {case} ({files}); --overwrite replaces it")


def remove_earlier_study(outdir: Path, case: str) -> int:
    """Remove the files of an earlier study of ``case`` in ``outdir``; return how many."""
    found = study_files(outdir, case)
    for path in found:
        path.unlink(missing_ok=True)
    return len(found)
