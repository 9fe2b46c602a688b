"""Text in pictures in any script: installed fonts as fallbacks, no glyph warnings.

matplotlib draws text in DejaVu Sans, which has Latin, Greek and Cyrillic but
no CJK, Arabic or Indic glyphs: a block or scene named 斜面 came out as empty
boxes, with one warning per character on stderr (even under ``dda run -q``).
:func:`unicode_text` draws with DejaVu Sans first and then every installed font
of :data:`FALLBACK` (matplotlib takes each glyph from the first font that has
it), and turns the warnings of characters that no installed font has into one
log line (INFO) that names them and says what to install.
"""

from __future__ import annotations

import contextlib
import logging
import re
import warnings
from collections.abc import Iterator

logger = logging.getLogger(__name__)

FALLBACK = (
    "DejaVu Sans", "Noto Sans", "Noto Sans CJK JP", "Noto Sans CJK SC", "Noto Sans CJK TC",
    "Noto Sans CJK KR", "Source Han Sans", "WenQuanYi Zen Hei", "WenQuanYi Micro Hei",
    "Droid Sans Fallback", "IPAGothic", "Noto Sans Arabic", "Noto Sans Hebrew",
    "Noto Sans Devanagari", "Noto Sans Thai", "Arial Unicode MS", "Microsoft YaHei",
    "MS Gothic", "Malgun Gothic", "Segoe UI", "Arial",
)  # fmt: skip
_GLYPH = re.compile(r"Glyph \d+ \((.*)\) missing from font")


def installed_fallbacks() -> list[str]:
    """The families of :data:`FALLBACK` that are installed, DejaVu Sans first."""
    from matplotlib import font_manager

    installed = {font.name for font in font_manager.fontManager.ttflist}
    return [name for name in FALLBACK if name in installed] or ["DejaVu Sans"]


@contextlib.contextmanager
def unicode_text() -> Iterator[None]:
    """Draw and save pictures inside this: fallback fonts, missing glyphs logged once."""
    import matplotlib

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with matplotlib.rc_context({"font.family": installed_fallbacks()}):
            yield
    missing = []
    for warning in caught:
        match = _GLYPH.search(str(warning.message))
        if match is None:  # not ours to hide
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
        elif match.group(1) not in missing:
            missing.append(match.group(1))
    if missing:
        logger.info(
            "no installed font draws %s (shown as boxes); install a font that has them, "
            "e.g. Noto Sans CJK",
            ", ".join(missing[:10]) + (" ..." if len(missing) > 10 else ""),
        )
