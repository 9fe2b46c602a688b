"""The project installs like a package: its package list, version, ``python -m dda``, and
a wheel that works installed (not editable) in a fresh virtual environment."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pytest

import dda

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "dda", "verify", "cases")


def test_every_package_folder_is_listed_in_pyproject():
    """The list is explicit (cases/ is mapped into dda.cases): a new subpackage must join it."""
    found = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for top in ("dda", "verify")
        for p in (ROOT / top).rglob("__init__.py")
    }
    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    assert found | {"dda.cases", "dda.cases.verify"} == listed


def test_version_and_python_m_dda():
    out = subprocess.run(
        [sys.executable, "-m", "dda", "--version"], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == f"dda {dda.__version__}"
    assert dda.__version__ == PYPROJECT["project"]["version"]


def test_shipped_cases_are_the_cases_folder():
    import dda.cases

    assert dda.cases.names() == sorted(p.stem for p in (ROOT / "cases").glob("*.toml"))
    assert dda.load_scene(dda.cases.text("stack")).title
    with pytest.raises(KeyError, match="no shipped scene"):
        dda.cases.text("no_such_case")


def run(command: list, cwd: Path, timeout: float = 300) -> str:
    env = {**os.environ, "VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"}
    env.pop("PYTHONPATH", None)
    out = subprocess.run(
        [str(c) for c in command], cwd=cwd, capture_output=True, text=True, env=env,
        timeout=timeout,
    )  # fmt: skip
    assert out.returncode == 0, f"{command}:\n{out.stdout}\n{out.stderr}"
    return out.stdout + out.stderr


def test_the_wheel_installed_in_a_fresh_venv_verifies_and_sweeps(tmp_path):
    """Build the wheel from a copy of the sources, install it (not editable) into a new
    venv and run two ``dda verify`` cases and ``dda tradeoff --serial`` outside the source
    tree. The new venv sees this environment's site-packages for the dependencies (a .pth
    line: no download), and ``pip check`` confirms the wheel's requirements are met."""
    pytest.importorskip("build")
    source = tmp_path / "source"
    source.mkdir()
    for name in SOURCES:
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, source / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(path, source / name)
    run([sys.executable, "-m", "build", "--wheel", "--outdir", tmp_path / "dist", source], tmp_path)
    (wheel,) = (tmp_path / "dist").glob("dda_rock-*.whl")

    venv = tmp_path / "venv"
    run([sys.executable, "-m", "venv", "--without-pip", venv], tmp_path)
    python = venv / "bin" / "python"
    site = Path(
        run(
            [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"], tmp_path
        ).strip()
    )
    (site / "dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    pip = [sys.executable, "-m", "pip", "--python", python]
    run([*pip, "install", "--no-deps", "--no-index", wheel], tmp_path)
    run([*pip, "check"], tmp_path)

    work = tmp_path / "work"
    work.mkdir()
    where = run(
        [python, "-c", "import dda, dda.cases; print(dda.__file__, dda.cases.names())"], work
    )
    assert str(site) in where and "sliding_block" in where
    dda_command = venv / "bin" / "dda"
    # one FEM comparison and one motion case from the wheel's own verify cases (the whole
    # quick suite runs in tests/verify/test_verify.py)
    verify = [dda_command, "verify", "self_weight", "rocking", "--no-refinement", "-o", "report"]
    report = run(verify, work)
    assert (work / "report" / "report.md").is_file(), report
    grid = "method=penalty;penalty=1;time_step=0.02;ratio=0.01"
    run([dda_command, "tradeoff", "sliding_block", "--serial", "--grid", grid, "-o", "t"], work)
    assert "finished" in (work / "t" / "sliding_block.csv").read_text()
