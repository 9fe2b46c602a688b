"""What the comparison needs from a DDA run, indexed by scene block.

The engine's frames index blocks by row; the FEM side indexes them by their
position in the scene. :class:`DdaSide` maps one onto the other by name and
groups the closed contacts of the final frame by block pair.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.result import OPEN, Result
from dda.scene import Scene

LOCKED = 2


@dataclass(frozen=True)
class DdaInterface:
    """Closed DDA contacts between two blocks (scene indices ``a < b``)."""

    count: int  # closed contacts
    total: int  # contacts detected between the two blocks, open ones included
    locked: bool
    normal_force: float  # sum over the contacts, compression positive
    penetration: float  # mean over the contacts
    max_penetration: float


@dataclass(frozen=True)
class DdaSide:
    """Final DDA state per scene block, plus the settling of the static run."""

    stresses: np.ndarray  # (n, 3)
    centroid_displacement: np.ndarray  # (n, 2)
    vertex_displacement: tuple[np.ndarray, ...]  # (k_i, 2) each
    interfaces: dict[tuple[int, int], DdaInterface]
    settled: float  # relative stress change over the last saved frames
    summary: dict

    @classmethod
    def from_result(cls, result: Result, scene: Scene) -> DdaSide:
        """Collect the final frame of ``result`` in scene order."""
        first, final = result.frames[0], result.final
        missing = [b.name for b in scene.blocks if b.name not in final.names]
        if missing:
            raise ValueError(
                f"blocks {missing} are not in the final frame (broken?): "
                "the FEM comparison needs the scene's blocks intact"
            )
        rows = [final.block(b.name) for b in scene.blocks]
        first_rows = [first.block(b.name) for b in scene.blocks]
        vertex_displacement = tuple(
            final.vertices[r] - first.vertices[r0] for r, r0 in zip(rows, first_rows, strict=True)
        )
        to_scene = {row: i for i, row in enumerate(rows)}
        return cls(
            stresses=final.stresses[rows],
            centroid_displacement=final.displacements[rows],
            vertex_displacement=vertex_displacement,
            interfaces=group_contacts(final.contacts, to_scene),
            settled=settling(result),
            summary=dict(result.summary),
        )

    def closed_pairs(self) -> dict[tuple[int, int], tuple[int, bool]]:
        """``(a, b) -> (contact count, locked)`` for :func:`verify.interfaces.with_dda_contacts`."""
        return {pair: (i.count, i.locked) for pair, i in self.interfaces.items()}


def group_contacts(contacts, to_scene: dict[int, int]) -> dict[tuple[int, int], DdaInterface]:
    """Closed contacts grouped by (scene) block pair (pairs with none closed left out)."""
    state_all = np.asarray(contacts.state)
    pair_all = [
        tuple(sorted((to_scene[int(a)], to_scene[int(b)])))
        for a, b in zip(contacts.block_a, contacts.block_b, strict=True)
    ]
    closed = state_all != OPEN
    a = np.array([to_scene[int(r)] for r in contacts.block_a[closed]], dtype=int)
    b = np.array([to_scene[int(r)] for r in contacts.block_b[closed]], dtype=int)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    normal = np.asarray(contacts.normal_force)[closed]
    penetration = np.asarray(contacts.penetration)[closed]
    state = np.asarray(contacts.state)[closed]
    out = {}
    for pair in sorted(set(zip(lo.tolist(), hi.tolist(), strict=True))):
        on = (lo == pair[0]) & (hi == pair[1])
        out[pair] = DdaInterface(
            count=int(on.sum()),
            total=sum(p == pair for p in pair_all),
            locked=bool((state[on] == LOCKED).any()),
            normal_force=float(normal[on].sum()),
            penetration=float(penetration[on].mean()),
            max_penetration=float(penetration[on].max()),
        )
    return out


def settling(result: Result) -> float:
    """Largest stress change between the last two saved frames over the largest stress.

    A static DDA run iterates time steps towards equilibrium; a value near
    round-off means the final frame is settled.
    """
    if len(result.frames) < 3:
        return float("nan")
    last, before = result.frames[-1].stresses, result.frames[-2].stresses
    if last.shape != before.shape:
        return float("nan")
    scale = max(float(np.abs(last).max()), np.finfo(float).tiny)
    return float(np.abs(last - before).max() / scale)
