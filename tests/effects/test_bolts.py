"""Rock bolts (dda/effects/bolts.py, dda/effects/pair_springs.py): closed forms, breaking, energy,
and the coupling terms of K and of the Newton solve's quadratic."""

from __future__ import annotations

import numpy as np
import pytest

import dda
from dda.effects.pair_springs import PairSprings
from dda.solve import assembly
from dda.solve.assembly import BlockPattern, assemble
from dda.solve.newton import BlockQuadratic
from tests.helpers import ROCK, G, rectangle, rotated, slope_scene

WEIGHT = ROCK["density"] * G * 0.5  # the 1 m x 0.5 m slider of slope_scene, per metre


def held_by_a_bolt(phi: float, theta: float, mode: str = "static", **bolt) -> dict:
    """slope_scene's slider with a bolt from its lower up-slope corner to the slab surface
    1 m further up: parallel to the slope, it stays so while the block slides."""
    scene = slope_scene(phi, angle=theta)
    scene["analysis"]["mode"] = mode
    start, end = rotated([[5.0, 0.0], [6.0, 0.0]], theta)
    scene["bolts"] = [{"name": "anchor", "start": start, "end": end,
                       "blocks": ["slider", "slope"], "stiffness": 1e7, **bolt}]  # fmt: skip
    scene["measure"] = [{"name": "anchor", "bolt": "anchor"}]
    return scene


def limit_force(phi: float, theta: float) -> float:
    """W (sin θ − cos θ tan φ): what the bolt carries once friction is used up."""
    t, p = np.radians(theta), np.radians(phi)
    return WEIGHT * (np.sin(t) - np.cos(t) * np.tan(p))


@pytest.mark.parametrize(("phi", "theta"), [(20.0, 30.0), (25.0, 40.0)])
def test_the_bolt_carries_what_friction_cannot(phi, theta):
    """Quasi-static: the block creeps down until T = W (sin θ − cos θ tan φ) (measured 1e-6)."""
    result = dda.simulate(held_by_a_bolt(phi, theta))
    force = result.measurements["anchor.force"][-1]
    assert force == pytest.approx(limit_force(phi, theta), rel=0.01)
    assert force == pytest.approx(limit_force(phi, theta), rel=1e-5)  # what it does
    assert "bolts" in result.summary["active_effects"] and result.bolt_events == []


def test_a_bolt_weaker_than_that_breaks_and_the_block_slides():
    capacity = 0.8 * limit_force(20.0, 30.0)
    result = dda.simulate(held_by_a_bolt(20.0, 30.0, "dynamic", capacity=capacity))
    (event,) = result.bolt_events
    assert event.bolt == "anchor" and event.force > capacity and event.step <= 5
    assert result.summary["bolt_events"] == [event]
    assert result.measurements["anchor.force"][-1] == 0.0
    slid = np.linalg.norm(result.final.displacements[1])
    assert slid > 0.85  # 0.906 m unbolted (cases/sliding_block.toml), less the first steps
    assert result.frames[0].bolts.shape == (1, 2, 2) and result.final.bolts.shape == (0, 2, 2)
    strong = dda.simulate(held_by_a_bolt(20.0, 30.0, capacity=1.05 * limit_force(20.0, 30.0)))
    assert strong.bolt_events == []
    # what it held as it broke, T²/(2k) from no pretension, goes with it, booked (an
    # audit: the springs' energy fell by it in one step, in no column or entry)
    assert event.energy == pytest.approx(event.force**2 / (2 * 1e7), rel=1e-12)
    assert result.summary["bolt_break_energy"] == event.energy


def test_pictures_draw_the_bolts(tmp_path):
    from dda.io import render_frame

    result = dda.simulate(held_by_a_bolt(20.0, 30.0))
    np.testing.assert_allclose(result.final.bolts[0, 1], rotated([[6.0, 0.0]], 30.0)[0])
    path = render_frame(result.final, tmp_path / "bolted.png", scene_title="bolted")
    assert path.stat().st_size > 10_000


def hanging_pair(mode: str = "static", pretension: float = 0.0, steps: int = 60) -> dict:
    """Block a hangs from a fixed ceiling by one bolt, block b from a by another (no contact):
    the lower bolt couples two free blocks."""
    return {
        "analysis": {"mode": mode, "time_step": 0.01, "steps": steps, "gravity": [0.0, -G]},
        "materials": {"rock": ROCK},
        "blocks": [
            {"name": "ceiling", "material": "rock", "fixed": True,
             "vertices": rectangle(-1, 3, 2, 4)},
            {"name": "a", "material": "rock", "vertices": rectangle(0, 1.5, 1, 2.5)},
            {"name": "b", "material": "rock", "vertices": rectangle(0, 0, 1, 1)},
        ],
        "bolts": [
            {"name": "upper", "start": [0.5, 2.5], "end": [0.5, 3.0], "blocks": ["a", "ceiling"],
             "stiffness": 1e8},
            {"name": "lower", "start": [0.5, 1.0], "end": [0.5, 1.5], "blocks": ["b", "a"],
             "stiffness": 1e8, "pretension": pretension},
        ],
        "measure": [{"name": "upper", "bolt": "upper"}, {"name": "lower", "bolt": "lower"}],
    }  # fmt: skip


