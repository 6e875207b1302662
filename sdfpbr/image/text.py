"""Text for images: the font every chart, sheet and heat map is set in, and what it can draw.

DejaVu Sans (Debian's fonts-dejavu-core, which .ci/run installs) draws α and ²; Pillow's
embedded scalable font is the fallback when it is absent. That font covers little beyond
ASCII, so characters it cannot draw are replaced by ASCII spellings ("α" -> "alpha",
"²" -> "^2", "é" -> "e")."""
from __future__ import annotations

import functools
import unicodedata
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # imported by load_font: a chart whose labels come from the disk cache sets no text
    from PIL import ImageFont

SYSTEM_FONTS = ("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "DejaVuSans.ttf")
ASCII_FALLBACK = {"²": "^2", "³": "^3", "–": "-", "—": "-", "−": "-", "×": "x",
                  "→": "->", "≈": "~", "µ": "u", "…": "..."}


@functools.lru_cache(maxsize=64)
def load_font(size: int) -> ImageFont.FreeTypeFont:
    """The font at ``size`` px, loaded once per size (fonts are only read)."""
    from PIL import ImageFont
    for name in SYSTEM_FONTS:
        try:
            return ImageFont.truetype(name, int(size))
        except OSError:
            continue
    return ImageFont.load_default(size=int(size))


# drawable_text's answers by (font, text): a gallery build asks ~40 000 times (a glyph
# rendered per character each time: 1.2 s), about 2 000 distinct; and whether a font draws a
# character, by (font, character): the distinct texts (captions) share their characters.
_drawable: dict[tuple, str] = {}
_glyphs: dict[tuple, bool] = {}


def _font_key(font: ImageFont.FreeTypeFont) -> tuple:
    path = getattr(font, "path", None)
    return path if isinstance(path, str) else id(font), getattr(font, "size", 0)


def drawable_text(text: str, font: ImageFont.FreeTypeFont) -> str:
    """``text`` with the characters ``font`` has no glyph for replaced by ASCII spellings."""
    key = (*_font_key(font), text)
    if key not in _drawable:
        if len(_drawable) >= 8192:
            _drawable.clear()
        _drawable[key] = _drawable_now(text, font)
    return _drawable[key]


def _drawable_now(text: str, font: ImageFont.FreeTypeFont) -> str:
    font_key = _font_key(font)
    missing_key = []   # the font's "no glyph" mask, made on the first character not yet known

    def has_glyph(ch: str) -> bool:
        if ch.isspace():
            return True
        key = (*font_key, ch)
        if key not in _glyphs:
            if not missing_key:
                missing = font.getmask("\U0010fffd")
                missing_key.append((missing.size, bytes(missing)))
            if len(_glyphs) >= 65536:
                _glyphs.clear()
            mask = font.getmask(ch)
            _glyphs[key] = (mask.size, bytes(mask)) != missing_key[0]
        return _glyphs[key]

    def fallback(ch: str) -> str:
        if ch in ASCII_FALLBACK:
            return ASCII_FALLBACK[ch]
        name = unicodedata.name(ch, "")
        if name.startswith("GREEK") and " LETTER " in name:
            word = name.split()[-1].lower()
            return word.capitalize() if "CAPITAL" in name else word
        base = "".join(c for c in unicodedata.normalize("NFKD", ch) if not unicodedata.combining(c))
        return base if base and base != ch and all(has_glyph(c) for c in base) else "?"

    return "".join(ch if has_glyph(ch) else fallback(ch) for ch in text)


def wrap_text(text: str, font: ImageFont.FreeTypeFont, width: float) -> list[str]:
    """Greedy word wrap to ``width`` pixels (drawable text); explicit newlines start new
    paragraphs."""
    lines: list[str] = []
    for paragraph in drawable_text(text, font).split("\n"):
        line = ""
        for word in paragraph.split():
            trial = f"{line} {word}" if line else word
            if not line or font.getlength(trial) <= width:
                line = trial
            else:
                lines.append(line)
                line = word
        lines.append(line)
    return lines
