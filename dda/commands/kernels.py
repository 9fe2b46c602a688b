"""``dda kernels``: where numba keeps the compiled kernels, and ``--clear`` to remove them."""

from __future__ import annotations

import argparse
from typing import Any

from dda.io.wording import counted


def register(subparsers: Any) -> None:
    """Add ``dda kernels`` to the ``dda`` command's sub-commands."""
    parser = subparsers.add_parser(
        "kernels",
        help="the compiled kernels' cache: where it is, --clear to remove it",
        description="Say where numba keeps this installation's compiled kernels and how "
        "much they take. A kernel is compiled again by itself whenever its module or a "
        "module it imports changes (docs/design.md); --clear removes them all, and the "
        "next run that uses a kernel compiles it (up to a minute or two).",
    )
    parser.add_argument(
        "--clear", action="store_true", help="remove the cached kernels of this installation"
    )
    parser.set_defaults(func=run_command)


def run_command(args: argparse.Namespace) -> int:
    """Print the cache's folders and size (where numba keeps kernels, when there are
    none yet), or clear it; 0 on success."""
    from dda import jit

    if not jit.numba_enabled():
        print("numba is not in use (not installed, or DDA_NO_NUMBA=1): no kernels are cached")
        return 0
    from dda.jit import cache

    if args.clear:
        files, size = cache.clear()
        print(f"removed {counted(files, 'cached kernel file')} ({size / 2**20:.1f} MiB)")
        return 0
    files = cache.cache_files()
    if not files:
        print(f"0 cached kernel files: numba keeps them {cache.cache_home()}")
        return 0
    folders = sorted({str(path.parent) for path in files})
    size = sum(path.stat().st_size for path in files)
    print(f"{counted(len(files), 'cached kernel file')} ({size / 2**20:.1f} MiB) in "
          f"{counted(len(folders), 'folder')}")  # fmt: skip
    for folder in folders:
        print(f"  {folder}")
    return 0
