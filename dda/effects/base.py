"""The interface every block-diagonal effect implements."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dda.blocks import BlockSet
from dda.effects.pair_springs import PairSprings


@dataclass
class StepContext:
    """What an effect may read during one step attempt."""

    dt: float  # step length
    time: float  # time at the end of the step
    step: int  # index of the step being computed (1-based)
    static: bool
    extras: dict = field(default_factory=dict)
    # (n, 6) step of the fixed blocks that follow the ground (dda.effects.seismic), else None
    prescribed: np.ndarray | None = None


class Effect:
    """One physical term. Subclasses override what they contribute.

    ``stiffness`` returns (n, 6, 6) diagonal blocks of K (or None);
    ``forces`` returns (n, 6) additions to F (or None); ``couplings`` the
    springs it puts between two blocks (:mod:`dda.effects.pair_springs`, or None); all
    are evaluated once per step attempt. ``after_step`` lets an effect move its own state
    (tracked material points, ...) once a step is accepted.
    """

    name = "effect"

    def stiffness(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray | None:
        return None

    def forces(self, blocks: BlockSet, ctx: StepContext) -> np.ndarray | None:
        return None

    def couplings(self, blocks: BlockSet, ctx: StepContext) -> PairSprings | None:
        """Springs between two blocks (off-diagonal blocks of K), or None."""
        return None

    def after_step(self, blocks: BlockSet, d: np.ndarray, ctx: StepContext) -> None:
        return None

    def on_blocks_replaced(self, old: BlockSet, new: BlockSet, parent_of: np.ndarray) -> None:
        """Blocks were split: ``parent_of[k]`` is the old row of new block k."""
        return None

    def preload(self, blocks: BlockSet, d: np.ndarray) -> None:
        """Take on, with the blocks where they are, the forces the effect's springs would
        have after the step ``d`` (the equilibrium start, dda.run.equilibrium_start)."""
        return None
