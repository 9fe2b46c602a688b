"""What every hard case must satisfy, whatever the scene.

``run_checked`` runs a scene and asserts, on the finished run or on the
partial result a :class:`dda.SimulationError` carries:

* no NaN or inf anywhere in the frames or the history;
* AL: no step ends with a closed contact penetrating more than the tolerance;
* energy: the stored total (kinetic + potential + elastic + contact +
  springs) never exceeds its initial value plus the work of the loads by more
  than 1 % of the energy that moved (max of kinetic, |ΔV|, elastic, contact
  and |W| over the run), nor by more than 1 % of E₀ + |W|;
* every block's area changes only by its elastic strain:
  |ln(A/A₀) − tr ε| ≤ 1e-5 + 1e-2 max |tr ε|, ε = E⁻¹σ (the two differ at
  second order in the strain increments: ~1e-6 after ten revolutions of a
  rolling polygon whose every landing strains it by ~1e-4);
* a run that stops says at which step, at what time and why.
"""

from __future__ import annotations

import re

import numpy as np

import dda
from dda.model import build
from dda.run import run_warnings

ENERGY_SLACK = 0.01
AREA_SLACK = 1e-5
DIAGNOSTIC = re.compile(r"step \d+ at t = \S+: .+ after \d+ attempts")


def run_checked(scene, must_finish: bool = True) -> dda.Result:
    """Simulate ``scene`` (dict or Scene) and apply every check."""
    scene = scene if isinstance(scene, dda.Scene) else dda.load_scene(scene)
    try:
        result = dda.simulate(scene)
    except dda.SimulationError as exc:
        assert DIAGNOSTIC.search(str(exc)), f"unclear diagnostic: {exc}"
        assert not must_finish, f"run stopped: {exc}"
        result = exc.result
    check_finite(result)
    check_penetration(scene, result)
    check_energy(result)
    check_areas(scene, result)
    return result


def check_finite(result: dda.Result) -> None:
    for name, values in result.history.items():
        assert np.all(np.isfinite(values)), f"history {name} not finite"
    for frame in result.frames:
        for array in (
            frame.centroids,
            frame.velocities,
            frame.stresses,
            frame.areas,
            frame.contacts.normal_force,
            frame.contacts.penetration,
        ):
            assert np.all(np.isfinite(array)), f"non-finite value at step {frame.step}"
        assert all(np.all(np.isfinite(v)) for v in frame.vertices)


def check_penetration(scene: dda.Scene, result: dda.Result) -> None:
    model = build(scene)
    if model.contact is None or not model.contact.law.augmented:
        return
    tolerance = model.contact.law.tolerance
    worst = result.history["max_penetration"].max(initial=0.0)
    assert worst <= tolerance, f"penetration {worst:.3g} above the AL tolerance {tolerance:.3g}"


def energy_excess(result: dda.Result) -> tuple[float, float, float]:
    """(largest excess over E₀ + W, energy that moved, E₀ + max |W|): the engine's
    :func:`dda.run.run_warnings.energy_excess` of the run's history."""
    return run_warnings.energy_excess(result.history, result.summary["initial_energy"])


def check_energy(result: dda.Result) -> None:
    excess, moved, budget = energy_excess(result)
    allowed = ENERGY_SLACK * min(moved, budget) + 1e-12 * budget
    assert excess <= allowed, (
        f"energy rose by {excess:.4g} above E0 + W (moved {moved:.4g}, budget {budget:.4g})"
    )


def check_areas(scene: dda.Scene, result: dda.Result) -> None:
    if result.fracture_events:
        return
    elasticity = build(scene).elastic
    first, last = result.frames[0], result.final
    # the blocks still there at the end (a stage may have excavated some), by id
    _, kept, at_end = np.intersect1d(first.ids, last.ids, return_indices=True)
    compliance = np.linalg.inv(elasticity.material_elasticity[_materials(scene)[kept]])
    stress_change = last.stresses[at_end] - first.stresses[kept]
    strain = np.einsum("nij,nj->ni", compliance, stress_change)
    trace = strain[:, 0] + strain[:, 1]
    change = np.log(last.areas[at_end] / first.areas[kept])
    allowed = AREA_SLACK + 1e-2 * np.abs(trace).max()
    worst = np.abs(change - trace).max()
    assert worst <= allowed, f"area changed by {worst:.3g} beyond the elastic strain"


def _materials(scene: dda.Scene) -> np.ndarray:
    rows = {name: k for k, name in enumerate(scene.materials)}
    return np.array([rows[b.material] for b in scene.blocks])
