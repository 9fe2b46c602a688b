"""The compile helper: a second process compiles the step's kernels while the run
compiles the rest, and the run waits for it before it needs them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from dda import jit
from dda.commands import compile_helper
from dda.contact import rows as rows_module
from dda.solve import band_step

needs_numba = pytest.mark.skipif(not jit.numba_enabled(), reason="numba is not in use")
CASES = Path(__file__).resolve().parents[2] / "cases"


@pytest.fixture
def clean(monkeypatch):
    """No helper offered or running before and after the test."""
    monkeypatch.delenv(compile_helper.SWITCH, raising=False)
    compile_helper.withdraw()
    yield
    compile_helper.withdraw()


def _sleeper(seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])


@needs_numba
def test_a_helper_process_uses_the_kernels_of_its_modules_only(monkeypatch):
    monkeypatch.setattr(jit, "_ONLY", frozenset({"dda.solve.band_step"}))
    assert jit.compiled(band_step.band_step_kernel)
    assert not jit.compiled(rows_module._rows_kernel)
    with jit.run_work(blocks=900, steps=100):
        assert jit.compiled_in_run(band_step.band_step_kernel)
        assert not jit.compiled_in_run(rows_module._rows_kernel)


def test_a_helper_is_offered_only_with_a_second_core_and_not_switched_off(clean, monkeypatch):
    scene = CASES / "rock_slope.toml"
    compile_helper.offer(scene, second_core=False)
    assert compile_helper._offered is None
    monkeypatch.setenv(compile_helper.SWITCH, "0")
    compile_helper.offer(scene, second_core=True)
    assert compile_helper._offered is None
    monkeypatch.delenv(compile_helper.SWITCH)
    compile_helper.offer(CASES / "no_such_scene.toml", second_core=True)
    assert compile_helper._offered is None
    compile_helper.offer(scene, second_core=True)
    assert compile_helper._offered == scene.resolve()
    compile_helper.withdraw()
    assert compile_helper._offered is None


def test_the_first_compile_starts_the_helper_unless_it_is_a_step_kernel(clean, monkeypatch):
    started = []
    monkeypatch.setattr(compile_helper, "_start", lambda scene: started.append(scene))
    scene = CASES / "rock_slope.toml"
    compile_helper.offer(scene, second_core=True)
    compile_helper.compile_begins("dda.solve.band_step")  # the run compiles it itself
    compile_helper.compile_begins("dda.contact.pipeline")
    assert started == []
    compile_helper.offer(scene, second_core=True)
    compile_helper.compile_begins("dda.contact.pipeline")
    compile_helper.compile_begins("dda.contact.narrow")  # once only
    assert started == [scene.resolve()]


def test_a_step_kernel_waits_for_a_compiling_helper_to_end(clean, tmp_path):
    signal = tmp_path / "signal"
    signal.touch()
    process = _sleeper(0.5)
    compile_helper._helper = compile_helper._Helper(process, signal)
    compile_helper.wait_for("dda.contact.pipeline")  # not a step kernel: no wait
    assert process.poll() is None and compile_helper._helper is not None
    waited = jit.compile_seconds()
    compile_helper.wait_for("dda.solve.band_step")
    assert process.returncode == 0  # it ended by itself
    assert compile_helper._helper is None and not signal.exists()
    assert jit.compile_seconds() > waited


def test_a_helper_not_yet_compiling_is_stopped_and_the_run_compiles(clean, tmp_path):
    process = _sleeper(60.0)
    compile_helper._helper = compile_helper._Helper(process, tmp_path / "signal")
    compile_helper.wait_for("dda.solve.update")
    assert process.returncode is not None and process.returncode != 0  # killed
    assert compile_helper._helper is None


@needs_numba
def test_the_helper_process_runs_a_scene_first_step_and_fails_quietly(tmp_path):
    """``python -P -m dda.commands.compile_helper SCENE SIGNAL`` exits 0 after the
    scene's first step, 1 on a scene it cannot run, printing and writing nothing but the
    signal (touched only if it compiled: not with the suite's warm cache)."""
    command = [sys.executable, "-P", "-m", "dda.commands.compile_helper"]
    environment = {**os.environ, jit.KERNEL_MODULES: ",".join(compile_helper.STEP_MODULES)}
    work, signal = tmp_path / "work", tmp_path / "signal"
    work.mkdir()
    scene = str(CASES / "sliding_block.toml")
    done = subprocess.run([*command, scene, str(signal)], env=environment, cwd=work,
                          capture_output=True, timeout=600)  # fmt: skip
    assert done.returncode == 0 and done.stdout == b"", done.stderr
    bad = work / "bad.toml"
    bad.write_text("[analysis]\nsteps = -1\n")
    failed = subprocess.run([*command, str(bad), str(signal)], env=environment, cwd=work,
                            capture_output=True, timeout=600)  # fmt: skip
    assert failed.returncode == 1 and failed.stdout == b""
    assert sorted(p.name for p in work.iterdir()) == ["bad.toml"]


@pytest.mark.slow
@needs_numba
def test_a_first_run_leaves_the_step_kernels_to_the_helper(tmp_path):
    """Into an empty numba cache, ``dda run`` of the rock slope (its first 125 steps) with
    two solver threads: the step's kernels are in the cache at the end, and the run saved
    none of them itself (numba's ``NUMBA_DEBUG_CACHE`` lines are the run's alone: the
    helper's output goes nowhere), whether it waited for the helper or the helper had
    ended by then (on a loaded machine); the run's numbers are those of a run that
    compiled them itself."""
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
                   "NUMBA_DEBUG_CACHE": "1", "DDA_THREADS": "2"}  # fmt: skip
    environment.pop(compile_helper.SWITCH, None)
    scene = tmp_path / "slope.toml"  # 125 steps of 81 blocks: enough work for the kernels
    text = (CASES / "rock_slope.toml").read_text()
    scene.write_text(text.replace("duration = 2.0", "duration = 0.25", 1))
    command = [sys.executable, "-m", "dda", "-v", "run", str(scene), "--no-picture", "-q"]
    first = subprocess.run([*command, "-o", str(tmp_path / "a")], env=environment,
                           capture_output=True, text=True, timeout=900)  # fmt: skip
    assert first.returncode == 0, first.stderr
    saved = [line for line in first.stdout.splitlines() if "data saved" in line]
    assert saved and not any("band_step" in line or "update" in line for line in saved)
    cached = [path.name for path in (tmp_path / "cache").rglob("*.nbc")]
    assert any(name.startswith("band_step.") for name in cached)
    assert any(name.startswith("update.") for name in cached)
    alone = {**environment, "NUMBA_CACHE_DIR": str(tmp_path / "cache2"),
             compile_helper.SWITCH: "0"}  # fmt: skip
    second = subprocess.run([*command, "-o", str(tmp_path / "b")], env=alone,
                            capture_output=True, text=True, timeout=900)  # fmt: skip
    assert second.returncode == 0, second.stderr
    assert "compile helper" not in second.stderr
    import meshio
    import numpy as np

    frames = sorted((tmp_path / "a" / "frames").glob("*.vtu"))
    mine, its = (meshio.read(tmp_path / run / "frames" / frames[-1].name) for run in "ab")
    np.testing.assert_array_equal(mine.points, its.points)
    for name, data in mine.cell_data.items():
        np.testing.assert_array_equal(data[0], its.cell_data[name][0])
