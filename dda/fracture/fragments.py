"""Fragments of broken blocks and the new BlockSet that holds them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dda.blocks import BlockSet
from dda.fracture.children import children_state
from dda.fracture.edges import fragment_edge_joints
from dda.geometry import owner_of_vertex, pack_polygons, polygon_moments


@dataclass(frozen=True)
class Fragments:
    """The pieces of one broken block, with everything a BlockSet row needs.

    Attributes
    ----------
    parent : row of the broken block in the old BlockSet
    polygons : list of (k_i, 2) counter-clockwise arrays
    names, ids : of the pieces ("parent/1", ...; fresh ids)
    edge_joint : (Σk_i,) joint row of every piece edge, packed like the polygons
    velocity : (m, 6) the parent's velocity field at each piece centroid (eq. 2)
    stress : (m, 3) the parent's stress
    rotation : (m,) the parent's accumulated rotation
    displacement : (m, 2) centroid displacement since the start (see ``of``)
    """

    parent: int
    polygons: list[np.ndarray]
    names: tuple[str, ...]
    ids: np.ndarray
    edge_joint: np.ndarray
    velocity: np.ndarray
    stress: np.ndarray
    rotation: np.ndarray
    displacement: np.ndarray

    @classmethod
    def of(
        cls,
        blocks: BlockSet,
        row: int,
        polygons: list[np.ndarray],
        names: tuple[str, ...],
        ids: np.ndarray,
        crack_joint: int,
    ) -> Fragments:
        """Pieces ``polygons`` of block ``row``: motion, stress and joints inherited.

        The displacement of a piece since the start is estimated from the
        parent's rigid motion: the material point now at the piece centroid
        c was at x0 − u + R(−θ)(c − x0), with x0, u, θ the parent's centroid,
        displacement and rotation (the parent's strain is neglected here).
        """
        parent_xy = blocks.polygon(row)
        parent_joints = blocks.edge_joint[blocks.offsets[row] : blocks.offsets[row + 1]]
        joints = np.concatenate(
            [fragment_edge_joints(parent_xy, parent_joints, p, crack_joint) for p in polygons]
        )
        centroid = polygon_moments(*pack_polygons(polygons))["centroid"]
        x0 = blocks.centroid[row]
        velocity, stress = children_state(blocks.velocity[row], x0, blocks.stress[row], centroid)
        theta = blocks.rotation[row]
        arm = centroid - x0
        c, s = np.cos(theta), np.sin(theta)
        unrotated = np.column_stack([c * arm[:, 0] + s * arm[:, 1], -s * arm[:, 0] + c * arm[:, 1]])
        m = len(polygons)
        return cls(
            parent=row,
            polygons=polygons,
            names=names,
            ids=ids,
            edge_joint=joints,
            velocity=velocity,
            stress=stress,
            rotation=np.full(m, theta),
            displacement=blocks.displacement[row] + arm - unrotated,
        )


def parent_rows(old: BlockSet, new: BlockSet) -> np.ndarray:
    """Each new block's row in ``old``: its own, or its parent's for a piece (named
    "parent/k")."""
    row_of = {name: row for row, name in enumerate(old.names)}
    return np.array(
        [row_of[name] if name in row_of else row_of[name.rsplit("/", 1)[0]] for name in new.names],
        dtype=np.int64,
    )


def replace_blocks(
    blocks: BlockSet, broken: list[Fragments], removed: np.ndarray | None = None
) -> BlockSet:
    """A new BlockSet: the unbroken blocks in their order, then every fragment.

    Vectorised over the kept blocks (one mask over the packed vertices);
    only the fragments are handled one by one. ``removed``: (n,) bool, blocks
    left out without fragments (excavated by a stage, :mod:`dda.run.stages`).
    """
    gone = np.zeros(blocks.count, dtype=bool) if removed is None else removed.copy()
    gone[[f.parent for f in broken]] = True
    keep = np.flatnonzero(~gone)
    keep_vertex = ~gone[owner_of_vertex(blocks.offsets)]
    pieces = [p for f in broken for p in f.polygons]
    piece_vertices, piece_offsets = pack_polygons(pieces)
    counts = np.concatenate([np.diff(blocks.offsets)[keep], np.diff(piece_offsets)])
    offsets = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])

    def stack(old: np.ndarray, field: str) -> np.ndarray:
        return np.concatenate([old[keep], *[getattr(f, field) for f in broken]])

    return BlockSet(
        names=[blocks.names[k] for k in keep] + [n for f in broken for n in f.names],
        ids=stack(blocks.ids, "ids"),
        material=np.concatenate(
            [
                blocks.material[keep],
                *[np.full(len(f.names), blocks.material[f.parent]) for f in broken],
            ]
        ),
        vertices=np.concatenate([blocks.vertices[keep_vertex], piece_vertices]),
        offsets=offsets,
        edge_joint=np.concatenate(
            [blocks.edge_joint[keep_vertex], *[f.edge_joint for f in broken]]
        ),
        velocity=stack(blocks.velocity, "velocity"),
        acceleration=np.concatenate(  # a fragment's is not known: Shi's update once
            [blocks.acceleration[keep], np.full((len(pieces), 6), np.nan)]
        ),
        stress=stack(blocks.stress, "stress"),
        rotation=stack(blocks.rotation, "rotation"),
        displacement=stack(blocks.displacement, "displacement"),
        fixed=np.concatenate([blocks.fixed[keep], np.zeros(len(pieces), dtype=bool)]),
        origin=np.concatenate(
            [
                blocks.origin[keep],
                *[np.full(len(f.names), blocks.origin[f.parent]) for f in broken],
            ]
        ),
        mass_area=np.concatenate(  # a fragment keeps its share of the parent's mass
            [blocks.mass_area[keep], *[_mass_areas(blocks, f) for f in broken]]
        ),
    )


def _mass_areas(blocks: BlockSet, fragments: Fragments) -> np.ndarray:
    """Each fragment's area times its parent's density ratio (its share of the mass)."""
    areas = polygon_moments(*pack_polygons(fragments.polygons))["area"]
    return areas * blocks.density_ratio[fragments.parent]
