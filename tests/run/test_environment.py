"""A run's summary names the versions it ran with, read once a process."""

from __future__ import annotations

from importlib import metadata

import numpy as np

from dda.run import environment as run_environment


def test_the_summary_names_the_installed_versions():
    found = run_environment.environment()
    assert found["dda"] == metadata.version("dda-rock")
    assert found["numpy"] == np.__version__


def test_a_package_s_metadata_is_read_once_a_process(monkeypatch):
    run_environment._version.cache_clear()
    reads = []
    monkeypatch.setattr(run_environment.metadata, "version", lambda name: reads.append(name) or "1")
    run_environment.environment()
    run_environment.environment()
    assert sorted(reads) == sorted(set(reads))
    run_environment._version.cache_clear()
