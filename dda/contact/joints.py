"""Which joint each contact uses: interface override, else the edge's joint, else default."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.law import JointProperties


class JointTable:
    """Joint properties as arrays, plus the ``[[interfaces]]`` overrides by block id pair.

    The pair is of scene blocks (``BlockSet.origin``): a fragment of a block
    meets the other block of an interface through that interface's joint;
    two fragments of one block meet through their crack's joint.

    ``factor`` (F, 1 unless a ``[[stages]]`` entry sets ``strength_factor``) divides the
    strengths the contacts get: tan φ / F, c / F, T / F.
    """

    def __init__(
        self,
        names: list[str],
        friction_angle: np.ndarray,
        cohesion: np.ndarray,
        tensile: np.ndarray,
        interface_ids: np.ndarray,
        interface_joint: np.ndarray,
    ) -> None:
        self.names = names
        self.tan_friction = np.tan(np.radians(friction_angle))
        self.cohesion = np.asarray(cohesion, float)
        self.tensile = np.asarray(tensile, float)
        self.factor = 1.0
        self.default = names.index("default")
        keys = (
            self._pair_keys(interface_ids[:, 0], interface_ids[:, 1])
            if len(interface_ids)
            else np.zeros(0, np.int64)
        )
        order = np.argsort(keys)
        self.interface_keys = keys[order]
        self.interface_joint = np.asarray(interface_joint, np.int64)[order]

    @staticmethod
    def _pair_keys(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        return lo.astype(np.int64) * (1 << 31) + hi

    @property
    def has_friction(self) -> bool:
        return bool(np.any(self.tan_friction > 0) or np.any(self.cohesion > 0))

    def rows_for(self, blocks: BlockSet, contacts: ContactSet) -> np.ndarray:
        """Joint row of each contact."""
        rows = blocks.edge_joint[contacts.edge]
        rows = np.where(rows >= 0, rows, self.default)
        if len(self.interface_keys) and len(contacts):
            origin = blocks.origin  # fragments keep their scene block's interfaces
            keys = self._pair_keys(origin[contacts.block_a], origin[contacts.block_b])
            at = np.clip(
                np.searchsorted(self.interface_keys, keys), 0, len(self.interface_keys) - 1
            )
            hit = self.interface_keys[at] == keys
            rows = np.where(hit, self.interface_joint[at], rows)
        return rows

    def properties(self, rows: np.ndarray, contact_length: np.ndarray) -> JointProperties:
        """tan φ / F and the cohesion and tensile forces c·l / F, T·l / F of each contact
        (F = ``factor``; x / 1 is x to the bit)."""
        f = self.factor
        return JointProperties(
            friction=self.tan_friction[rows] / f,
            cohesion=self.cohesion[rows] * contact_length / f,
            tensile=self.tensile[rows] * contact_length / f,
        )
