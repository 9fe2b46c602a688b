"""A compiled kernel never runs machine code built from sources other than those on disk.

numba compiles a kernel's callees into it; its own cache is keyed by the kernel's file
only. ``dda.jit.cache`` stamps each entry with every source the kernel's module
imports (docs/design.md): these tests edit a callee in another module of a scratch copy
of the package (its own numba cache) and see the caller's numbers change, then come
back to the bit when the edit is reverted, while an untouched package loads its
kernels without compiling.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from dda import jit
from dda.jit import cache

needs_numba = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")

PACKAGE = Path(jit.__file__).resolve().parent.parent
ROOT = PACKAGE.parent

# the compiled vertex moves (dda/solve/update.py) of fixed blocks and steps; their
# callee is dda/kinematics.py's exact_position
MOVES = """
import hashlib, json, numpy as np, dda
from dda import jit
from dda.solve import update
rng = np.random.default_rng(7)
vertices, centroid = rng.normal(size=(40, 2)), rng.normal(size=(8, 2))
owner, d = np.repeat(np.arange(8), 5), rng.normal(scale=1e-2, size=(8, 6))
moved = update.moves_kernel(vertices, centroid, d, owner)
print(json.dumps({"package": dda.__file__, "digest": hashlib.sha256(moved.tobytes()).hexdigest(),
                  "compile_seconds": jit.compile_seconds()}))
"""

# the shipped sliding block (30° plane, φ = 20°) for 500 steps of 1 ms (the kernels, and
# with them the band step, are used from 500 steps): its travel goes through the
# friction bound of dda/contact/formulas.py
SLIDE = """
import hashlib, json, tomllib, dda, dda.cases
from dda import jit
scene = tomllib.loads(dda.cases.text("sliding_block"))
scene["analysis"].update(time_step=1e-3, duration=0.5, save_every=500)
result = dda.simulate(dda.load_scene(scene))
moved = result.final.displacements
print(json.dumps({"package": dda.__file__, "digest": hashlib.sha256(moved.tobytes()).hexdigest(),
                  "travel": float(abs(moved).max()), "compile_seconds": jit.compile_seconds()}))
