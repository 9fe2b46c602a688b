"""``dda cut SCENE -o blocks.toml``: write the explicit block scene and a picture.

A cut estimated at :data:`dda.run.cut_bar.LONG_CUT` blocks or more shows a progress bar
on stderr (none with ``-q``) over the command's stages, each given its share of the
time of two crossing sets cut into 13,279 blocks (docs/benchmarks.md): cutting 39 %,
checking the blocks 20 %, the TOML 12 %, the picture 29 %.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from dda.commands.cli import check_png, default_outdir, output_path, positive_int
from dda.errors import SceneError
from dda.io.atomic import atomic_path, write_text
from dda.io.output_paths import OutputError, check_output_file
from dda.run.cut_bar import CutBar

if TYPE_CHECKING:
    from dda.scene.rockmass.progress import Progress

log = logging.getLogger(__name__)

#: stage -> share of ``dda cut``'s time, in the order it runs them
STAGES = {"cutting": 0.39, "checking": 0.20, "toml": 0.12, "picture": 0.29}


def register(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``cut`` sub-command to the ``dda`` command line."""
    parser = subparsers.add_parser(
        "cut",
        help="cut a rock mass (regions + joint sets) into explicit blocks",
        description="Cut the rock mass of SCENE by its joints and write the scene "
        "with explicit [[blocks]] (TOML) and a picture of the blocks (PNG).",
    )
    parser.add_argument(
        "scene",
        help="scene file (TOML) with [[regions]] and joints or a [drawing], a shipped case's "
        "name, or a DXF drawing (its materials and joints from --scene, else from the TOML "
        "file of the same name beside it)",
    )
    parser.add_argument(
        "--scene", dest="props", type=Path, metavar="TOML",
        help="for a DXF drawing: the scene file of its materials, joints, analysis and "
        "[drawing] layers (default: DRAWING.toml beside DRAWING.dxf)",
    )  # fmt: skip
    parser.add_argument(
        "-o",
        "--output",
        type=_output_text,
        help="TOML file to write, or a folder (an existing one, or a name ending in /) to "
        "write <scene>.toml in (default: out/cut_<scene>/<scene>.toml)",
    )
    parser.add_argument(
        "--png", type=output_path, default=None, help="picture to write (default: OUTPUT.png)"
    )
    parser.add_argument("--no-png", action="store_true", help="do not draw a picture")
    parser.add_argument(
        "--overwrite", action="store_true",
        help="replace OUTPUT and the picture if they exist (the scene TOML may hold edits: "
        "without this option an existing file is refused)",
    )  # fmt: skip
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no summary")
    parser.add_argument(
        "--max-blocks", type=positive_int, metavar="N",
        help="cut even if the estimate exceeds N blocks (overrides cutting.max_blocks)",
    )  # fmt: skip
    parser.set_defaults(func=run_cut)
    return parser


