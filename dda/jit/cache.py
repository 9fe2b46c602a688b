"""numba's on-disk cache of the kernels, keyed by every source a kernel's machine code holds.

numba keys a cached kernel on its own source file only. A kernel's machine code also
holds what it calls and reads: other kernels (compiled into it), and module-level
constants of the modules its module imports (frozen at compile time). So here a
kernel's cache entry is keyed by the content (SHA-256) of its own module **and of
every module of the** ``dda`` **package that module imports at module level,
directly or through others** (:func:`kernel_sources`). Changing any of those files,
caller or callee, makes numba compile the kernel afresh at its next call (and
overwrite its entry); reverting the change compiles it once more, to the same
machine code. A file that no kernel's module imports never invalidates a kernel.

The entries stay where numba puts them (``__pycache__`` beside the module,
``NUMBA_CACHE_DIR``, or the user's cache folder for a read-only install);
:func:`clear` removes them (``dda kernels --clear``).
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

PACKAGE_ROOT = Path(__file__).resolve().parent.parent  # dda/
PACKAGE = PACKAGE_ROOT.name

# a module-level import of a dda module: `from dda.x import a, b` or `import dda.x`
# (indented imports run inside functions or TYPE_CHECKING blocks: kernels never see them)
_IMPORT = re.compile(
    rf"^(?:from\s+({PACKAGE}(?:\.\w+)*)\s+import\s+(\([^)]*\)|[^\n]*)|import\s+({PACKAGE}(?:\.\w+)*))",
    re.M,
)


def module_file(module: str) -> Path | None:
    """The source file of the ``dda`` module ``module`` (dotted), or None."""
    base = PACKAGE_ROOT.parent.joinpath(*module.split("."))
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return candidate
    return None


@functools.cache
def _imported_files(path: Path, mtime_ns: int, size: int) -> tuple[Path, ...]:
    """The dda files that ``path`` imports at module level (submodules named after
    ``from package import`` included)."""
    found: set[Path] = set()
    for match in _IMPORT.finditer(path.read_text(encoding="utf-8")):
        module = match.group(1) or match.group(3)
        home = module_file(module)
        if home is not None:
            found.add(home)
        if match.group(1):
            names = re.sub(r"#[^\n]*", "", match.group(2))
            for name in re.findall(r"\w+", names):
                sub = module_file(f"{module}.{name}")
                if sub is not None:
                    found.add(sub)
    return tuple(sorted(found))


def _stat_key(path: Path) -> tuple[Path, int, int]:
    status = path.stat()
    return path, status.st_mtime_ns, status.st_size


def kernel_sources(function: Callable) -> tuple[Path, ...]:
    """Every file whose change must recompile ``function``'s kernel: its module and the
    dda modules that module imports at module level, transitively (sorted)."""
    start = Path(function.__code__.co_filename).resolve()
    seen = {start}
    pending = [start]
    while pending:
        for imported in _imported_files(*_stat_key(pending.pop())):
            if imported not in seen:
                seen.add(imported)
                pending.append(imported)
    return tuple(sorted(seen))


@functools.cache
def _file_digest(path: Path, mtime_ns: int, size: int) -> bytes:
    return hashlib.sha256(path.read_bytes()).digest()


def sources_stamp(function: Callable) -> str:
    """SHA-256 over the contents of :func:`kernel_sources` (paths relative to the
    package, so a copied or moved package keeps its stamps)."""
    digest = hashlib.sha256()
    for path in kernel_sources(function):
        digest.update(str(path.relative_to(PACKAGE_ROOT)).encode())
        digest.update(_file_digest(*_stat_key(path)))
    return digest.hexdigest()


def cached_dispatcher(function: Callable, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)(function)`` whose cache entry is stamped
    with :func:`sources_stamp` rather than the function's own file alone."""
    import numba

    dispatcher = numba.njit(**options)(function)
    dispatcher._cache = _sources_cache_class()(function)
    return dispatcher


@functools.cache
def _sources_cache_class() -> type:
    """numba's function cache with a locator that stamps by :func:`sources_stamp`
    (made once numba is imported: numba is imported lazily)."""
    from numba.core.caching import CompileResultCacheImpl, FunctionCache

    class SourcesLocator:
        """numba's own locator for the function (same folder, same file names), its
        source stamp widened to every source of the kernel."""

        def __init__(self, inner: Any, function: Callable) -> None:
            self._inner, self._function = inner, function

        def ensure_cache_path(self) -> None:
            self._inner.ensure_cache_path()

        def get_cache_path(self) -> str:
            return self._inner.get_cache_path()

        def get_disambiguator(self) -> str:
            return self._inner.get_disambiguator()

        def get_source_stamp(self) -> tuple[Any, str]:
            return self._inner.get_source_stamp(), sources_stamp(self._function)

    class SourcesCacheImpl(CompileResultCacheImpl):
        def __init__(self, py_func: Callable) -> None:
            super().__init__(py_func)
            self._locator = SourcesLocator(self._locator, py_func)

    class SourcesCache(FunctionCache):
        _impl_class = SourcesCacheImpl

    return SourcesCache


def cache_folders() -> Iterator[Path]:
    """Every folder where numba may keep the package's kernels: each package folder's
    ``__pycache__``, and its folders under ``NUMBA_CACHE_DIR`` and the user's cache."""
    from numba.core import config
    from numba.core.caching import _CacheLocator
    from numba.misc.appdirs import AppDirs

    roots = [Path(AppDirs(appname="numba", appauthor=False).user_cache_dir)]
    if config.CACHE_DIR:
        roots.append(Path(config.CACHE_DIR))
    for folder in sorted({p.parent for p in PACKAGE_ROOT.rglob("*.py")}):
        yield folder / "__pycache__"
        subpath = _CacheLocator.get_suitable_cache_subpath(str(folder / "x.py"))
        for root in roots:
            yield root / subpath


def cache_home() -> str:
    """Where numba keeps the package's kernel files, in a few words (numba's order):
    under ``NUMBA_CACHE_DIR`` when it is set; else in ``__pycache__`` beside each module
    when the package folder is writable; else under the user's cache folder."""
    from numba.core import config
    from numba.misc.appdirs import AppDirs

    if config.CACHE_DIR:
        return f"under {config.CACHE_DIR} (NUMBA_CACHE_DIR)"
    pycache = PACKAGE_ROOT / "__pycache__"
    if os.access(pycache if pycache.is_dir() else PACKAGE_ROOT, os.W_OK):
        return f"in __pycache__ beside the modules under {PACKAGE_ROOT}"
    user = AppDirs(appname="numba", appauthor=False).user_cache_dir
    return f"under {user} (the user's cache: {PACKAGE_ROOT} is read-only)"


def cache_files() -> list[Path]:
    """The package's kernel cache files (numba's ``.nbi`` indexes and ``.nbc`` code)."""
    found = []
    for folder in cache_folders():
        if folder.is_dir():
            found += [p for p in folder.iterdir() if p.suffix in (".nbi", ".nbc")]
    return sorted(found)


def clear() -> tuple[int, int]:
    """Remove the package's kernel cache files; returns (files, bytes) removed. The
    next run that uses a kernel compiles it again."""
    files = size = 0
    for path in cache_files():
        try:
            length = path.stat().st_size
            os.remove(path)
        except FileNotFoundError:
            continue
        files, size = files + 1, size + length
    return files, size
