"""Contact never creates energy: toppling and collapsing stacks, with and without
friction, augmented Lagrangian and penalty, 3 to 20 blocks.

At every step the stored energy (kinetic + potential + elastic + contact springs)
stays below its initial value plus the work of the loads, E₀ + W, within 1e-3 E₀.
Each step minimises one convex incremental potential (dda.solve.newton), and Shi's
integrator with a convex potential can only dissipate; before, the open–close
iteration's held contacts gave the 3-block leaning stack 36 % of E₀ and the
10-block one 62 %.
"""

from __future__ import annotations

import numpy as np
import pytest

import dda
import dda.solve.step
from tests.helpers import ROCK, G, rectangle, use_policy

SLACK = 1e-3


def leaning_stack(count: int, offset: float, friction: float, method: str, duration: float):
    """``count`` 1 x 0.5 m blocks, each ``offset`` m right of the one below, on a fixed base
    (E = 5e9 Pa, p = 5e10 N/m, Δt = 1e-3 s): the stack topples and collapses."""
    width = 4.0 + count * offset
    blocks = [
        {"name": "base", "material": "rock", "fixed": True, "vertices": rectangle(-3, -1, width, 0)}
    ]
    for k in range(count):
        x0, y0 = k * offset, 0.5 * k
        blocks.append(
            {"name": f"b{k}", "material": "rock", "vertices": rectangle(x0, y0, x0 + 1, y0 + 0.5)}
        )
    return {
        "analysis": {
            "time_step": 1e-3,
            "duration": duration,
            "gravity": [0.0, -G],
            "save_every": 1000,
        },
        "contact": {"method": method, "penalty": 5e10},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": friction}},
        "blocks": blocks,
    }


def largest_gain(result: dda.Result) -> float:
    """max over steps of (T + V + U + C − W − E₀) / E₀."""
    h = result.history
    e0 = result.summary["initial_energy"]
    return float(np.max(h["total_energy"] - h["external_work"] - e0) / e0)


CASES = [
    (3, 0.6, 0.0, "augmented-lagrangian", 0.5),
    (3, 0.6, 0.0, "penalty", 0.5),
    (10, 0.2, 30.0, "augmented-lagrangian", 1.0),
    (10, 0.2, 0.0, "penalty", 1.0),
    # its corners slide past each other as it topples: a contact must pass from one
    # corner to the other (dda.contact.narrow); when it did not, the 20-block stack
    # gained 0.16 E₀ (measured gain now 2.2e-5 E₀)
    (20, 0.1, 0.0, "augmented-lagrangian", 1.5),
]
SLOW = [
    (10, 0.2, 0.0, "augmented-lagrangian", 1.0),
    (10, 0.2, 30.0, "penalty", 1.0),
    (20, 0.1, 30.0, "penalty", 1.5),
]


@pytest.mark.parametrize("count, offset, friction, method, duration", CASES)
def test_a_toppling_stack_gains_no_energy(count, offset, friction, method, duration):
    result = dda.simulate(leaning_stack(count, offset, friction, method, duration))
    assert result.summary["status"] == "finished"
    assert largest_gain(result) <= SLACK
    assert result.history["kinetic_energy"].max() > 0.05 * result.summary["initial_energy"]


@pytest.mark.slow
@pytest.mark.parametrize("count, offset, friction, method, duration", SLOW)
def test_larger_toppling_stacks_gain_no_energy(count, offset, friction, method, duration):
    result = dda.simulate(leaning_stack(count, offset, friction, method, duration))
    assert largest_gain(result) <= SLACK


@pytest.mark.parametrize("method", ["augmented-lagrangian", "penalty"])
def test_a_column_dropped_onto_itself_gains_no_energy(method):
    """Eight unit blocks with 1 mm gaps fall onto each other and the base (0.3 s)."""
    blocks = [
        {"name": "base", "material": "rock", "fixed": True, "vertices": rectangle(-2, -1, 3, 0)}
    ]
    for k in range(8):
        y0 = 1e-3 + k * (1.0 + 1e-3)
        blocks.append(
            {"name": f"b{k}", "material": "rock", "vertices": rectangle(0, y0, 1, y0 + 1)}
        )
    raw = {
        "analysis": {"time_step": 2e-3, "duration": 0.3, "gravity": [0.0, -G]},
        "contact": {"method": method},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": 30.0}},
        "blocks": blocks,
    }
    assert largest_gain(dda.simulate(raw)) <= SLACK