def run_cut(args: argparse.Namespace) -> int:
    """Run ``dda cut``: 0 on success, 2 on a bad scene or output path (nothing written)."""
    from tomli_w import dumps

    from dda.commands.cli import scene_source

    try:
        args.scene = str(scene_source(Path(args.scene)))  # a file, or a shipped case's name
        props, drawing = _scene_and_drawing(Path(args.scene), args.props)
    except SceneError as exc:
        sys.stderr.write(f"dda cut: {exc}\n")
        return 2
    stem = Path(args.scene).stem
    output = _output_file(args.output, default_outdir("cut", args.scene), f"{stem}.toml")
    png = None if args.no_png else Path(args.png) if args.png else output.with_suffix(".png")
    if args.png is not None and not args.no_png:
        try:
            check_png(args.png, "--png")
        except ValueError as exc:  # before any work (was matplotlib's, after the cut)
            sys.stderr.write(f"dda cut: {exc}\n")
            return 2
    stages = _stage_ends(picture=png is not None)
    with CutBar(Path(args.scene).name, share=stages["cutting"], quiet=args.quiet) as bar:
        try:
            for path, option in ((output, "-o"), (png, "--png")):
                if path is not None:
                    _check_output(path, option, Path(args.scene), args.overwrite)
            cut, scene = _cut(props, args.max_blocks, bar, drawing)
            scene = _without_set_draws(scene, args.scene)
            _check_loadable(_files_from(scene, props, None), str(props))
        except (SceneError, OutputError) as exc:
            bar.close()
            log.debug("refused: %s", exc)
            sys.stderr.write(f"dda cut: {exc}\n")
            return 2
        bar.update(stages["checking"], "toml")
        origin = args.scene if drawing is None else f"{args.scene} with {props}"
        blocks = scene.get("blocks", [])  # the cut ones and those the scene draws itself
        fixed = sum(bool(block.get("fixed", False)) for block in blocks)
        header = f"# Blocks cut from {origin} by `dda cut`: {len(blocks)} blocks.\n"
        text = header + dumps(_files_from(scene, props, output.parent))
        if png is not None:  # the picture first: a drawing that fails leaves no scene behind
            from dda.io.fonts import unicode_text
            from dda.scene.rockmass.picture import draw_cut

            bar.update(stages["toml"], "picture")
            png.parent.mkdir(parents=True, exist_ok=True)
            title = str(scene.get("title", "")) or Path(args.scene).stem
            cut_names = set(cut.names)
            drawn = [block for block in blocks if block.get("name") not in cut_names]
            units = scene.get("units", {})
            with atomic_path(png) as tmp, unicode_text():
                draw_cut(
                    cut, tmp, title=title, removed=removed_by_stages(scene), drawn=drawn,
                    length_unit=str(units.get("length", "m")),
                )  # fmt: skip
            log.info("wrote %s", png)
        output.parent.mkdir(parents=True, exist_ok=True)
        write_text(output, text)
        log.info("wrote %s", output)
        bar.finish()
    if not args.quiet:
        sys.stdout.write(f"{output}: {len(blocks)} blocks, {fixed} fixed\n")
    return 0


def _output_text(text: str) -> str:
    """argparse type of ``-o``: the name as given (a trailing / says it is a folder)."""
    output_path(text)  # not empty
    return text


def _output_file(given: str | None, default_folder: Path, name: str) -> Path:
    """The scene file ``-o`` names: ``given``, or ``name`` in it where it is a folder (an
    existing one, or a name ending in a separator), or ``name`` in ``default_folder``."""
    if given is None:
        return default_folder / name
    if given.endswith(("/", os.sep)) or Path(given).is_dir():
        return Path(given) / name
    return Path(given)


def _stage_ends(picture: bool) -> dict[str, float]:
    """Stage -> the fraction of ``dda cut`` done at its end (:data:`STAGES`)."""
    shares = {k: v for k, v in STAGES.items() if picture or k != "picture"}
    total, ends, done = sum(shares.values()), {}, 0.0
    for stage, share in shares.items():
        done += share / total
        ends[stage] = done
    return ends


def _check_output(path: Path, option: str, scene: Path, overwrite: bool) -> None:
    """Refuse an output path that cannot be written, that is the scene file itself, or
    that exists (unless ``overwrite``: a cut scene is meant to be edited, so a second
    cut must not replace those edits unasked)."""
    try:
        check_output_file(path)
    except OutputError as exc:
        raise OutputError(f"{option} {path}", exc.reason) from None
    if path.exists() and scene.exists() and path.resolve() == scene.resolve():
        raise OutputError(f"{option} {path}", "is the scene file itself; give another name")
    if path.exists() and not overwrite:
        raise OutputError(f"{option} {path}", "exists; give --overwrite to replace it")


