"""OpenBLAS is held to one thread during a run, and given back afterwards."""

from __future__ import annotations

import numpy as np
import pytest

import dda
import dda.simulation as simulation
from dda.bench.scenes import wall_scene
from dda.blas_threads import loaded_openblas, single_threaded_blas

LIBRARIES = loaded_openblas()


@pytest.mark.skipif(not LIBRARIES, reason="no OpenBLAS found in this process")
def test_every_openblas_runs_on_one_thread_inside_and_as_before_after():
    paths = [path for path, _, _ in LIBRARIES]
    assert any("numpy" in path for path in paths)  # numpy's own, the one np.dot uses
    for _, _, setter in LIBRARIES:
        setter(2)
    with single_threaded_blas():
        assert [getter() for _, getter, _ in LIBRARIES] == [1] * len(LIBRARIES)
        np.dot(np.ones(100_000), np.ones(100_000))  # still computes
    assert [getter() for _, getter, _ in LIBRARIES] == [2] * len(LIBRARIES)


@pytest.mark.skipif(not LIBRARIES, reason="no OpenBLAS found in this process")
def test_a_run_holds_openblas_to_one_thread_and_gives_it_back(monkeypatch):
    seen = []
    advance = simulation._advance

    def watched(state):
        seen.append(max(getter() for _, getter, _ in LIBRARIES))
        advance(state)

    monkeypatch.setattr(simulation, "_advance", watched)
    before = [getter() for _, getter, _ in LIBRARIES]
    dda.simulate(dda.load_scene(wall_scene(2, steps=3)))
    assert seen == [1, 1, 1]
    assert [getter() for _, getter, _ in LIBRARIES] == before


def test_without_openblas_nothing_changes(monkeypatch):
    monkeypatch.setattr("dda.blas_threads._loaded_libraries", lambda: [])
    assert loaded_openblas() == []
    with single_threaded_blas():
        pass
