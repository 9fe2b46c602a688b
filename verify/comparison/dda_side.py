"""What the comparison needs from a DDA run, indexed by scene block.

The engine's frames index blocks by row; the FEM side indexes them by their
position in the scene. :class:`DdaSide` maps one onto the other by name,
measures each block's strain from its vertices and groups the contacts of
the frame by block pair. Only the public result types are read.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import polar

from dda import Frame, Result, Scene
from dda.result import LOCKED, OPEN, SLIDING


@dataclass(frozen=True)
class DdaInterface:
    """DDA contacts between two blocks (scene indices ``a < b``)."""

    closed: int  # closed contacts
    total: int  # contacts detected between the two blocks, open ones included
    locked: int  # closed contacts that stick
    sliding: int  # closed contacts that slide
    force: np.ndarray  # (2,) resultant force on block b from block a (x, y)
    penetration: float  # sum of the closed contacts' penetrations over ``total``
    max_penetration: float


@dataclass(frozen=True)
class DdaSide:
    """One DDA frame per scene block, plus the settling of the run."""

    stresses: np.ndarray  # (n, 3)
    strains: np.ndarray  # (n, 3) exx, eyy, gxy from the block's vertices
    centroid_displacement: np.ndarray  # (n, 2)
    vertex_displacement: tuple[np.ndarray, ...]  # (k_i, 2) each
    interfaces: dict[tuple[int, int], DdaInterface]
    settled: float  # relative stress change over the last saved frames
    summary: dict
    time: float = 0.0

    @classmethod
    def from_result(
        cls, result: Result, scene: Scene, frame: int = -1, start: Scene | None = None
    ) -> DdaSide:
        """Collect frame ``frame`` (default the last) of ``result`` in scene order;
        displacements and strains from the geometry of ``start`` (a turned scene,
        :mod:`verify.fem.turn`) instead of the first frame when it is given."""
        final = result.frames[frame]
        missing = [b.name for b in scene.blocks if b.name not in final.names]
        if missing:
            raise ValueError(
                f"blocks {missing} are not in the frame (broken?): "
                "the FEM comparison needs the scene's blocks intact"
            )
        side = cls.from_frames(result.frames[0], final, scene, start)
        index = frame % len(result.frames)
        settled = settling(result.frames[: index + 1])
        return cls(**{**side.__dict__, "settled": settled, "summary": dict(result.summary)})

    @classmethod
    def from_frames(
        cls, first: Frame, final: Frame, scene: Scene, start: Scene | None = None
    ) -> DdaSide:
        """Displacements of ``final`` against ``first`` (or the geometry of ``start``),
        in scene order."""
        rows = [final.block(b.name) for b in scene.blocks]
        first_rows = [first.block(b.name) for b in scene.blocks]
        before = [first.vertices[r] for r in first_rows]
        if start is not None:
            before = [np.asarray(b.vertices, dtype=float) for b in start.blocks]
        after = [final.vertices[r] for r in rows]
        moved = final.displacements[rows]
        if start is not None:  # centroid against the start geometry's
            moved = final.centroids[rows] - np.array([_centroid(v) for v in before])
        to_scene = {row: i for i, row in enumerate(rows)}
        return cls(
            stresses=final.stresses[rows],
            strains=np.array([block_strain(x0, x1) for x0, x1 in zip(before, after, strict=True)]),
            centroid_displacement=moved,
            vertex_displacement=tuple(x1 - x0 for x0, x1 in zip(before, after, strict=True)),
            interfaces=group_contacts(final.contacts, to_scene),
            settled=float("nan"),
            summary={},
            time=float(final.time),
        )


def _centroid(vertices: np.ndarray) -> np.ndarray:
    """Area centroid of a polygon (shoelace)."""
    x, y = vertices[:, 0], vertices[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = cross.sum() / 2.0
    return np.array(
        [((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()]
    ) / (6.0 * area)


def block_strain(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(exx, eyy, gxy) of the affine map that takes a block's vertices ``before`` to ``after``.

    A DDA block moves by one affine map (rigid motion and constant strain,
    docs/theory.md §1), so its vertices determine it: the deformation
    gradient F is the least-squares fit of ``after − c' = F (before − c)``,
    and the strain the stretch of its polar decomposition F = R U, U − I
    (engineering shear 2 U_xy), free of the block's rotation.
    """
    x0 = before - before.mean(axis=0)
    x1 = after - after.mean(axis=0)
    gradient = np.linalg.lstsq(x0, x1, rcond=None)[0].T
    _, stretch = polar(gradient)
    e = stretch - np.eye(2)
    return np.array([e[0, 0], e[1, 1], 2.0 * e[0, 1]])


def contact_force_vectors(contacts) -> np.ndarray:
    """(m, 2) force on the vertex block (``block_a``) of every contact.

    ``normal_force`` N acts along the normal (from ``block_b`` towards
    ``block_a``), and the shear force T is the force coefficient along the
    edge direction t = (−n_y, n_x) of ``block_b``: the vertex block feels
    N n − T t (the spring pulls it back against its slip).
    """
    n = np.asarray(contacts.normals, dtype=float).reshape(-1, 2)
    t = np.column_stack([-n[:, 1], n[:, 0]])
    closed = np.asarray(contacts.state) != OPEN
    normal = np.where(closed, contacts.normal_force, 0.0)
    shear = np.where(closed, contacts.shear_force, 0.0)
    return normal[:, None] * n - shear[:, None] * t


def group_contacts(contacts, to_scene: dict[int, int]) -> dict[tuple[int, int], DdaInterface]:
    """Contacts grouped by (scene) block pair, ``a < b``."""
    if not len(contacts):
        return {}
    a = np.array([to_scene[int(r)] for r in contacts.block_a], dtype=int)
    b = np.array([to_scene[int(r)] for r in contacts.block_b], dtype=int)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    state = np.asarray(contacts.state)
    closed = state != OPEN
    penetration = np.where(closed, np.asarray(contacts.penetration), 0.0)
    # force on the higher-index block: the vertex block's force, turned round if it is the lower
    on_hi = contact_force_vectors(contacts) * np.where(a == hi, 1.0, -1.0)[:, None]
    out = {}
    for pair in sorted(set(zip(lo.tolist(), hi.tolist(), strict=True))):
        on = (lo == pair[0]) & (hi == pair[1])
        out[pair] = DdaInterface(
            closed=int((on & closed).sum()),
            total=int(on.sum()),
            locked=int((on & (state == LOCKED)).sum()),
            sliding=int((on & (state == SLIDING)).sum()),
            force=on_hi[on].sum(axis=0),
            penetration=float(penetration[on].sum() / on.sum()),
            max_penetration=float(penetration[on].max()),
        )
    return out


def settling(frames: list[Frame]) -> float:
    """Largest stress change between the last two frames over the largest stress.

    A static DDA run iterates time steps towards equilibrium; a value near
    round-off means the final frame is settled.
    """
    if len(frames) < 3:
        return float("nan")
    last, before = frames[-1].stresses, frames[-2].stresses
    if last.shape != before.shape:
        return float("nan")
    scale = max(float(np.abs(last).max()), np.finfo(float).tiny)
    return float(np.abs(last - before).max() / scale)
