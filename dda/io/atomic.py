"""Atomic file writes: a reader never sees a half-written file.

Everything goes to a temporary file in the destination's directory first and
is then moved over the destination with :func:`os.replace`, which is atomic
on POSIX and Windows when both names are on the same file system. A run that
is interrupted leaves either the previous complete file or the new complete
file, plus at worst a stray ``*.tmp-*`` file, never a truncated one.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
from collections.abc import Iterator
from pathlib import Path

TEMP_MARK = ".tmp-"


def temp_path_for(path: str | os.PathLike[str]) -> Path:
    """A fresh temporary name beside ``path`` that keeps its extension.

    ``frames/blocks_000010.vtu`` gives ``frames/blocks_000010.tmp-3f9a1c2e.vtu``:
    writers that choose the format from the extension (meshio, VTK's PNG
    writer) still recognise it.

    Parameters
    ----------
    path
        The destination file.

    Returns
    -------
    Path
        A name in the same directory that does not exist yet.
    """
    path = Path(path)
    while True:
        candidate = path.with_name(f"{path.stem}{TEMP_MARK}{secrets.token_hex(4)}{path.suffix}")
        if not candidate.exists():
            return candidate


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Give a writer a temporary path; move it over ``path`` if the block succeeds.

    Parameters
    ----------
    path
        The destination file. Its directory must exist.

    Yields
    ------
    Path
        The temporary path to write to. If the ``with`` block raises, or
        writes nothing, the temporary file is removed and ``path`` is left as
        it was; an OSError of the block (with an error number) is raised again
        naming ``path`` (what the user asked for, not the temporary name, nor no
        name: writers that fill the disk often give none).

    Examples
    --------
    >>> with atomic_path("mesh.vtu") as tmp:  # doctest: +SKIP
    ...     meshio.write(tmp, mesh)
    """
    path = Path(path)
    tmp = temp_path_for(path)
    try:
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(f"the writer produced no file for {path}")
        os.replace(tmp, path)
    except OSError as exc:  # the error names the file asked for, never the temporary one,
        if exc.errno is not None:  # and one that names none (a full disk in a writer) too
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically.

    Parameters
    ----------
    path
        The destination file. Its directory must exist.
    data
        The whole content.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    with atomic_path(path) as tmp:  # a full disk names the file
        with open(tmp, "xb") as stream:
            stream.write(data)
    return path


def write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (``newline`` characters kept as given).

    Parameters
    ----------
    path
        The destination file. Its directory must exist.
    text
        The whole content.
    encoding
        Text encoding.

    Returns
    -------
    Path
        ``path``.
    """
    return write_bytes(path, text.encode(encoding))


def write_fully(fd: int, data: bytes, offset: int | None = None) -> None:
    """Write all of ``data`` to ``fd`` (appended, or at ``offset``), or raise OSError.

    ``os.write`` and ``os.pwrite`` may write part of the data when the disk fills
    (they return the count written); this retries the rest, so a full disk raises
    ``OSError(ENOSPC)`` instead of losing the tail of the data silently.
    """
    view = memoryview(data)
    while view:
        done = os.write(fd, view) if offset is None else os.pwrite(fd, view, offset)
        if done <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        view = view[done:]
        if offset is not None:
            offset += done


@contextlib.contextmanager
def naming(path: str | os.PathLike[str]) -> Iterator[None]:
    """Re-raise an OSError of the block with ``path`` as its file name when it has none
    (so "No space left on device" says which file)."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None and exc.errno is not None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise


def append_whole(fd: int, text: str, path: str | os.PathLike[str]) -> None:
    """Append ``text`` to the open file ``fd`` whole, or not at all (a full disk: the
    file is cut back to its size before and the OSError names ``path``)."""
    size = os.fstat(fd).st_size
    with naming(path):
        try:
            write_fully(fd, text.encode("utf-8"))
        except OSError:
            os.ftruncate(fd, size)
            raise
