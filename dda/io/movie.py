"""Animations of a run: its frames drawn one after the other into MP4 or GIF.

Every picture of a movie has the same view (the extent of the blocks over all its
frames), the same colour range and the same contact-force scale (over all its
frames), so that motion and the growth of a stress or a force show as they
happened; each is titled with its time and step. The colour range spans the values
the frames hold for two frames or more (:func:`steady_extremes`): a one-frame spike
of an impact does not grey out the rest of the movie; it is drawn in the end colour,
and the bar's arrow says that values lie beyond. MP4 (H.264, ``yuv420p``: what
browsers and players open) is written through imageio-ffmpeg, which carries its
own ffmpeg (the optional ``movie`` extra); GIF through Pillow, which matplotlib
already brings. :func:`movie_format` picks MP4 when imageio-ffmpeg is installed
and the name does not ask for GIF.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from dda.io.atomic import atomic_path
from dda.io.colour_scale import ColourScale, colour_scale
from dda.io.fields import SCALARS, scalar_field
from dda.io.images import compose, extent, largest_force, picture_pixels
from dda.result import Frame

FORMATS = (".mp4", ".gif")


class MovieError(ValueError):
    """A movie that cannot be written as asked (format, size, no frames)."""


class FfmpegError(RuntimeError):
    """ffmpeg failed while writing a movie: one line, the file and ffmpeg's last word."""


def mp4_available() -> bool:
    """True when imageio-ffmpeg (and so an ffmpeg) is installed."""
    return importlib.util.find_spec("imageio_ffmpeg") is not None


def movie_format(path: str | os.PathLike[str] | None) -> str:
    """``".mp4"`` or ``".gif"``: the suffix of ``path``, or (no path) MP4 when it can be
    written, else GIF.

    Raises
    ------
    MovieError
        Another suffix, or ``.mp4`` without imageio-ffmpeg.
    """
    if path is None:
        return ".mp4" if mp4_available() else ".gif"
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        given = f", not {suffix}" if suffix else ""
        raise MovieError(f"{path}: a movie is .mp4 or .gif{given}; give a file name ending in one")
    if suffix == ".mp4" and not mp4_available():
        raise MovieError(
            f"{path}: MP4 needs imageio-ffmpeg (pip install 'dda-rock[movie]'); or name a .gif"
        )
    return suffix


@dataclass(frozen=True)
class MovieLook:
    """What every picture of a movie shares: colour scale, view
    (``[[x_min, y_min], [x_max, y_max]]``) and the contact force drawn longest."""

    scale: ColourScale
    view: np.ndarray
    force_max: float

    @property
    def clim(self) -> tuple[float, float]:
        """The colour range ``(low, high)``."""
        return self.scale.clim


def shared_look(
    frames: Sequence[Frame], scalars: str, clim: tuple[float, float] | None = None
) -> MovieLook:
    """The :class:`MovieLook` of ``frames``: the colour scale of ``scalars`` on the free
    blocks (``clim`` if given, else the range of :func:`steady_extremes`, as
    :func:`dda.io.colour_scale.colour_scale` makes it), the blocks' extent and the largest
    contact force, each over all frames."""
    info = SCALARS[scalars]
    fields = [_free_field(f, scalars) for f in frames]
    everything = np.concatenate(fields) if fields else np.zeros(0)
    scale = colour_scale(steady_extremes(fields), info.signed) if clim is None else None
    if scale is None or scale.constant is None:  # a range: values beyond it are announced
        scale = colour_scale(everything, info.signed, clim or scale.clim)
    force_max = max((largest_force(f) for f in frames), default=0.0)
    return MovieLook(scale, extent(frames), force_max)


def steady_extremes(fields: Sequence[np.ndarray]) -> np.ndarray:
    """Each frame's lowest and highest value after a running median over three consecutive
    frames (the first and last frame repeated at the ends): a value reached in a single
    frame (an impact's spike) is left out, one held for two frames or more, or reached in
    the first or the last frame, is kept. Frames without a value are skipped."""
    kept = [v[np.isfinite(v)] for v in fields]
    kept = [v for v in kept if v.size]
    if not kept:
        return np.zeros(0)
    low = np.array([v.min() for v in kept])
    high = np.array([v.max() for v in kept])
    return np.concatenate([_running_median(low), _running_median(high)])


def _running_median(series: np.ndarray) -> np.ndarray:
    """The median of each value and its two neighbours (the ends repeated)."""
    padded = np.concatenate([series[:1], series, series[-1:]])
    return np.median(np.stack([padded[:-2], padded[1:-1], padded[2:]]), axis=0)


