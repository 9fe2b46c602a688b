"""Progress of a rock-mass cut, reported stage by stage to a callback.

The cut calls ``progress(fraction, info)`` (the signature of ``dda.simulate``'s
``progress``) once before it starts and at the end of every stage; stages that work
through a known number of items (joint traces clipped to the rock, block edges tagged,
block tables written) run in up to :data:`CHUNKS` vectorised chunks and report after
each.
``fraction`` is in [0, 1], never decreases and ends at exactly 1;
``info = {"stage": name, "blocks": estimate}``: the stage the cut is in from now on
(one of :data:`STAGES`, then ``"done"``) and the estimate of
:mod:`dda.scene.rockmass.estimate` (a caller shows a bar only for cuts it deems long).

The fraction moves about evenly with time: a stage's share of it is its share of the
wall time of the cuts of docs/benchmarks.md (one set of 50,000 strips, two sets of
13,000 and 140,000 blocks), about 20 µs a joint trace for the clipping and 150 µs an
estimated block for the rest, split by :data:`REST`. Without a callback nothing is
chunked and nothing is called.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

#: a callback ``progress(fraction, info)``
Progress = Callable[[float, dict], None]

TRACES_SHARE = 0.01  # stage "traces": the joint traces of every set
CLIP_COST = 20e-6  # s a joint trace: stage "clipping", the traces clipped to the rock
BLOCK_COST = 150e-6  # s an estimated block: the stages of REST
#: share of the time after the clipping, in the order the cut runs the stages
REST = {
    "noding": 0.30,  # crossings of the joint pieces found
    "polygonising": 0.24,  # faces of the noded linework, each found in its region
    "merging": 0.04,  # holes split, slivers merged, polygons checked
    "tagging": 0.28,  # faces packed and named, each edge tagged with its joint
    "selecting": 0.09,  # fixed blocks and groups
    "tables": 0.05,  # the explicit [[blocks]] tables
}
#: the stages in the order the cut runs them
STAGES = ("traces", "clipping", *REST)
CHUNKS = 10  # chunks of a stage with a known count
MIN_CHUNK = 1_000  # items: smaller stages run in one piece


class CutProgress:
    """Reports the stages of one cut to ``callback`` (None: a reporter that does nothing).

    Parameters
    ----------
    callback
        ``callback(fraction, info)``, or None.
    blocks
        The estimated number of blocks, passed in every ``info``.
    """

    def __init__(self, callback: Progress | None, blocks: int) -> None:
        self.callback = callback
        self.blocks = int(blocks)
        self.fraction = 0.0
        self._start: dict[str, float] = {}
        self._share: dict[str, float] = {}
        self.plan(traces=0)
        self._report(0.0, STAGES[0])

    def plan(self, traces: int) -> None:
        """Share the fraction among the stages for ``traces`` joint traces (before the
        stage "traces" is reported done)."""
        clip_time, rest_time = CLIP_COST * traces, BLOCK_COST * max(self.blocks, 1)
        clipping = (1.0 - TRACES_SHARE) * clip_time / (clip_time + rest_time)
        rest = 1.0 - TRACES_SHARE - clipping
        self._share = {"traces": TRACES_SHARE, "clipping": clipping}
        self._share.update({stage: rest * share for stage, share in REST.items()})
        ends = np.cumsum(list(self._share.values())).tolist()
        self._start = dict(zip(self._share, [0.0, *ends[:-1]], strict=True))

    def done(self, stage: str, part: float = 1.0) -> None:
        """``part`` (0 to 1) of ``stage`` is done."""
        if self.callback is None:
            return
        part = min(max(part, 0.0), 1.0)
        if part < 1.0:
            now = stage
        else:
            later = STAGES.index(stage) + 1
            now = STAGES[later] if later < len(STAGES) else "done"
        fraction = 1.0 if now == "done" else self._start[stage] + self._share[stage] * part
        self._report(min(fraction, 1.0), now)

    def chunks(self, stage: str, count: int) -> Iterator[slice]:
        """Slices of ``range(count)`` in up to :data:`CHUNKS` pieces, the part of ``stage``
        done reported after each but the last (the caller says when the stage is done);
        one piece without a callback or for a small count."""
        pieces = 1 if self.callback is None else max(1, min(CHUNKS, count // MIN_CHUNK))
        bounds = np.linspace(0, count, pieces + 1).round().astype(int)
        for k in range(pieces):
            yield slice(int(bounds[k]), int(bounds[k + 1]))
            if k + 1 < pieces:
                self.done(stage, (k + 1) / pieces)

    def _report(self, fraction: float, now: str) -> None:
        if self.callback is None:
            return
        self.fraction = max(self.fraction, fraction)
        self.callback(self.fraction, {"stage": now, "blocks": self.blocks})
