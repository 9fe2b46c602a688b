"""Room on the output disk for a run, checked before it writes anything.

A run writes its frames as it goes and keeps one checkpoint, replaced by the next
(the old one stays until the new one is whole, so both are on disk for a moment),
which grows with the steps done (:mod:`dda.scene.limits`). Before the run:

- the estimate is logged (INFO): frames, the largest checkpoint, the total;
- a run whose disk cannot hold what it writes before its first step (the first
  frame and the first checkpoint) is refused: it could only fail;
- a run whose whole estimate exceeds the free space gets a warning: it may stop on a
  full disk, cleanly and with a checkpoint to resume from (docs/runs.md), and space
  may be freed while it runs.

The free space counts the files of an earlier run that ``--overwrite`` removes.
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dda.io.output_paths import OutputError
from dda.scene.limits import (
    estimated_checkpoint_bytes,
    estimated_frame_bytes,
    estimated_frames,
)

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class DiskNeed:
    """What a run is estimated to write, in bytes."""

    frames: int  # every kept frame, with its history rows
    frame: int  # one frame
    first_checkpoint: int  # the checkpoint of step 0
    checkpoint: int  # the last (largest) checkpoint

    @property
    def start(self) -> int:
        """What the run writes before its first step: a frame and a checkpoint."""
        return self.frame + self.first_checkpoint

    @property
    def total(self) -> int:
        """The frames and, at the end, two checkpoints (the last while it is written)."""
        return self.frames + 2 * self.checkpoint


def disk_need(scene: Any) -> DiskNeed:
    """The bytes a run of ``scene`` is estimated to write (:mod:`dda.scene.limits`)."""
    frame = estimated_frame_bytes(scene)
    return DiskNeed(
        frames=estimated_frames(scene) * frame,
        frame=frame,
        first_checkpoint=estimated_checkpoint_bytes(scene, steps=0),
        checkpoint=estimated_checkpoint_bytes(scene),
    )


def check_disk_space(scene: Any, outdir: str | Path, reclaimable: int = 0) -> DiskNeed:
    """Log the run's estimated output; refuse a disk that cannot hold its start, warn
    about one that cannot hold all of it (module docstring).

    Parameters
    ----------
    scene
        The scene to run.
    outdir
        The output directory (it must exist).
    reclaimable
        Bytes of files in ``outdir`` the run removes before it writes (``--overwrite``).

    Returns
    -------
    DiskNeed
        The estimate.

    Raises
    ------
    OutputError
        The disk's free space is below :attr:`DiskNeed.start`.
    """
    need, disk = disk_need(scene), shutil.disk_usage(outdir)
    free = disk.free + reclaimable
    logger.info(
        "the run may need %s on disk: %s of frames and a checkpoint of up to %s, twice "
        "while the next replaces it", _size(need.total), _size(need.frames),
        _size(need.checkpoint),
    )  # fmt: skip
    if not disk.total:  # a pseudo file system reports no size
        return need
    if free < need.start:
        raise OutputError(
            outdir,
            f"{_size(free)} free on its disk, less than the run writes before its first "
            f"step (a frame and a checkpoint, about {_size(need.start)}); free space or "
            "write elsewhere",
        )
    if need.total > free:
        logger.warning(
            "the run may need %s on disk (%s of frames, a checkpoint of %s twice); %s has %s free",
            _size(need.total), _size(need.frames), _size(need.checkpoint), outdir, _size(free),
        )  # fmt: skip
    return need


def _size(size: int) -> str:
    """``"3.2 MB"``: bytes in kB, MB or GB (powers of 1000), three significant digits."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if size >= scale:
            return f"{size / scale:.3g} {unit}"
    return f"{size} B"