@pytest.mark.parametrize("pretension", [0.0, 5000.0])
def test_a_chain_of_two_blocks_hangs_on_its_bolts(pretension):
    """Statics: the lower bolt holds W_b, the upper W_a + W_b, whatever the pretension.

    (W = ρ g S₀ with the area S₀ the block was made with: the hanging blocks stretch by
    ~5e-6, and their mass stays.)"""
    result = dda.simulate(hanging_pair(pretension=pretension))
    w = ROCK["density"] * G * result.frames[0].areas
    m = result.measurements
    assert m["lower.force"][-1] == pytest.approx(w[2], rel=1e-9)
    assert m["upper.force"][-1] == pytest.approx(w[1] + w[2], rel=1e-9)
    assert m["lower.force"][0] == pretension  # the row of step 0: installed at its pretension


@pytest.mark.parametrize("which", ["slider", "chain"])
def test_energy_of_bolted_blocks_stays_within_the_initial_energy_and_the_work(which):
    """kinetic + potential + strain + contact + bolt springs ≤ E0 + W at every step, for
    a bolted block sliding onto its bolt and for the free chain of two blocks falling
    onto theirs (the bolt energy, f0 e + ½ k e², is in the springs term; for the slider's
    bolt, without pretension, it is T²/2k)."""
    if which == "slider":
        scene, last = held_by_a_bolt(20.0, 30.0, "dynamic"), "anchor"
    else:
        scene, last = hanging_pair("dynamic", 5000.0, 100), "lower"
    result = dda.simulate(scene)
    h = result.history
    e0 = result.summary["initial_energy"]
    excess = h["total_energy"] - e0 - h["external_work"]
    assert np.all(excess <= 1e-9 * e0), excess.max()
    tension = result.measurements[f"{last}.force"][1:]
    assert tension.max() > 1000.0  # the bolts did hold the blocks
    if which == "slider":
        np.testing.assert_allclose(h["springs_energy"], tension**2 / 2e7, rtol=1e-9)


def test_bolted_free_blocks_keep_their_momentum():
    """No gravity: one block moves away from another it is bolted to. The bolt's forces are
    equal and opposite, so Σ m v stays what it was while the bolt stretches and pulls back."""
    scene = hanging_pair("dynamic", steps=80)
    scene["analysis"]["gravity"] = [0.0, 0.0]
    scene["blocks"][2]["velocity"] = [0.0, -1.0, 0.0]
    del scene["bolts"][0], scene["measure"][0]
    result = dda.simulate(scene)
    m = ROCK["density"] * 1.0
    momentum = [m * (f.velocities[1, 1] + f.velocities[2, 1]) for f in result.frames]
    np.testing.assert_allclose(momentum, -m, rtol=1e-9)
    assert result.measurements["lower.force"].max() > 1e4  # the bolt pulled
    assert result.history["total_energy"].max() <= result.summary["initial_energy"] * (1 + 1e-12)


def random_springs(seed: int, n: int, m: int) -> tuple[np.ndarray, PairSprings]:
    rng = np.random.default_rng(seed)
    fixed = np.zeros(n, bool)
    fixed[0] = True
    i = rng.integers(0, n, m)
    j = (i + 1 + rng.integers(0, n - 1, m)) % n
    springs = PairSprings(i, j, rng.normal(size=(m, 6)), rng.normal(size=(m, 6)), rng.random(m))
    return fixed, springs


@pytest.mark.parametrize("compiled", [True, False])
def test_the_springs_of_k_are_the_hessian_of_their_energy(monkeypatch, compiled):
    """K from the scatter equals Σ k [r_i r_j]ᵀ[r_i r_j] on the free blocks, and the
    quadratic's product K₀D equals K D: the solve and the line search see one energy."""
    if not compiled:
        monkeypatch.setattr(assembly, "_scatter_kernel", None)
    n = 6
    fixed, springs = random_springs(4, n, 9)
    none = np.zeros(0, np.int64)
    pairs = assembly.free_pairs(assembly.free_rows(fixed), springs.block_i, springs.block_j)
    pattern = BlockPattern(fixed, none, none, extra_pairs=pairs)
    diagonal = np.tile(np.eye(6), (n, 1, 1))
    k = assemble(pattern, diagonal, fixed, couplings=springs).toarray()
    dense = np.zeros((6 * n, 6 * n))
    for b in range(n):
        dense[6 * b : 6 * b + 6, 6 * b : 6 * b + 6] += np.eye(6)
    for c in range(len(springs)):
        row = np.zeros(6 * n)
        row[6 * springs.block_i[c] : 6 * springs.block_i[c] + 6] += springs.row_i[c]
        row[6 * springs.block_j[c] : 6 * springs.block_j[c] + 6] += springs.row_j[c]
        dense += springs.stiffness[c] * np.outer(row, row)
    free = np.repeat(~fixed, 6)
    order = (6 * np.argsort(pattern.position)[:, None] + np.arange(6)).ravel()
    np.testing.assert_allclose(k, dense[np.ix_(free, free)][np.ix_(order, order)], atol=1e-12)
    d = np.random.default_rng(1).normal(size=(n, 6))
    d[fixed] = 0.0
    product = BlockQuadratic(diagonal, np.zeros((n, 6)), ~fixed, springs).product(d)
    np.testing.assert_allclose(product.ravel()[free], (dense @ d.ravel())[free], rtol=1e-12)


