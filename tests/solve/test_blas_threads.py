"""OpenBLAS is held to one thread during a run, and given back afterwards."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from threadpoolctl import ThreadpoolController, threadpool_info

import dda
import dda.run.simulation as simulation
from dda.bench.scenes import wall_scene
from dda.solve.linsolve import single_threaded_blas


def openblas_threads() -> list[int]:
    return [p["num_threads"] for p in threadpool_info() if p["internal_api"] == "openblas"]


def two_threads():
    return ThreadpoolController().select(internal_api="openblas").limit(limits=2)


pytestmark = pytest.mark.skipif(not openblas_threads(), reason="no OpenBLAS in this process")


def test_every_openblas_runs_on_one_thread_inside_and_as_before_after():
    with two_threads():
        with single_threaded_blas():
            assert set(openblas_threads()) == {1}
            np.dot(np.ones(100_000), np.ones(100_000))  # still computes
        assert set(openblas_threads()) == {2}


def test_a_run_holds_openblas_to_one_thread_and_gives_it_back(monkeypatch):
    seen = []
    advance = simulation._advance

    def watched(state):
        seen.append(max(openblas_threads()))
        advance(state)

    monkeypatch.setattr(simulation, "_advance", watched)
    with two_threads():
        dda.simulate(dda.load_scene(wall_scene(2, steps=3)))
        assert seen == [1, 1, 1]
        assert set(openblas_threads()) == {2}


def test_scipys_openblas_is_limited_in_a_fresh_process_too():
    """The first run of a process loads scipy's OpenBLAS (scipy.linalg) while it runs;
    the limit is set on it as on numpy's (before, it ran on two threads in the first run
    only, which then differed from the next run of the same scene in the last bits)."""
    code = (
        "import dda, threadpoolctl\n"
        "from dda.solve.linsolve import single_threaded_blas\n"
        "with single_threaded_blas():\n"
        "    import scipy.linalg, scipy.sparse.linalg\n"
        "    print(sorted({p['num_threads'] for p in threadpoolctl.threadpool_info()\n"
        "                  if p['internal_api'] == 'openblas'}))\n"
    )
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "", "OMP_NUM_THREADS": ""}
    env = {k: v for k, v in env.items() if v}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[1]"


def test_the_pools_are_looked_for_again_only_after_an_import(monkeypatch):
    """threadpoolctl's walk over the loaded libraries (1.5 ms, twice a run) is repeated
    only when a module was imported since the last one (a library loads with a module)."""
    from dda.solve.linsolve import _openblas_pools

    first = _openblas_pools()
    assert _openblas_pools() is first
    monkeypatch.setitem(sys.modules, "a_module_imported_since", object())
    again = _openblas_pools()
    assert again is not first

    def paths(pools):
        return {pool.filepath for pool in pools.lib_controllers}

    assert paths(again) == paths(first)
