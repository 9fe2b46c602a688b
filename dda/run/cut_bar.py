"""The progress bar of a long rock-mass cut (``dda cut``, ``dda run`` of a rock-mass scene).

A :class:`CutBar` is the ``progress`` callback of the cut
(:mod:`dda.scene.rockmass.progress`): it draws a :class:`~dda.run.progress.ProgressBar`
on standard error, labelled with the estimated number of blocks and followed by the
stage the cut is in, only when the estimate is at least ``threshold`` blocks
(:data:`LONG_CUT`, about a second of cutting); a smaller cut prints nothing.

The cut fills the bar up to ``share``; the scene loader then checks the cut blocks
(stage "checking"), and the caller may show stages of its own after that. Loading a
scene (``dda run``) gives the cut :data:`LOAD_SHARE`: of loading two crossing sets cut
into 13,279 blocks (docs/benchmarks.md), the cut took 66 %, the check 34 %.

Examples
--------
>>> with CutBar("slope.toml") as bar:  # doctest: +SKIP
...     scene = dda.load_scene("slope.toml", progress=bar)
...     bar.finish()
"""

from __future__ import annotations

from typing import TextIO

from dda.run.progress import ProgressBar

LONG_CUT = 5_000  # estimated blocks from which the cut is shown (about 1 s of cutting)
LOAD_SHARE = 0.65  # of loading a rock-mass scene: the cut; the rest checks its blocks


class CutBar:
    """A cut's progress as a bar over ``[0, share]`` (the rest for the check and the
    caller's later stages, told through :meth:`update`), or nothing for a short cut.

    Parameters
    ----------
    name
        The scene, in front of the bar.
    share
        The part of the bar the cut fills.
    threshold
        The estimated block count from which the bar is drawn (default :data:`LONG_CUT`).
    stream
        Where to write; default standard error.
    quiet
        Draw nothing, whatever the cut (``-q``). The cut, given a callback, does not
        log its "may take a minute" warning either.
    """

    def __init__(
        self,
        name: str,
        share: float = LOAD_SHARE,
        threshold: int | None = None,
        stream: TextIO | None = None,
        quiet: bool = False,
    ) -> None:
        self.name = name
        self.share = share
        self.threshold = LONG_CUT if threshold is None else threshold
        self.stream = stream
        self.quiet = quiet
        self.bar: ProgressBar | None = None
        self._decided = False

    def __call__(self, fraction: float, info: dict) -> None:
        """The cut's callback: ``fraction`` of the cut done, ``info`` its stage and estimate."""
        if not self._decided:
            self._decided = True
            blocks = int(info.get("blocks", 0))
            if blocks >= self.threshold and not self.quiet:
                label = f"{self.name} (~{blocks:,} blocks)"
                self.bar = ProgressBar(1.0, label=label, stream=self.stream)
        stage = str(info.get("stage", ""))
        self.update(self.share * fraction, "checking" if stage == "done" else stage)

    def update(self, fraction: float, stage: str) -> None:
        """Show ``fraction`` (of the whole bar) done and the ``stage`` now running."""
        if self.bar is not None:
            self.bar.update(fraction, stage=stage)

    def finish(self) -> None:
        """Show everything done and end the line."""
        self.update(1.0, "done")
        self.close()

    def close(self) -> None:
        """End the bar's line (nothing when no bar was drawn)."""
        if self.bar is not None:
            self.bar.close()

    def __enter__(self) -> CutBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
