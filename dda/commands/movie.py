"""The ``dda movie OUTDIR`` command: an animation of a run's written frames.

Registered as an entry point of ``dda.commands`` (pyproject.toml); the drawing
is :mod:`dda.io.movie`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dda.commands.cli import (
    add_range_option,
    checked_range,
    output_path,
    picture_side,
    positive_float,
    positive_int,
)
from dda.io.fields import SCALARS

EXIT_OK, EXIT_FAILURE, EXIT_INPUT = 0, 1, 2


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``movie`` sub-command to the ``dda`` command line."""
    parser = subparsers.add_parser(
        "movie",
        help="animate a run's frames (MP4, or GIF)",
        description="Draw every frame written by `dda run` into OUTDIR into one movie, "
        "with one view and one colour range for all frames (--range, else the values the "
        "frames hold for two frames or more: a one-frame spike is left out): MP4 when "
        "imageio-ffmpeg is "
        "installed (pip install 'dda-rock[movie]'), else GIF; -o NAME.gif or NAME.mp4 "
        "chooses.",
    )
    parser.add_argument("outdir", type=Path, help="output directory of dda run")
    parser.add_argument(
        "-o",
        "--output",
        type=output_path,
        help="movie file, .mp4 or .gif (default: OUTDIR/movie.*)",
    )
    parser.add_argument("--scalars", choices=sorted(SCALARS), default="syy", help="block colour")
    add_range_option(parser)
    parser.add_argument(
        "--fps", type=positive_float, default=10.0, help="frames a second (default 10)"
    )
    parser.add_argument(
        "--every", type=positive_int, default=1, metavar="N",
        help="draw every N-th written frame (default: all)",
    )  # fmt: skip
    parser.add_argument(
        "--size", type=picture_side, nargs=2, default=(960, 720), metavar=("W", "H"),
        help="picture size in pixels, even numbers (default: 960 720)",
    )  # fmt: skip
    parser.add_argument("--no-contacts", action="store_true", help="do not draw contact forces")
    parser.set_defaults(func=movie_command)
    return parser


def movie_command(args: argparse.Namespace) -> int:
    """``dda movie``: 0 with the movie written, 2 on bad input (nothing written), 1 when
    ffmpeg fails (one line with its last message; nothing written)."""
    from dda.io.frame_files import all_frames, read_found_frame
    from dda.io.movie import FfmpegError, MovieError, movie_format, shared_look, write_movie
    from dda.io.output_paths import OutputError, check_output_file
    from dda.run.progress import ProgressBar

    try:
        found = all_frames(args.outdir)[:: args.every]
        output = args.output or args.outdir / f"movie{movie_format(None)}"
        movie_format(output)
        if args.size[0] % 2 or args.size[1] % 2:
            raise MovieError(f"--size {args.size[0]} {args.size[1]}: give even numbers")
        check_output_file(output)
        clim = checked_range(args)
        frames = [read_found_frame(f) for f in found]
        look = shared_look(frames, args.scalars, clim)
    except (FileNotFoundError, ValueError, OutputError) as exc:
        print(f"dda movie: {exc}", file=sys.stderr)
        return EXIT_INPUT
    run = found[0].summary()
    try:
        with ProgressBar(total=len(frames), label=f"writing {output.name}") as bar:
            count = write_movie(
                frames, output, look, scalars=args.scalars, fps=args.fps,
                size=tuple(args.size), show_contacts=not args.no_contacts,
                scene_title=run.get("title") or "", units=found[0].units(run),
                on_frame=lambda k: bar.update(k, frame=k), water_table=run.get("water_table"),
                water_follows=run.get("water_follows") or (),
            )  # fmt: skip
    except FfmpegError as exc:  # not the input's fault: exit 1, in one line
        print(f"dda movie: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    frames_said = f"{count} frame" + ("" if count == 1 else "s")
    print(f"{output} ({frames_said}, {args.size[0]} x {args.size[1]}, {args.fps:g} fps)")
    return EXIT_OK