def _scene_and_drawing(scene: Path, props: Path | None) -> tuple[Path, Path | None]:
    """(the scene file to read, the DXF drawing given in its place or None). A drawing's
    scene is ``--scene``, else the TOML file of the drawing's name beside it."""
    if scene.suffix.lower() != ".dxf":
        if props is not None:
            raise SceneError(str(props), "--scene", "is for a DXF drawing; give the scene alone")
        return scene, None
    if not scene.is_file():
        raise SceneError(str(scene), "<file>", "no such drawing file")
    props = props or scene.with_suffix(".toml")
    if not props.is_file():
        raise SceneError(
            str(scene), "<file>", f"a drawing needs a scene of its materials and joints: no "
            f"{props}; give --scene FILE.toml (docs/rock_masses.md, Drawings)",
        )  # fmt: skip
    return props, scene


def _cut(
    path: Path, max_blocks: int | None = None, progress: Progress | None = None,
    drawing: Path | None = None,
):  # fmt: skip
    """Cut the scene file ``path`` (its ``[drawing] file`` replaced by ``drawing``)."""
    from dda.scene.format import parse_toml
    from dda.scene.rockmass.expand import cut_rock_mass
    from dda.scene.text_file import check_scene_file, read_scene_text

    check_scene_file(path)
    raw = parse_toml(read_scene_text(path), str(path))
    if max_blocks is not None and isinstance(raw.get("cutting", {}), dict):
        raw["cutting"] = {**raw.get("cutting", {}), "max_blocks": max_blocks}
    if drawing is not None:
        table = raw.get("drawing", {})
        raw["drawing"] = {
            **(table if isinstance(table, dict) else {}),
            "file": str(drawing.absolute()),
        }
    return cut_rock_mass(raw, str(path), progress)


def _without_set_draws(scene: dict, source: str) -> dict:
    """``scene`` without the ``[[ensemble.vary]]`` draws of its joint sets (the cut
    scene's blocks are cut once; ``dda ensemble`` on the rock-mass scene cuts them anew
    in every realisation), said on stderr; without ``[ensemble]`` when no draw is left."""
    ensemble = scene.get("ensemble")
    vary = ensemble.get("vary") if isinstance(ensemble, dict) else None
    if not isinstance(vary, list):
        return scene
    kept = [d for d in vary if not str(d.get("key", "")).startswith("joint_sets[")]
    if len(kept) == len(vary):
        return scene
    for k, draw in enumerate(vary):
        if draw not in kept:
            log.warning(
                "ensemble.vary[%d] (%s) left out of the cut scene: its blocks are cut once; "
                "dda ensemble %s draws the joint sets anew in each realisation",
                k, draw.get("key"), source,
            )  # fmt: skip
    out = dict(scene)
    if kept:
        out["ensemble"] = {**ensemble, "vary": kept}
    else:
        del out["ensemble"]
    return out


def _files_from(scene: dict, source: Path, folder: Path | None) -> dict:
    """``scene`` with the file its ``[seismic]`` reads (relative to the folder of the
    scene file ``source``, as the loader reads it) named from ``folder``, where the
    written scene will be, or absolute (``folder`` None): a scene cut into another
    folder runs there as it is."""
    seismic = scene.get("seismic")
    if not (isinstance(seismic, dict) and isinstance(seismic.get("file"), str)):
        return scene
    record = (source.parent / seismic["file"]).absolute()
    try:
        file = record if folder is None else Path(os.path.relpath(record, folder.absolute()))
    except ValueError:  # another drive (Windows): no relative path
        file = record
    return {**scene, "seismic": {**seismic, "file": file.as_posix()}}


def _check_loadable(scene: dict, source: str) -> None:
    """Validate the explicit scene with the scene loader, re-labelling the source."""
    from dda.scene import load_scene

    try:
        load_scene(scene)
    except SceneError as exc:
        raise SceneError(source, exc.key, exc.reason) from None


def removed_by_stages(scene: dict) -> set[str]:
    """The names of the blocks the explicit ``scene``'s stages remove (by name or group)."""
    groups = scene.get("groups", {})
    names: set[str] = set()
    for stage in scene.get("stages", []):
        for name in stage.get("remove", []) if isinstance(stage, dict) else []:
            members = groups.get(name) if isinstance(groups, dict) else None
            names.update(members if isinstance(members, list) else [name])
    return names