def _free_field(frame: Frame, scalars: str) -> np.ndarray:
    """``scalars`` of the frame's free blocks (NaN for fixed ones)."""
    return np.where(frame.fixed, np.nan, scalar_field(frame, scalars))


def write_movie(
    frames: Iterable[Frame],
    path: str | os.PathLike[str],
    look: MovieLook,
    scalars: str = "syy",
    fps: float = 10.0,
    size: tuple[int, int] = (960, 720),
    show_contacts: bool = True,
    scene_title: str = "",
    units: Mapping[str, str] | None = None,
    on_frame: Callable[[int], None] | None = None,
    water_table: Sequence[Sequence[float]] | None = None,
    water_follows: Sequence[str] = (),
) -> int:
    """Draw ``frames`` into the movie ``path`` (.mp4 or .gif, written atomically), each
    with ``look``; returns the number of frames. ``on_frame(k)`` is called after the
    k-th (from 1). ``water_table``: the scene's phreatic line (drawn on every frame, moved
    with the blocks ``water_follows``: :func:`dda.io.images.render_frame`)."""
    suffix = movie_format(path)
    if size[0] % 2 or size[1] % 2:
        raise MovieError(f"movie size {size[0]} x {size[1]}: width and height must be even")

    def pictures():
        for k, frame in enumerate(frames, start=1):
            figure = compose(
                [frame], [None], scalars, show_contacts, size, look.scale, scene_title, units,
                look.view, look.force_max, water_table, water_follows,
            )  # fmt: skip
            yield picture_pixels(figure)
            if on_frame is not None:
                on_frame(k)

    with atomic_path(Path(path)) as tmp:
        if suffix == ".mp4":
            count = _write_mp4(pictures(), tmp, fps, size, Path(path))
        else:
            count = _write_gif(pictures(), tmp, fps, size)
    if count == 0:
        raise MovieError("no frame to draw")
    return count


def _write_gif(pictures: Iterable[np.ndarray], path: Path, fps: float, size) -> int:
    """GIF through Pillow: each picture reduced to its own 256-colour palette."""
    from PIL import Image

    images = [Image.fromarray(p).quantize(colors=256) for p in pictures]
    if images:
        images[0].save(
            path, format="GIF", save_all=True, append_images=images[1:],
            duration=max(20, round(1000.0 / fps)), loop=0,
        )  # fmt: skip
    return len(images)


def _write_mp4(pictures: Iterable[np.ndarray], path: Path, fps: float, size, name: Path) -> int:
    """MP4 (H.264, yuv420p) through imageio-ffmpeg, one picture at a time. ffmpeg's own
    messages go to a temporary file, not the terminal: when it fails, an
    :class:`FfmpegError` says so in one line that names ``name`` (the file asked for)
    and ends with ffmpeg's last message. ffmpeg logs at its "error" level only, and
    imageio-ffmpeg's ``close`` does not look at how ffmpeg ended (a full disk leaves a
    movie without its index and exits 0 there), so anything ffmpeg said is its failure."""
    import imageio_ffmpeg

    with tempfile.TemporaryFile() as said:
        writer = imageio_ffmpeg.write_frames(
            str(path), size, fps=fps, codec="libx264", pix_fmt_out="yuv420p",
            output_params=["-f", "mp4"], macro_block_size=2, ffmpeg_log_level="error",
        )  # fmt: skip
        count = 0
        try:
            with _child_stderr(said):  # ffmpeg starts here, its stderr the file
                writer.send(None)
            for picture in pictures:
                writer.send(np.ascontiguousarray(picture))
                count += 1
            writer.close()
            if _said_anything(said):
                raise RuntimeError("ffmpeg reported an error")
        except (OSError, RuntimeError) as exc:
            with contextlib.suppress(OSError, RuntimeError):
                writer.close()
            said_last = _last_words(said, exc)
            raise FfmpegError(f"{name}: ffmpeg could not write the movie ({said_last})") from None
    return count


def _said_anything(log: IO[bytes]) -> bool:
    """True when ffmpeg wrote a line that is not blank to ``log``."""
    log.seek(0)
    return bool(log.read().strip())


@contextlib.contextmanager
def _child_stderr(log: IO[bytes]) -> Iterator[None]:
    """Processes started within the block inherit ``log`` as their standard error (the
    descriptor 2 of this process is swapped for the block and restored after it)."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        os.dup2(log.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _last_words(log: IO[bytes], exc: BaseException) -> str:
    """The last line ffmpeg wrote to ``log``, else the error's first line."""
    log.seek(0)
    lines = [line.strip() for line in log.read().decode("utf-8", "replace").splitlines()]
    lines = [line for line in lines if line]
    if lines:
        return lines[-1]
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]
