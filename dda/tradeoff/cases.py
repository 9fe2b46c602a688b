"""Studied cases: the scene, the quantity measured and its reference.

* ``sliding_block`` (cases/sliding_block.toml): distance slid in 1 s down the
  30° slope, closed form s = ½ g (sin θ − cos θ tan φ) t².
* ``pushed_block`` (cases/paper_two_blocks.toml, the paper's Fig. 2 pushed by
  H = 4000 lb so that it slides, run with the engine's defaults: the equilibrium
  start and material damping, not the paper's unloaded start without damping):
  acceleration 2x/t² over 0.5 s, closed form a = (H − tan φ (V + W)) / m.
* ``pendulum`` (a 2 x 0.2 m bar let go level on a pin at the middle of one end,
  no contact): its angle after 1 s, closed form of the compound pendulum (Jacobi's
  sn): the case where Δt, not the contact, sets the error.
* ``stack`` (cases/stack.toml, 0.2 s): mean σyy of the bottom block, closed
  form −ρ g (4 + ½) h.
* ``wall`` (the benchmark's 10 x 10 wall of dda.bench.scenes, 0.1 s): the
  displacements of every block, against a fine run (error: the
  largest difference over the largest displacement). The many-contact case,
  where the AL tolerance sets how many solves a step takes.
* any other scene file: the final centroids, against a fine run
  (error: the largest centroid distance over the model size).
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.special

import dda
import dda.cases
from dda.bench.scenes import wall_scene
from dda.tradeoff.grid import SCENE_FILE, Setting, default_grid


@dataclass(frozen=True)
class Case:
    """A scene (raw dict), what to measure in its result and the closed form if any.

    ``measure`` is a module-level function, so that a dask worker receives it by
    name together with the scene dict and reads no file.
    """

    name: str
    raw: dict
    measure: Callable[[dda.Result], np.ndarray]
    reference: np.ndarray | None  # closed form; None: a fine run (not converged: its own
    # error, measured on the wall, is 2e-2 to 3e-2, docs/accuracy.md)
    quantity: str  # what is measured, for tables
    grid: dict[str, list]  # default grid of the study
    per_model_size: bool = False  # error over the model size (else over max |reference|)

    def scene(self, setting: Setting) -> dict:
        """The raw scene with ``setting`` applied."""
        raw = copy.deepcopy(self.raw)
        young = max(m["young"] for m in raw["materials"].values())
        contact = raw.setdefault("contact", {})
        contact["method"] = setting.method
        contact["penalty"] = setting.penalty * young
        contact["tolerance"] = setting.tolerance * model_size(raw)
        analysis = raw.setdefault("analysis", {})
        analysis["time_step"] = setting.time_step
        analysis["max_displacement_ratio"] = setting.ratio
        return raw


def model_size(raw: dict) -> float:
    """The largest extent of the blocks (the unit of tolerances and errors)."""
    points = np.concatenate([np.asarray(b["vertices"], float) for b in raw["blocks"]])
    return float(np.ptp(points, axis=0).max())


def relative_error(value: np.ndarray, reference: np.ndarray, scale: float | None = None) -> float:
    """max |value − reference| / (scale or max |reference|)."""
    value, reference = np.atleast_1d(value), np.atleast_1d(reference)
    denominator = scale if scale is not None else float(np.abs(reference).max())
    return float(np.abs(value - reference).max() / denominator)


def _load(name: str, **analysis) -> dict:
    raw = tomllib.loads(dda.cases.text(name))
    raw["analysis"].update(analysis)
    return raw


def _row(result: dda.Result, name: str) -> int:
    return result.final.names.index(name)


def slid_distance(r: dda.Result) -> np.ndarray:
    """How far the block called ``slider`` moved."""
    return np.array([np.linalg.norm(r.final.displacements[_row(r, "slider")])])


def sliding_block() -> Case:
    g, theta, phi = 9.81, np.radians(30.0), np.radians(20.0)
    exact = 0.5 * g * (np.sin(theta) - np.cos(theta) * np.tan(phi))
    return Case(
        "sliding_block",
        _load("sliding_block"),
        slid_distance,
        np.array([exact]),
        "distance slid in 1 s (m)",
        default_grid("sliding_block"),
    )


PUSH = 4000.0


def acceleration(r: dda.Result) -> np.ndarray:
    """2 x / t² of the block called ``top`` (constant acceleration from rest)."""
    return np.array([2 * r.final.displacements[_row(r, "top"), 0] / r.final.time**2])


def pushed_block() -> Case:
    raw = _load("paper_two_blocks", duration=0.5)
    raw["analysis"].pop("steps")
    # the defaults: undamped, an elastic block sliding on friction flutters (a growing
    # mode, docs/theory.md §3) that small steps resolve, so the rigid closed form would
    # be the answer of large steps only
    raw["analysis"].pop("start")
    raw["materials"]["rock"].pop("damping")
    raw["loads"][0]["force"] = [PUSH, -1000.0]
    g, density = 32.174, 4.0405
    weight = density * g * 32.0
    exact = (PUSH - np.tan(np.radians(30.0)) * (1000.0 + weight)) / (weight / g)

    return Case(
        "pushed_block",
        raw,
        acceleration,
        np.array([exact]),
        "acceleration (ft/s²)",
        default_grid("pushed_block"),
    )


BAR_LENGTH, BAR_HEIGHT = 2.0, 0.2  # m; pinned at (0, h/2), the middle of its left end


def swing_angle(r: dda.Result) -> np.ndarray:
    """The rotation (rad) of the block called ``bar``."""
    return np.array([r.final.rotations[_row(r, "bar")]])


def pendulum_angle(t: float, g: float = 9.81) -> float:
    """The angle φ (rad, from level, negative downward) at time t of the bar let go
    level from rest: ψ = φ + π/2 from the downward vertical obeys ψ'' = −ω₀² sin ψ,
    ω₀² = g d / k² (d = L/2 from pin to centroid, k² = (L² + h²)/12 + d²), so
    sin(ψ/2) = κ sn(K(κ²) − ω₀ t | κ²), κ = sin(ψ₀/2), ψ₀ = π/2."""
    d = BAR_LENGTH / 2
    omega_0 = np.sqrt(g * d / ((BAR_LENGTH**2 + BAR_HEIGHT**2) / 12 + d**2))
    kappa = np.sin(np.pi / 4)
    m = kappa**2
    sn = scipy.special.ellipj(scipy.special.ellipk(m) - omega_0 * t, m)[0]
    return float(2.0 * np.arcsin(kappa * sn) - np.pi / 2)


def pendulum() -> Case:
    rock = {"density": 2700.0, "young": 5e9, "poisson": 0.25, "damping": 0.0}
    bar = [[0.0, 0.0], [BAR_LENGTH, 0.0], [BAR_LENGTH, BAR_HEIGHT], [0.0, BAR_HEIGHT]]
    raw = {
        "title": "A bar swinging on a pin (compound pendulum)",
        "analysis": {"duration": 1.0, "gravity": [0.0, -9.81], "save_every": 10**6},
        "materials": {"rock": rock},
        "blocks": [{"name": "bar", "material": "rock", "vertices": bar,
                    "fixed_points": [[0.0, BAR_HEIGHT / 2]]}],
    }  # fmt: skip
    return Case(
        "pendulum",
        raw,
        swing_angle,
        np.array([pendulum_angle(1.0)]),
        "angle after 1 s (rad)",
        default_grid("pendulum"),
    )


def bottom_stress(r: dda.Result) -> np.ndarray:
    """σyy of the block called ``block1``."""
    return np.array([r.final.stresses[_row(r, "block1"), 1]])


def stack() -> Case:
    raw = _load("stack", duration=0.2)
    exact = -2700.0 * 9.81 * 4.5
    return Case(
        "stack",
        raw,
        bottom_stress,
        np.array([exact]),
        "σyy of the bottom block at 0.2 s (Pa)",
        default_grid("stack"),
    )


def centroids(r: dda.Result) -> np.ndarray:
    """The final centroids of every block."""
    return r.final.centroids.ravel()


def displacements(r: dda.Result) -> np.ndarray:
    """The final x and y displacements of every block."""
    return r.final.displacements[:, :2].ravel()


def scene_file(path: str) -> Case:
    """Any scene file: final centroids against a fine run (the file is read here, once,
    and checked: a bad scene raises :class:`dda.SceneError` naming the file)."""
    from dda.scene import load_scene

    load_scene(path)
    raw = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    time_step = raw.get("analysis", {}).get("time_step", 1e-3)
    return Case(
        Path(path).stem,
        raw,
        centroids,
        None,
        "final centroids (error / model size)",
        default_grid(SCENE_FILE, time_step),
        per_model_size=True,
    )


def wall() -> Case:
    raw = wall_scene(10, steps=100)
    raw["analysis"]["duration"] = 0.1
    raw["analysis"].pop("steps")
    return Case(
        "wall",
        raw,
        displacements,
        None,
        "block displacements at 0.1 s (error / largest displacement)",
        default_grid("wall"),
    )


BUILT_IN = {
    "sliding_block": sliding_block,
    "pushed_block": pushed_block,
    "pendulum": pendulum,
    "stack": stack,
    "wall": wall,
}


def case_name(name: str) -> str:
    """The name a case's files take: a built-in case's own, a scene file's stem (what
    :func:`get_case` names it, without reading the file)."""
    return name if name in BUILT_IN else Path(name).stem


def get_case(name: str) -> Case:
    """A built-in case by name, or a scene file by path."""
    if name in BUILT_IN:
        return BUILT_IN[name]()
    if Path(name).is_file():
        return scene_file(name)
    if name.endswith(".toml"):  # a scene file meant (was "unknown case 'x.toml'")
        why = "is not a file" if Path(name).exists() else "no such file"
        raise ValueError(f"{name}: {why}")
    raise ValueError(f"unknown case {name!r}: use {', '.join(BUILT_IN)} or a scene file")


def fine_setting(grid: dict[str, list]) -> Setting:
    """The converged reference run: AL, the stiffest penalty, 1/10 of the smallest
    tolerance, 1/4 of the smallest time step and ratio."""
    return Setting(
        "augmented-lagrangian",
        max(grid["penalty"]),
        min(grid["tolerance"]) / 10,
        min(grid["time_step"]) / 4,
        min(grid["ratio"]) / 4,
    )