def test_a_pattern_without_the_pair_of_a_spring_is_refused():
    fixed, springs = random_springs(2, 5, 4)
    none = np.zeros(0, np.int64)
    with pytest.raises(ValueError, match="does not hold every pair"):
        assemble(BlockPattern(fixed, none, none), np.zeros((5, 6, 6)), fixed, couplings=springs)


def swinging(dt: float, seconds: float) -> dict:
    """A 0.2 m square hung by its top on a 2 m bolt from a fixed ceiling, drawn 30° out of
    the vertical and let go (Shi's unloaded start): a pendulum, no contact, no friction."""
    angle = np.radians(30.0)
    pivot = np.array([2.0 * np.sin(angle), -2.0 * np.cos(angle)])  # the block's top
    square = rotated([[-0.1, -0.2], [0.1, -0.2], [0.1, 0.0], [-0.1, 0.0]], 30.0)
    return {
        "analysis": {
            "mode": "dynamic",
            "time_step": dt,
            "duration": seconds,
            "gravity": [0.0, -G],
            "start": "unloaded",
            "save_every": 10**6,
        },
        "materials": {"rock": {"density": 2700.0, "young": 5e9, "poisson": 0.25}},
        "blocks": [
            {
                "name": "ceiling",
                "material": "rock",
                "fixed": True,
                "vertices": rectangle(-1.0, 0.0, 1.0, 0.5),
            },
            {"name": "bob", "material": "rock", "vertices": (np.array(square) + pivot).tolist()},
        ],
        "bolts": [
            {
                "name": "string",
                "start": (pivot * 1.005).tolist(),
                "end": [0.0, 0.01],
                "stiffness": 1e8,
                "blocks": ["bob", "ceiling"],
            }
        ],
    }


@pytest.mark.parametrize(("dt", "seconds"), [(1e-3, 3.0), (1e-4, 0.5)])
def test_a_block_swinging_on_a_bolt_makes_no_energy(dt, seconds):
    """The bolt's direction turns within a step: its stiffness across the bolt, T/L,
    holds the swing as the bolt's true length would. Without it the pendulum gained
    2.4 J by 3 s at Δt = 1e-3 (0.8 % of the energy that moved, no warning) and 0.017 J by
    0.5 s at 1e-4."""
    result = dda.simulate(swinging(dt, seconds))
    h = result.history
    excess = h["total_energy"] - result.summary["initial_energy"] - h["external_work"]
    assert excess.max() <= 0.0, excess.max()
    assert h["kinetic_energy"].max() > 100.0  # it swung (0.29 m of drop: 310 J)


def pendulum_on_shaken_ceiling(dt: float) -> dict:
    """A 0.2 m square hung by its top on a 2 m bolt from a ceiling that follows the
    ground: 2 m/s² sideways for 0.3 s, then none (equilibrium start)."""
    return {
        "analysis": {"mode": "dynamic", "time_step": dt, "duration": 0.6,
                     "gravity": [0.0, -G], "save_every": 10**6},
        "materials": {"rock": {"density": 2700.0, "young": 5e9, "poisson": 0.25}},
        "blocks": [
            {"name": "ceiling", "material": "rock", "fixed": True,
             "vertices": rectangle(-1.0, 0.0, 1.0, 0.5)},
            {"name": "bob", "material": "rock", "vertices": rectangle(-0.1, -2.2, 0.1, -2.0)},
        ],
        "bolts": [{"name": "string", "start": [0.0, -2.01], "end": [0.0, 0.01],
                   "stiffness": 1e8, "blocks": ["bob", "ceiling"]}],
        "seismic": {"acceleration": [[0.0, 2.0], [0.3, 2.0], [0.3000001, 0.0]]},
    }  # fmt: skip


def test_a_pendulum_on_a_shaken_ceiling_converges_and_makes_no_energy():
    """The ceiling's sideways step pulls the bolt's other end through the spring across
    the bolt (T/L), whose work the ground's is booked with: E ≤ E0 + W at every step, and
    the bob's sway against the ceiling converges as Δt halves (each difference under half
    the one before: measured 3.6 times smaller). Without the ceiling's step in that spring
    the bob dragged behind a ceiling that stood still (0.74 % off at Δt = 1e-3)."""
    sway = []
    for dt in (1e-3, 5e-4, 2.5e-4):
        result = dda.simulate(pendulum_on_shaken_ceiling(dt))
        h = result.history
        excess = h["total_energy"] - result.summary["initial_energy"] - h["external_work"]
        assert excess.max() <= 1e-9 * result.summary["initial_energy"]
        d = result.final.displacements
        sway.append(d[1, 0] - d[0, 0])
    first, second = abs(sway[0] - sway[1]), abs(sway[1] - sway[2])
    assert second < 0.5 * first, sway