"""


def scratch_package(tmp_path: Path) -> Path:
    """A copy of the package (and its shipped cases) without any numba cache."""
    copy = tmp_path / "site"
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc")
    shutil.copytree(PACKAGE, copy / "dda", ignore=ignore)
    shutil.copytree(ROOT / "cases", copy / "dda" / "cases", ignore=ignore)
    return copy


def run_in(copy: Path, script: str) -> dict:
    """Run ``script`` on the scratch package with its own numba cache folder."""
    env = dict(os.environ, PYTHONPATH=str(copy), NUMBA_CACHE_DIR=str(copy.parent / "numba"))
    env.pop("DDA_NO_NUMBA", None)
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=copy.parent
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert Path(result["package"]).is_relative_to(copy)
    return result


def edit(path: Path, old: str, new: str) -> str:
    """Replace ``old`` (once) by ``new`` in ``path``; returns the original text."""
    text = path.read_text()
    assert text.count(old) == 1, old
    path.write_text(text.replace(old, new))
    return text


@needs_numba
def test_an_edited_callee_recompiles_the_update_kernel_that_calls_it(tmp_path):
    copy = scratch_package(tmp_path)
    first = run_in(copy, MOVES)
    assert first["compile_seconds"] > 0
    warm = run_in(copy, MOVES)
    assert warm["compile_seconds"] == 0 and warm["digest"] == first["digest"]

    callee = copy / "dda" / "kinematics.py"
    original = edit(callee, "    g = gxy / 2.0\n", "    g = gxy / 2.0 + 0.25 * ex\n")
    edited = run_in(copy, MOVES)
    assert edited["compile_seconds"] > 0 and edited["digest"] != first["digest"]

    callee.write_text(original)
    reverted = run_in(copy, MOVES)
    assert reverted["digest"] == first["digest"]


@needs_numba
def test_a_change_outside_a_kernels_imports_keeps_its_cache(tmp_path):
    """A file the update kernels' module does not import (the scene reader) leaves them
    cached: no compile in the second run."""
    copy = scratch_package(tmp_path)
    first = run_in(copy, MOVES)
    unrelated = copy / "dda" / "scene" / "format.py"
    unrelated.write_text(unrelated.read_text() + "\n# an edit no kernel sees\n")
    again = run_in(copy, MOVES)
    assert again["compile_seconds"] == 0 and again["digest"] == first["digest"]


@needs_numba
@pytest.mark.slow
def test_an_edited_contact_law_callee_recompiles_the_band_step(tmp_path):
    """Scaling the friction bound in dda/contact/formulas.py (compiled into the contact
    law's kernels and the band step of dda/solve/band_step.py) changes a sliding block's
    travel; reverting gives the first run's numbers to the bit."""
    copy = scratch_package(tmp_path)
    first = run_in(copy, SLIDE)
    callee = copy / "dda" / "contact" / "formulas.py"
    old = "    coulomb = tangent * pressed + held\n"
    original = edit(callee, old, old.replace("tangent", "0.5 * tangent"))
    edited = run_in(copy, SLIDE)
    assert edited["compile_seconds"] > 0
    assert edited["travel"] > 1.05 * first["travel"]

    callee.write_text(original)
    reverted = run_in(copy, SLIDE)
    assert reverted["digest"] == first["digest"]


@needs_numba
def test_kernel_sources_follow_the_imports_of_the_kernels_module():
    from dda.solve import band_step, update

    def names(function):
        return {str(p.relative_to(PACKAGE)) for p in cache.kernel_sources(function)}

    assert {"solve/update.py", "kinematics.py", "solve/integrator.py"} <= names(update._apply)
    assert {"contact/law_kernels.py", "contact/formulas.py"} <= names(band_step._band_step)
    assert "scene/format.py" not in names(update._apply)


def test_dda_kernels_clear_removes_the_cached_kernels(tmp_path):
    """``dda kernels --clear`` removes the cache files of a (scratch) package's kernels."""
    copy = scratch_package(tmp_path)
    pycache = copy / "dda" / "contact" / "__pycache__"
    pycache.mkdir()
    for name in ("law_kernels._terms-20.py311.nbi", "law_kernels._terms-20.py311.1.nbc"):
        (pycache / name).write_bytes(b"x" * 10)
    (pycache / "law.cpython-311.pyc").write_bytes(b"kept")
    env = dict(os.environ, PYTHONPATH=str(copy), NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    env.pop("DDA_NO_NUMBA", None)
    script = textwrap.dedent(
        """
        import sys
        from dda.commands.cli import main
        sys.exit(main(sys.argv[1:]))
        """
    )
    if not jit.numba_enabled():
        pytest.skip("numba is not in use")
    listed = subprocess.run(
        [sys.executable, "-c", script, "kernels"],
        capture_output=True, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip
    assert listed.returncode == 0 and "2 cached kernel files" in listed.stdout, listed.stderr
    assert str(copy) in listed.stdout  # the scratch package's cache, not this checkout's
    cleared = subprocess.run(
        [sys.executable, "-c", script, "kernels", "--clear"],
        capture_output=True, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip

    assert cleared.returncode == 0 and "removed 2 cached kernel files" in cleared.stdout
    assert sorted(p.name for p in pycache.iterdir()) == ["law.cpython-311.pyc"]
    empty = subprocess.run(
        [sys.executable, "-c", script, "kernels"],
        capture_output=True, text=True, env=env, cwd=tmp_path,
    )  # fmt: skip
    assert empty.returncode == 0, empty.stderr  # was "0 cached kernel files ... in 0 folders"
    assert empty.stdout == (
        f"0 cached kernel files: numba keeps them under {tmp_path / 'numba'} (NUMBA_CACHE_DIR)\n"
    )


def test_dda_kernels_says_where_numba_keeps_them_when_there_are_none(monkeypatch, capsys):
    """With no cache file yet: beside the modules, or (a read-only package) the user's
    cache, by numba's order."""
    from numba.core import config

    from dda.commands import cli

    if not jit.numba_enabled():
        pytest.skip("numba is not in use")
    monkeypatch.setattr(cache, "cache_files", list)
    monkeypatch.setattr(config, "CACHE_DIR", "")
    monkeypatch.setattr(cache.os, "access", lambda *args: True)
    assert cli.main(["kernels"]) == 0
    assert capsys.readouterr().out == (
        "0 cached kernel files: numba keeps them in __pycache__ beside the modules under "
        f"{cache.PACKAGE_ROOT}\n"
    )
    monkeypatch.setattr(cache.os, "access", lambda *args: False)
    assert cli.main(["kernels"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("0 cached kernel files: numba keeps them under ")
    assert out.endswith(f"numba (the user's cache: {cache.PACKAGE_ROOT} is read-only)\n")