def test_the_ringing_wall_gains_no_energy_through_chord_steps(monkeypatch):
    """The 10 x 10 benchmark wall, 100 steps: its contacts with next to no force make the
    solve take many chord steps (−K_f⁻¹∇Π with an older factorisation, then the exact
    line search); they descend on the same potential, so they create no energy either."""
    from dda.bench.scenes import wall_scene

    chords = []
    minimise = dda.solve.step.minimise

    def counting(*args, **kwargs):
        result = minimise(*args, **kwargs)
        chords.append(result.chords)
        return result

    monkeypatch.setattr(dda.solve.step, "minimise", counting)
    use_policy(monkeypatch, band_work=0.0)  # the sparse systems
    result = dda.simulate(dda.load_scene(wall_scene(10, steps=100)))
    assert sum(chords) > 100  # measured: 433 chord steps in 100 steps; largest gain −1.3e-7 E₀
    assert result.summary["cut_steps"] == 0
    assert largest_gain(result) <= SLACK


@pytest.mark.parametrize("size", ["large", "huge"])
def test_the_ringing_wall_gains_no_energy_with_the_large_systems_chord_rules(size, monkeypatch):
    """The same wall with the chord rules of large systems (conjugated chord steps go on
    while each leaves at most 0.99 of ‖∇Π‖, and a pass on new friction bounds starts
    with a chord step from where the last pass stopped, converged or not) and of huge
    ones (plain chord steps to 0.99 of ‖∇Π‖, the friction bounds follow every solve):
    more chord steps, still descent on each pass's potential, no energy created.
    Measured: 401 of 553 / 1,743 of 2,039 passes started with a chord step; largest
    gain −8.4e-12 E₀ both."""
    from dda.bench.scenes import wall_scene

    use_policy(monkeypatch, large_rows=0)  # every system counts as large
    if size == "huge":
        use_policy(monkeypatch, large_rows=0, huge_rows=0)
    chord_first = []
    minimise = dda.solve.step.minimise

    def counting(*args, **kwargs):
        chord_first.append(kwargs.get("chord_first", False))
        return minimise(*args, **kwargs)

    monkeypatch.setattr(dda.solve.step, "minimise", counting)
    use_policy(monkeypatch, band_work=0.0)  # the sparse systems
    result = dda.simulate(dda.load_scene(wall_scene(10, steps=100)))
    assert sum(chord_first) > 100
    assert result.summary["cut_steps"] == 0
    assert largest_gain(result) <= SLACK


@pytest.mark.skipif(not dda.jit.numba_enabled(), reason="numba is not in use")
@pytest.mark.parametrize("size", ["mid", "large"])
def test_the_ringing_wall_gains_no_energy_on_band_systems(size, monkeypatch):
    """The same wall, 100 steps, as a long run takes it: every step on band systems, the
    step's loop one compiled call (dda.solve.band_step), with the band systems' rules of
    its size (conjugated chord steps to 0.85 of ‖∇Π‖, passes that start with a chord
    step) and with those of large systems (to 0.99): descent on each pass's potential,
    no energy created.
    Measured: largest gain −8.0e-9 E₀ with both rules (1,259 and 1,579 linear solves)."""
    import dda.solve.band_step
    from dda.bench.scenes import wall_scene

    if size == "large":
        use_policy(monkeypatch, large_rows=0)
    passes = []  # (solved, chord steps) of each step's compiled loop
    compiled_step = dda.solve.band_step.solve_on_band

    def counted(*args):
        result = compiled_step(*args)
        passes.append((result is not None, result[2] if result is not None else 0))
        return result

    monkeypatch.setattr(dda.solve.band_step, "solve_on_band", counted)
    with dda.jit.run_work(101, 10_000):
        result = dda.simulate(dda.load_scene(wall_scene(10, steps=100)))
    assert len(passes) >= 100 and all(done for done, _ in passes)
    assert sum(chords for _, chords in passes) > 100
    assert result.summary["cut_steps"] == 0
    assert largest_gain(result) <= SLACK


# the runs of the stick matrix (tests/standing/test_stick_slip.py, the same cached runs)
STICK = [
    (ratio, dt, pf, method)
    for ratio in (0.5, 0.8, 0.95)
    for dt in (1e-3, 2.5e-4, 1e-4, 2.5e-5)
    for pf in (1.0, 10.0, 100.0)
    for method in ("augmented-lagrangian", "penalty")
]
QUICK_STICK = [(0.95, 2.5e-4, 10.0, "augmented-lagrangian"), (0.95, 1e-3, 10.0, "penalty")]


@pytest.mark.parametrize(
    "ratio, dt, pf, method",
    [c if c in QUICK_STICK else pytest.param(*c, marks=pytest.mark.slow) for c in STICK],
)
def test_a_block_standing_on_a_slope_gains_no_energy(ratio, dt, pf, method):
    """The stick matrix's blocks (started loaded, materially damped): kinetic + potential
    + strain + contact ≤ E₀ + W + 1e-3 E₀ at every step (measured: at most 1.5e-9 E₀,
    at p = E)."""
    from tests.standing.incline import largest_gain as gain
    from tests.standing.incline import run

    assert gain(run(ratio, dt, 0.5, pf, method)) <= SLACK
