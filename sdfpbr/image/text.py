"""Text for images: the fonts every chart, sheet and heat map is set in, and what they can draw.

DejaVu Sans (Debian's fonts-dejavu-core, which .ci/run installs) is the main font; Pillow's
embedded scalable font stands in where it is absent. A character the main font has no glyph
for is drawn from the first fallback font that has one (FALLBACK_FONTS: WenQuanYi Micro Hei
for Chinese, Japanese and Korean, Symbola for emoji and symbols, in one colour like the rest
of the text). Text is cut into runs of one font each (text_runs) and measured and drawn run by
run: text_length, text_bbox, draw_text and wrap_text are the one way the charts, sheets and
layouts set text.

What no installed font draws is spelled in ASCII where it has a spelling ("α" -> "alpha",
"²" -> "^2", "é" -> "e": Pillow's own font covers little beyond ASCII); any other character is
refused (SpecError naming it and the Debian package that draws it): a chart never shows "?"
for what its user wrote.

Bidirectional controls (U+202E RIGHT-TO-LEFT OVERRIDE and the rest of Unicode's Bidi_Control)
are dropped, and so are other control characters: Pillow sets text with libraqm where it has
it, which applies the Unicode bidi algorithm, so "\\u202eevil" was drawn as "live". The spec
refuses them in its text fields (spec.checks.text); here they are neutralised in text from
elsewhere (glTF material names, file names in titles and footers)."""
from __future__ import annotations

import functools
import math
import os
import unicodedata
from typing import TYPE_CHECKING

from ..errors import SpecError
from ..spec.checks import BIDI_CONTROLS, describe_char, quote

if TYPE_CHECKING:   # imported by load_font: a chart whose labels come from the disk cache sets no text
    from PIL import ImageDraw, ImageFont

