"""Which joint each contact uses: interface override, else the edge's joint, else default."""

from __future__ import annotations

import numpy as np

from dda.blocks import BlockSet
from dda.contact.contact_set import ContactSet
from dda.contact.strength import JointProperties


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
        residual: dict[str, np.ndarray] | None = None,
    ) -> None:
        """``residual``: per joint, optional ``friction_angle``, ``cohesion``, ``tensile``
        (the residual strengths; defaults: the peak angle, 0, 0), ``barton`` (bool),
        ``jrc``, ``jcs`` and ``divisor`` (Barton–Bandis; :class:`JointProperties`) and
        ``restitution`` (e, NaN for none: :mod:`dda.solve.contact_dashpots`)."""
        self.names = names
        self.tan_friction = np.tan(np.radians(friction_angle))
        self.cohesion = np.asarray(cohesion, float)
        self.tensile = np.asarray(tensile, float)
        residual = residual or {}
        count = len(names)
        angle = np.asarray(residual.get("friction_angle", friction_angle), float)
        self.residual_angle = np.radians(angle)
        self.tan_residual = np.tan(self.residual_angle)
        self.residual_cohesion = np.asarray(residual.get("cohesion", np.zeros(count)), float)
        self.residual_tensile = np.asarray(residual.get("tensile", np.zeros(count)), float)
        self.barton = np.asarray(residual.get("barton", np.zeros(count, bool)), bool)
        self.jrc = np.asarray(residual.get("jrc", np.zeros(count)), float)
        self.jcs = np.asarray(residual.get("jcs", np.zeros(count)), float)
        self.divisor = np.asarray(residual.get("divisor", np.ones(count)), float)
        self.restitution = np.asarray(residual.get("restitution", np.full(count, np.nan)), float)
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
    def has_restitution(self) -> bool:
        """Some joint has a coefficient of restitution (its contacts get dashpots)."""
        return bool(np.any(np.isfinite(self.restitution)))

    @property
    def has_friction(self) -> bool:
        return bool(
            np.any(self.tan_friction > 0) or np.any(self.cohesion > 0) or np.any(self.barton)
        )

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
        """Each contact's strengths: tan φ / F and the cohesion and tensile forces
        c·l / F, T·l / F, peak and residual; a Barton–Bandis joint's shear strength
        (cohesion included) divided by F through its divisor (F = ``factor``; x / 1 is x
        to the bit)."""
        f = self.factor
        barton = self.barton[rows]
        return JointProperties(
            friction=self.tan_friction[rows] / f,
            cohesion=self.cohesion[rows] * contact_length / np.where(barton, 1.0, f),
            tensile=self.tensile[rows] * contact_length / f,
            residual_friction=self.tan_residual[rows] / f,
            residual_cohesion=self.residual_cohesion[rows] * contact_length / f,
            residual_tensile=self.residual_tensile[rows] * contact_length / f,
            barton=barton,
            jrc=self.jrc[rows],
            jcs_length=self.jcs[rows] * contact_length,
            residual_angle=self.residual_angle[rows],
            divisor=self.divisor[rows] * f,
        )
