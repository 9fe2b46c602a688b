"""The solver's threads: the usable cores less those other processes keep busy."""

import pytest

from dda.solve import thread_policy
from dda.solve.thread_policy import CpuSample, ThreadPolicy, others_busy, threads_for


@pytest.mark.parametrize(
    ("usable", "others", "cpus", "expected"),
    [
        (2, 0.0, 2, 2),  # idle machine: every core
        (2, 0.4, 2, 2),  # a light load rounds away
        (2, 1.0, 2, 1),  # one core busy elsewhere: one thread
        (2, 1.9, 2, 1),  # never fewer than one
        (2, 3.0, 2, 1),
        (4, 2.0, 8, 3),  # busy cores spread over a machine larger than the affinity
    ],
)
def test_threads_are_the_cores_left_idle(usable, others, cpus, expected):
    assert threads_for(usable, others, cpus) == expected


def test_the_process_own_time_is_not_counted_as_others():
    before = CpuSample(wall=10.0, busy=100.0, own=5.0)
    # 2 s of wall: the machine was busy 3 CPU-s, 2 of them this process (two threads)
    after = CpuSample(wall=12.0, busy=103.0, own=7.0)
    assert others_busy(before, after) == pytest.approx(0.5)
    assert others_busy(after, before) == 0.0  # no time passed: nothing known


def test_the_decision_is_kept_within_a_window_and_remade_after(monkeypatch):
    clock = {"now": 100.0}
    samples = iter(
        [
            (CpuSample(100.0, 1000.0, 1.0), 2),  # at import
            (CpuSample(102.0, 1004.0, 2.0), 2),  # others kept 1.5 cores busy over 2 s
            (CpuSample(103.0, 1004.5, 2.4), 2),  # then 0.1 core
        ]
    )
    monkeypatch.setattr(thread_policy, "sample", lambda: next(samples))
    monkeypatch.setattr(thread_policy, "usable_cores", lambda: 2)
    monkeypatch.setattr(thread_policy.time, "monotonic", lambda: clock["now"])
    policy = ThreadPolicy()
    clock["now"] = 100.05
    assert policy.threads() == 2  # the first window has not closed: every usable core
    clock["now"] = 102.0
    assert policy.threads() == 1
    clock["now"] = 102.5
    assert policy.threads() == 1  # kept for a second
    clock["now"] = 103.0
    assert policy.threads() == 2


def test_without_proc_stat_every_usable_core(monkeypatch):
    monkeypatch.setattr(thread_policy, "sample", lambda: None)
    monkeypatch.setattr(thread_policy, "usable_cores", lambda: 2)
    policy = ThreadPolicy()
    assert policy.threads() == 2


def test_a_real_sample_reads_the_machine():
    now = thread_policy.sample()
    assert now is not None  # the test machine is Linux
    counters, cpus = now
    assert cpus >= 1 and counters.busy > 0.0 and counters.own > 0.0