SYSTEM_FONTS = ("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "DejaVuSans.ttf")
# (file, Debian package, font, what it adds), tried in this order for a character the main font lacks.
FALLBACK_FONTS = (
    ("/usr/share/fonts/truetype/wqy/wqy-microhei.ttc", "fonts-wqy-microhei", "WenQuanYi Micro Hei",
     "Chinese, Japanese, Korean"),
    ("/usr/share/fonts/truetype/ancient-scripts/Symbola_hint.ttf", "fonts-symbola", "Symbola", "emoji and symbols"),
)
ASCII_FALLBACK = {"²": "^2", "³": "^3", "–": "-", "—": "-", "−": "-", "×": "x",
                  "→": "->", "≈": "~", "µ": "u", "…": "..."}


@functools.lru_cache(maxsize=64)
def load_font(size: int) -> ImageFont.FreeTypeFont:
    """The main font at ``size`` px, loaded once per size (fonts are only read)."""
    from PIL import ImageFont
    for name in SYSTEM_FONTS:
        try:
            return ImageFont.truetype(name, int(size))
        except OSError:
            continue
    return ImageFont.load_default(size=int(size))


@functools.lru_cache(maxsize=64)
def fallback_fonts(size: int) -> tuple[ImageFont.FreeTypeFont, ...]:
    """The installed fallback fonts at ``size`` px, in FALLBACK_FONTS' order."""
    from PIL import ImageFont
    fonts = []
    for path, *_ in FALLBACK_FONTS:
        try:
            fonts.append(ImageFont.truetype(path, int(size)))
        except OSError:
            continue
    return tuple(fonts)


def font_files() -> list[str]:
    """The font files text is drawn from here, main font first (what decides its pixels)."""
    return [path for path in (SYSTEM_FONTS[0], *(f for f, *_ in FALLBACK_FONTS)) if os.path.isfile(path)]


def _chain(font) -> tuple:
    """``font`` and the fallback fonts at its size (none for a bitmap font, which has no size)."""
    size = getattr(font, "size", None)
    return (font, *fallback_fonts(size)) if isinstance(size, (int, float)) and size > 0 else (font,)


# drawable_text's answers by (font, text): a gallery build asks ~40 000 times (a glyph
# rendered per character each time: 1.2 s), about 2 000 distinct; the runs text_runs cuts
# texts into, likewise; and whether a font draws a character, by (font, character): the
# distinct texts (captions) share their characters.
_drawable: dict[tuple, str] = {}
_runs: dict[tuple, tuple] = {}
_glyphs: dict[tuple, bool] = {}
_notdef: dict[tuple, tuple] = {}


def forget_fonts() -> None:
    """Drop the loaded fonts and every answer about them (after the fonts installed changed)."""
    for cache in (_drawable, _runs, _glyphs, _notdef):
        cache.clear()
    load_font.cache_clear()
    fallback_fonts.cache_clear()


def _font_key(font: ImageFont.FreeTypeFont) -> tuple:
    path = getattr(font, "path", None)
    return path if isinstance(path, str) else id(font), getattr(font, "size", 0)


def _has_glyph(font, ch: str) -> bool:
    """Whether ``font`` draws ``ch`` with a glyph of its own (not its "missing" box)."""
    font_key = _font_key(font)
    key = (*font_key, ch)
    known = _glyphs.get(key)
    if known is None:
        if font_key not in _notdef:
            missing = font.getmask("\U0010fffd")
            _notdef[font_key] = (missing.size, bytes(missing))
        if len(_glyphs) >= 65536:
            _glyphs.clear()
        mask = font.getmask(ch)
        known = _glyphs[key] = (mask.size, bytes(mask)) != _notdef[font_key]
    return known


def _invisible(font, ch: str) -> bool:
    """Whether ``font`` sets ``ch`` (a format character) as nothing, as a shaper does."""
    if not _has_glyph(font, ch):
        return False
    mask = font.getmask(ch)
    return not any(bytes(mask))


# Unicode's Default_Ignorable_Code_Point: characters drawn as nothing (zero-width joiners and
# spaces, variation selectors, tags, the bidi controls).
_IGNORABLE = ((0x00AD, 0x00AD), (0x034F, 0x034F), (0x061C, 0x061C), (0x115F, 0x1160), (0x17B4, 0x17B5),
              (0x180B, 0x180F), (0x200B, 0x200F), (0x202A, 0x202E), (0x2060, 0x206F), (0x3164, 0x3164),
              (0xFE00, 0xFE0F), (0xFEFF, 0xFEFF), (0xFFA0, 0xFFA0), (0xFFF0, 0xFFF8), (0x1BCA0, 0x1BCA3),
              (0x1D173, 0x1D17A), (0xE0000, 0xE0FFF))
_JOINERS = "\u200c\u200d"   # kept where the font sets them as nothing: they change how Arabic, Indic, emoji join


def _ignorable(ch: str) -> bool:
    o = ord(ch)
    return any(lo <= o <= hi for lo, hi in _IGNORABLE)


def drawable_text(text: str, font: ImageFont.FreeTypeFont) -> str:
    """``text`` as it is drawn in ``font`` and its fallbacks: control and bidirectional
    characters dropped (a tab or other spacing control is a space; line breaks stay, for
    wrap_text), bytes that were not UTF-8 shown as U+FFFD, characters no installed font has
    spelled in ASCII; SpecError, naming them, for characters no font has and that have no
    spelling."""
    key = (*_font_key(font), text)
    if key not in _drawable:
        if len(_drawable) >= 8192:
            _drawable.clear()
        _drawable[key] = _drawable_now(text, font)
    return _drawable[key]


def _drawable_now(text: str, font: ImageFont.FreeTypeFont) -> str:
    chain = _chain(font)

    def drawn(ch: str) -> bool:
        return any(_has_glyph(f, ch) for f in chain)

    def spelling(ch: str) -> str | None:
        if ch in ASCII_FALLBACK:
            return ASCII_FALLBACK[ch]
        name = unicodedata.name(ch, "")
        if name.startswith("GREEK") and " LETTER " in name:
            word = name.split()[-1].lower()
            return word.capitalize() if "CAPITAL" in name else word
        base = "".join(c for c in unicodedata.normalize("NFKD", ch) if not unicodedata.combining(c))
        return base if base and base != ch and all(c.isspace() or drawn(c) for c in base) else None

    out, undrawable = [], []
    for ch in text:
        category = unicodedata.category(ch)
        if ch == "\n" or (ch.isspace() and category not in ("Cc", "Zl", "Zp")):
            out.append(ch)
        elif ch.isspace():
            out.append(" ")   # a tab, a line or paragraph separator
        elif category == "Cc" or ch in BIDI_CONTROLS:
            continue
        elif _ignorable(ch):
            if ch in _JOINERS and _invisible(font, ch):
                out.append(ch)
        elif category == "Cs" and drawn("\ufffd"):
            out.append("\ufffd")   # a byte that was not UTF-8 (a file name's): the replacement character
        elif category != "Cs" and drawn(ch):
            out.append(ch)
        else:
            spelled = spelling(ch) if category != "Cs" else None
            if spelled is None:
                undrawable.append(ch)
            else:
                out.append(spelled)
    if undrawable:
        raise SpecError(undrawable_message(text, undrawable))
    return "".join(out)


def _package_for(ch: str) -> tuple[str, str, str, str] | None:
    """The fallback font (FALLBACK_FONTS' entry) meant for ``ch``: the CJK one or the emoji one."""
    if unicodedata.category(ch) == "Cs":
        return None
    name = unicodedata.name(ch, "")
    cjk = name.startswith(("CJK", "HIRAGANA", "KATAKANA", "HANGUL", "BOPOMOFO", "IDEOGRAPHIC", "FULLWIDTH",
                           "HALFWIDTH", "KANGXI", "YI ", "PARENTHESIZED HANGUL", "CIRCLED HANGUL"))
    package = "fonts-wqy-microhei" if cjk else "fonts-symbola"
    return next((entry for entry in FALLBACK_FONTS if entry[1] == package), None)


def undrawable_message(text: str, chars) -> str:
    """One line: which characters of ``text`` no installed font draws, and what would."""
    chars = list(dict.fromkeys(chars))
    named = ", ".join(describe_char(c) for c in chars[:6]) + (f" and {len(chars) - 6} more" if len(chars) > 6 else "")
    wanted = {p for p in map(_package_for, chars) if p}
    absent = [p for p in FALLBACK_FONTS if p in wanted and not os.path.isfile(p[0])]
    if absent:
        hint = "; install Debian's " + " and ".join(f"{package} ({what})" for _, package, _, what in absent)
    else:
        fonts = ", ".join(["DejaVu Sans", *(name for _, _, name, _ in FALLBACK_FONTS)])
        hint = f"; none of the fonts sdfpbr draws with has them ({fonts})"
    return f"cannot draw the text {quote(text)}: no installed font has {named}{hint}"


def text_runs(text: str, font: ImageFont.FreeTypeFont) -> tuple[tuple[str, ImageFont.FreeTypeFont], ...]:
    """``text`` (as drawable_text gives it) cut into runs, each set in one font: a character
    in ``font`` where it has a glyph, else in the first fallback that has one; spaces, joiners
    and combining marks stay in the run they follow where its font has them."""
    key = (*_font_key(font), text)
    runs = _runs.get(key)
    if runs is None:
        if len(_runs) >= 8192:
            _runs.clear()
        runs = _runs[key] = _runs_now(text, font)
    return runs


def _runs_now(text: str, font) -> tuple:
    chain = _chain(font)
    if len(chain) == 1 or all(c.isspace() or _has_glyph(font, c) for c in text):
        return ((text, font),)
    runs: list[list] = []
    current = 0
    for ch in text:
        if ch.isspace() or ch in _JOINERS:
            which = current if runs else 0
        elif unicodedata.category(ch)[0] == "M" and runs and _has_glyph(chain[current], ch):
            which = current
        else:
            which = next((i for i, f in enumerate(chain) if _has_glyph(f, ch)), 0)
        if runs and which == current:
            runs[-1][0] += ch
        else:
            runs.append([ch, chain[which]])
            current = which
    # The spaces before another font's run are a run of their own: set with the run before them,
    # they were moved to its start where it held right-to-left text (Arabic, Hebrew).
    out = []
    for i, (t, f) in enumerate(runs):
        kept = t.rstrip() if i < len(runs) - 1 else t
        out += [(kept, f), (t[len(kept):], f)] if kept and kept != t else [(t, f)]
    return tuple(out)


def text_length(font: ImageFont.FreeTypeFont, text: str) -> float:
    """The advance of ``text`` (drawable) in px, as font.getlength gives it for one font."""
    runs = text_runs(text, font)
    if len(runs) == 1 and runs[0][1] is font:   # (the common case: as Pillow sets it)
        return font.getlength(text)
    return sum(f.getlength(t) for t, f in runs)


def _runs_box(runs, stroke_width: float) -> tuple[tuple[float, float, float, float], list[float], float]:
    """The runs' ink box at anchor "ls" (origin on the baseline, left), each run's pen x, the advance."""
    pens, x = [], 0.0
    left = top = math.inf
    right = bottom = -math.inf
    for t, f in runs:
        pens.append(x)
        if not t.isspace():   # (a run of spaces has no ink, only its advance)
            l, tp, r, b = f.getbbox(t, anchor="ls", stroke_width=stroke_width)
            left, top, right, bottom = min(left, x + l), min(top, tp), max(right, x + r), max(bottom, b)
        x += f.getlength(t)
    if left == math.inf:
        left = top = right = bottom = 0
    return (left, top, right, bottom), pens, x


def _anchor_shift(font, box, advance: float, anchor: str | None) -> tuple[float, float]:
    """Where the "ls" origin lies from the point a Pillow ``anchor`` names, for text in runs:
    across by the advance, down by the main font's metrics (ascender, middle, descender) or by
    the ink (top, bottom)."""
    anchor = anchor or "la"
    if len(anchor) != 2 or anchor[0] not in "lmr" or anchor[1] not in "amsdtb":
        raise ValueError(f"anchor {anchor!r} is not a horizontal text anchor")
    h, v = anchor
    dx = {"l": 0.0, "m": -advance / 2, "r": -advance}[h]
    if v == "s":
        dy = 0.0
    elif v == "t":
        dy = -box[1]
    elif v == "b":
        dy = -box[3]
    else:   # the font's own lines, the same for any text
        dy = float(font.getbbox("x", anchor="l" + v)[1] - font.getbbox("x", anchor="ls")[1])
    return dx, dy


def text_bbox(font: ImageFont.FreeTypeFont, text: str, anchor: str | None = None,
              stroke_width: float = 0) -> tuple[int, int, int, int]:
    """font.getbbox(text, anchor=, stroke_width=) for text set in ``font`` and its fallbacks."""
    runs = text_runs(text, font)
    if len(runs) == 1 and runs[0][1] is font:
        return font.getbbox(text, anchor=anchor, stroke_width=stroke_width)
    box, _, advance = _runs_box(runs, stroke_width)
    dx, dy = _anchor_shift(font, box, advance, anchor)
    return (math.floor(box[0] + dx), math.floor(box[1] + dy), math.ceil(box[2] + dx), math.ceil(box[3] + dy))


def draw_text(draw: ImageDraw.ImageDraw, xy: tuple[float, float], text: str, font: ImageFont.FreeTypeFont,
              fill, anchor: str | None = None, stroke_width: float = 0, stroke_fill=None) -> None:
    """draw.text(xy, text, font=, fill=, anchor=, stroke_width=, stroke_fill=) for text set in
    ``font`` and its fallbacks: run by run on one baseline, every outline under every fill."""
    runs = text_runs(text, font)
    if len(runs) == 1 and runs[0][1] is font:
        draw.text(xy, text, font=font, fill=fill, anchor=anchor, stroke_width=stroke_width, stroke_fill=stroke_fill)
        return
    runs = tuple((t.replace("\n", " "), f) for t, f in runs)   # one line: callers wrap before drawing
    box, pens, advance = _runs_box(runs, stroke_width)
    dx, dy = _anchor_shift(font, box, advance, anchor)
    x, baseline = xy[0] + dx, xy[1] + dy
    if stroke_width:
        outline = fill if stroke_fill is None else stroke_fill
        for (t, f), pen in zip(runs, pens):
            draw.text((x + pen, baseline), t, font=f, fill=outline, anchor="ls", stroke_width=stroke_width,
                      stroke_fill=outline)
        if outline == fill:
            return
    for (t, f), pen in zip(runs, pens):
        draw.text((x + pen, baseline), t, font=f, fill=fill, anchor="ls")


def wrap_text(text: str, font: ImageFont.FreeTypeFont, width: float) -> list[str]:
    """Greedy word wrap to ``width`` pixels (drawable text); explicit newlines start new
    paragraphs."""
    lines: list[str] = []
    for paragraph in drawable_text(text, font).split("\n"):
        line = ""
        for word in paragraph.split():
            trial = f"{line} {word}" if line else word
            if not line or text_length(font, trial) <= width:
                line = trial
            else:
                lines.append(line)
                line = word
        lines.append(line)
    return lines
