"""Scene builders shared by the tests (plain dicts in the scene format)."""

from __future__ import annotations

import numpy as np

ROCK = {"density": 2700.0, "young": 5.0e9, "poisson": 0.25}
G = 9.81


def rotated(points, degrees: float) -> list[list[float]]:
    """Rotate points about the origin."""
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    return [[c * x - s * y, s * x + c * y] for x, y in points]


def rectangle(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def slope_scene(
    friction: float,
    method: str = "augmented-lagrangian",
    angle: float = 30.0,
    duration: float = 1.0,
    time_step: float = 0.01,
) -> dict:
    """A 1 x 0.5 block resting on a fixed slab inclined at ``angle`` degrees."""
    return {
        "title": "slope",
        "analysis": {"time_step": time_step, "duration": duration, "gravity": [0.0, -G]},
        "contact": {"method": method, "penalty": 5e10, "tolerance": 1e-6},
        "materials": {"rock": ROCK},
        "joints": {"default": {"friction_angle": friction}},
        "blocks": [
            {
                "name": "slope",
                "material": "rock",
                "fixed": True,
                "vertices": rotated(rectangle(0, -1, 10, 0), angle),
            },
            {
                "name": "slider",
                "material": "rock",
                "vertices": rotated(rectangle(4, 0, 5, 0.5), angle),
            },
        ],
    }


def projectile_scene(omega: float = 0.0) -> dict:
    """A free unit square thrown at (3, 4) m/s (spinning at ``omega``) under gravity, 1 s."""
    return {
        "analysis": {
            "time_step": 0.01,
            "duration": 1.0,
            "gravity": [0.0, -G],
            "max_displacement_ratio": 0.9,
        },
        "materials": {"rock": ROCK},
        "blocks": [
            {
                "name": "b",
                "material": "rock",
                "vertices": rectangle(0, 0, 1, 1),
                "velocity": [3.0, 4.0, omega],
            }
        ],
    }


def use_policy(monkeypatch, **changes) -> None:
    """Runs started from now take the step policy's defaults with ``changes``
    (:class:`dda.solve.policy.StepPolicy`), e.g. ``band_work=0.0``: no band systems."""
    import dataclasses

    import dda.solve.policy as policy

    monkeypatch.setattr(policy, "DEFAULT", dataclasses.replace(policy.DEFAULT, **changes))
