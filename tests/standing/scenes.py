"""Scene builders of the hard cases (plain dicts in the scene format)."""

from __future__ import annotations

import numpy as np

from tests.helpers import ROCK, G, rectangle, rotated


def scene(
    blocks: list[dict],
    analysis: dict | None = None,
    contact: dict | None = None,
    materials: dict | None = None,
    friction: float = 30.0,
) -> dict:
    """A scene under gravity with AL contact (tolerance 1e-5) unless told otherwise."""
    analysis = {"time_step": 0.002, "gravity": [0.0, -G], **(analysis or {})}
    if "steps" not in analysis:
        analysis.setdefault("duration", 0.3)
    return {
        "analysis": analysis,
        "contact": {"method": "augmented-lagrangian", "tolerance": 1e-5, **(contact or {})},
        "materials": materials or {"rock": ROCK},
        "joints": {"default": {"friction_angle": friction}},
        "blocks": blocks,
    }


def block(name: str, vertices, material: str = "rock", **more) -> dict:
    return {"name": name, "material": material, "vertices": [list(p) for p in vertices], **more}


def base(x0: float = -2.0, x1: float = 3.0, material: str = "rock") -> dict:
    """A fixed slab whose top face is y = 0."""
    return block("base", rectangle(x0, -1.0, x1, 0.0), material, fixed=True)


def placed(vertices, degrees: float, dx: float, dy: float) -> list[list[float]]:
    """Rotate about the origin, then translate."""
    return [[x + dx, y + dy] for x, y in rotated(vertices, degrees)]


def column(count: int, gap: float = 1e-3) -> list[dict]:
    """``count`` unit blocks stacked on the base with a small gap under each."""
    blocks = [base()]
    for k in range(count):
        y0 = gap + k * (1.0 + gap)
        blocks.append(block(f"b{k}", rectangle(0.0, y0, 1.0, y0 + 1.0)))
    return blocks


def arch(voussoirs: int = 36, radius: float = 5.0, thickness_ratio: float = 0.15) -> list[dict]:
    """A semicircular arch of trapezoidal voussoirs on a fixed base (centre line ``radius``)."""
    t = thickness_ratio * radius
    inner, outer = radius - t / 2, radius + t / 2
    blocks = [block("base", rectangle(-radius - 2, -1.0, radius + 2, 0.0), fixed=True)]
    for k in range(voussoirs):
        a0, a1 = np.pi * k / voussoirs, np.pi * (k + 1) / voussoirs
        ring = [
            (outer * np.cos(a0), outer * np.sin(a0)),
            (outer * np.cos(a1), outer * np.sin(a1)),
            (inner * np.cos(a1), inner * np.sin(a1)),
            (inner * np.cos(a0), inner * np.sin(a0)),
        ]
        blocks.append(block(f"v{k}", ring))
    return blocks


def diamond(cx: float, cy: float) -> list[tuple[float, float]]:
    """A unit square standing on a corner, centred at (cx, cy)."""
    h = np.sqrt(0.5)
    return [(cx, cy - h), (cx + h, cy), (cx, cy + h), (cx - h, cy)]


def regular_polygon(sides: int, radius: float) -> list[tuple[float, float]]:
    """A regular polygon with a flat bottom edge on y = 0."""
    start = -np.pi / 2 - np.pi / sides
    lift = radius * np.cos(np.pi / sides)
    return [
        (
            radius * np.cos(start + 2 * np.pi * k / sides),
            radius * np.sin(start + 2 * np.pi * k / sides) + lift,
        )
        for k in range(sides)
    ]
