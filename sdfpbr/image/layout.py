"""Chart layout: put the rendered sphere grid into a labeled canvas.

The renderer hands over an RGBA uint8 image of the render area plus the projected
sphere positions (:class:`Cell`).  :func:`compose_chart` pastes that image unchanged
into a larger canvas whose margins hold every piece of text:

* top: the title, the column axis title and one label per column, each label
  centred on the mean ``cx`` of its column's spheres;
* left: the row axis title (rotated 90°) and one label per row, right-aligned
  and centred on the mean ``cy`` of its row's spheres;
* bottom: a footer (tone mapper, exposure, environment ...), its parts (``FOOTER_SEPARATOR``
  apart) wrapped onto more lines where one line would be wider than the rest of the chart.

Text is set in the font of :mod:`sdfpbr.image.text`, sized from the render height;
margins are sized from measured text extents.
"""

from __future__ import annotations

import functools
import importlib.util
import math
import os
from dataclasses import dataclass, replace
from decimal import ROUND_HALF_UP, Decimal
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..cache import ArrayCache, content_key
from ..result_cache import ResultCache
from .colour import BACKGROUND, luminance, srgb_eotf
from .text import SYSTEM_FONTS, draw_text, drawable_text, font_files, load_font, text_bbox, wrap_text

if TYPE_CHECKING:   # Pillow is imported where text is set: a chart whose labels are kept on disk needs none
    from PIL import ImageFont

__all__ = ["FOOTER_SEPARATOR", "Cell", "compose_chart", "chart_canvas", "name_cells", "render_area_offset",
           "label_text", "label_boxes"]

DEFAULT_COLUMN_AXIS_TITLE = "roughness r (α = r²)"
DEFAULT_ROW_AXIS_TITLE = "metallic"
FOOTER_SEPARATOR = "  |  "   # between a footer's parts; a wrapped footer breaks there

_TRANSPARENT = (0, 0, 0, 0)
_OUTLINE = (16, 16, 16, 255)  # drawn around text only in transparent mode
# Text colours by style on the chart's dark ground. On a page colour (a chart laid onto a
# backdrop) each style keeps the contrast it has here, as far as the page allows (_text_colour).
_DARK_GROUND_INK = {"title": (240, 240, 240, 255), "label": (225, 225, 225, 255), "axis": (175, 175, 175, 255),
                    "footer": (150, 150, 150, 255)}
_ROW_LABEL_RESERVE = "0.00"  # widest plain value label; reserved even when the labels are not known


@dataclass(frozen=True)
class Cell:
    """One sphere as projected in the render image (pixels, origin top-left)."""

    row: int
    col: int
    cx: float
    cy: float
    radius_px: float


def label_text(value: float) -> str:
    """Axis label for a value: at most two decimals (half up), no trailing zeros."""
    if not math.isfinite(value):
        return str(value)
    text = str(Decimal(repr(float(value))).quantize(Decimal("0.01"), rounding=ROUND_HALF_UP))
    text = text.rstrip("0").rstrip(".") if "." in text else text
    return "0" if text == "-0" else text


@dataclass(frozen=True)
class _Style:
    size: int  # font size in pixels
    color: tuple[int, int, int, int]
    font: ImageFont.FreeTypeFont
    stroke: int  # outline width; reserved in the layout, drawn only in transparent mode


def _style(size: int, color: tuple[int, int, int, int]) -> _Style:
    return _Style(size, color, load_font(size), max(1, round(size / 16)))


def _relative_luminance(rgb8) -> float:
    return float(luminance(srgb_eotf(np.asarray(rgb8[:3], float) / 255)))


def _contrast(a, b) -> float:
    """WCAG 2 contrast ratio of two sRGB colours."""
    la, lb = sorted((_relative_luminance(a), _relative_luminance(b)))
    return (lb + 0.05) / (la + 0.05)


def page_colour(page_srgb: Sequence[float] | None) -> tuple[int, int, int, int] | None:
    """A page colour (sRGB 0..1) as the labels' opaque 8-bit background."""
    return None if page_srgb is None else (*(round(255 * min(max(v, 0.0), 1.0)) for v in page_srgb), 255)


# The least WCAG contrast a style keeps on a page that cannot give it its own (the value labels
# and the title are read; the axis titles and the footer are large or secondary).
_LEAST_CONTRAST = {"title": 4.5, "label": 4.5, "axis": 3.0, "footer": 3.0}


@functools.lru_cache(maxsize=64)
def _text_colour(style_name: str, page: tuple[int, int, int, int] | None) -> tuple[int, int, int, int]:
    """The text colour of a style on the chart's own ground (page None) or on a page: the grey
    between the page and white or black (whichever the page contrasts more with) whose WCAG
    contrast with the page is the style's on the chart's ground; where the page cannot reach the
    title's, every style's is scaled down alike (so a title stays above an axis title), but not
    under its least, nor over what the page allows. Dark on a light page."""
    ground = _DARK_GROUND_INK[style_name]
    if page is None:
        return ground
    extreme = max((0, 255), key=lambda v: _contrast((v, v, v), page))
    most = _contrast((extreme,) * 3, page)
    title = _contrast(_DARK_GROUND_INK["title"], BACKGROUND)
    scaled = 1 + (_contrast(ground, BACKGROUND) - 1) * min(1.0, (most - 1) / (title - 1))
    target = min(max(scaled, _LEAST_CONTRAST[style_name]), most)
    lo, hi = 0.0, 1.0                     # the extreme's share of the mix
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _contrast(_mix(page, extreme, mid), page) < target else (lo, mid)
    return (*_mix(page, extreme, hi), 255)


def text_colour(style_name: str, page_srgb: Sequence[float] | None) -> tuple[int, int, int, int]:
    """A label style's text colour ("title", "label", "axis", "footer") on the chart's ground
    (None) or on the page colour ``page_srgb`` (sRGB 0..1): what sheets set their text in."""
    return _text_colour(style_name, page_colour(page_srgb))


def _mix(page, extreme: int, share: float) -> tuple[int, int, int]:
    return tuple(round(c + (extreme - c) * share) for c in page[:3])


def _styles(render_side: int) -> dict[str, _Style]:
    """Font sizes scale with the render's longer side (a figure is read at its width on a page,
    however few rows it has): 1024 px -> 22 px labels, 30 px title."""
    scale = render_side / 1024
    label = max(11, round(22 * scale))
    return {
        "title": _style(max(14, round(30 * scale)), _DARK_GROUND_INK["title"]),
        "label": _style(label, _DARK_GROUND_INK["label"]),
        "axis": _style(label, _DARK_GROUND_INK["axis"]),
        "footer": _style(max(11, round(17 * scale)), _DARK_GROUND_INK["footer"]),
    }


def _ink(style: _Style, text: str) -> tuple[int, int, int, int]:
    """Ink box (left, top, right, bottom) of text drawn at origin (0, baseline), outline included."""
    return _ink_box(style.font, style.stroke, text)


# Layouts measure the same few hundred labels thousands of times (a gallery build: 5 700 boxes,
# 0.2 s); fonts come from load_font, one object per size, so the font itself is the key.
@functools.lru_cache(maxsize=8192)
def _ink_box(font: ImageFont.FreeTypeFont, stroke: int, text: str) -> tuple[int, int, int, int]:
    return text_bbox(font, text, anchor="ls", stroke_width=stroke)


def _width(style: _Style, text: str) -> int:
    left, _, right, _ = _ink(style, text)
    return right - left


def _line_height(style: _Style) -> int:
    ascent, descent = style.font.getmetrics()
    return ascent + descent + 2 * style.stroke


def _baseline(style: _Style, line_top: float) -> float:
    return line_top + style.stroke + style.font.getmetrics()[0]


@dataclass(frozen=True)
class _Layout:
    styles: dict[str, _Style]
    title: tuple[str, ...]    # its lines
    footer: tuple[str, ...]   # its lines
    column_axis_title: str
    row_axis_title: str
    pad: int
    gap: int
    x0: int  # render area origin inside the chart
    y0: int
    width: int  # chart size
    height: int
    title_top: int
    axis_top: int
    labels_top: int
    footer_top: int
    row_axis_x: int   # left of the rotated row axis title, beside the widest row label


def _layout(render_shape: Sequence[int], title: str, footer: str, row_labels: Sequence[str],
            column_axis_title: str, row_axis_title: str) -> _Layout:
    rh, rw = int(render_shape[0]), int(render_shape[1])
    styles = _styles(max(rh, rw))
    text = {"title": title, "footer": footer, "col": column_axis_title, "row": row_axis_title}
    font_of = {"title": "title", "footer": "footer", "col": "axis", "row": "axis"}
    raw_title = title   # wrapped below, at its spaces and its own line breaks
    text = {k: drawable_text(" ".join(v.split("\n")), styles[font_of[k]].font) for k, v in text.items()}
    label, axis = styles["label"], styles["axis"]
    pad, gap = label.size, max(4, label.size // 2)

    # Left margin: rotated row axis title, right-aligned row labels; none for a chart without
    # rows to label (a glTF chart's named cells: its grid sat 87 px from the left, 27 from the right).
    labels = [drawable_text(t, label.font) for t in row_labels]
    rows_labelled = bool(labels or text["row"])
    label_w = max(_width(label, t) for t in [_ROW_LABEL_RESERVE, *labels]) if rows_labelled else 0
    left = pad + (_line_height(axis) + gap if text["row"] else 0) + (label_w + gap if rows_labelled else 0)
    right = pad

    # Grow the margins so that centred text (on the render area) never clips; the title and the
    # footer first wrap (at spaces, at separators) to the width the rest of the chart takes (a
    # long reference footer under a small render set a 702-px canvas around a 256-px chart, a
    # 500-character title a 4166-px one around 400 px).
    half = _width(axis, text["col"]) / 2 + pad - rw / 2
    left, right = max(left, math.ceil(half)), max(right, math.ceil(half))
    room = rw + 2 * (min(left, right) - pad)       # centred on the render
    title = tuple(line if " " in line else _fitted(styles["title"], line, room)   # a word wider than the chart is cut
                  for line in wrap_text(raw_title, styles["title"].font, room) if line) if raw_title.strip() else ()
    footer = _wrapped(styles["footer"], text["footer"], room)
    for style, lines in ((styles["footer"], footer), (styles["title"], title)):
        for line in lines:
            half = _width(style, line) / 2 + pad - rw / 2
            left, right = max(left, math.ceil(half)), max(right, math.ceil(half))

    # Top margin: title, column axis title, column labels.
    y = pad
    title_top = y
    if title:
        y += len(title) * _line_height(styles["title"]) + gap
    axis_top = y
    if text["col"]:
        y += _line_height(axis) + max(2, gap // 3)
    labels_top = y
    top = y + (_line_height(label) + max(2, gap // 2) if text["col"] else 0)   # no column labels: no line

    bottom = (gap + len(footer) * _line_height(styles["footer"]) if footer else 0) + pad
    half = _width(axis, text["row"]) / 2 + pad - rh / 2
    top, bottom = max(top, math.ceil(half)), max(bottom, math.ceil(half))

    return _Layout(styles, title, footer, text["col"], text["row"], pad, gap,
                   x0=left, y0=top, width=left + rw + right, height=top + rh + bottom,
                   title_top=title_top, axis_top=axis_top, labels_top=labels_top,
                   footer_top=top + rh + gap, row_axis_x=left - gap - label_w - gap - _line_height(axis))


def _wrapped(style: _Style, text: str, room: float) -> tuple[str, ...]:
    """``text`` as lines no wider than ``room`` where it can be, broken between its parts (a
    part wider than ``room`` keeps a line of its own)."""
    if not text:
        return ()
    lines: list[str] = []
    for part in text.split(FOOTER_SEPARATOR):
        joined = lines[-1] + FOOTER_SEPARATOR + part if lines else part
        if lines and _width(style, joined) <= room:
            lines[-1] = joined
        else:
            lines.append(part)
    return tuple(lines)


def row_label_texts(row_values: Sequence[float], row_names: Sequence[str] | None) -> list[str]:
    if row_names is not None and len(row_names) != len(row_values):
        raise ValueError(f"{len(row_names)} row names for {len(row_values)} rows")
    if row_names is not None and len(set(row_values)) == 1:   # one value for every row: said once, by the
        return list(row_names)                                   # axis title ('1 · gold' on each row before)
    names = row_names if row_names is not None else [""] * len(row_values)
    return [f"{label_text(v)} · {n}" if n else label_text(v) for v, n in zip(row_values, names)]


def render_area_offset(render_shape: Sequence[int], n_rows: int, n_cols: int, title: str, footer: str,
                       *, row_values: Sequence[float] | None = None, row_names: Sequence[str] | None = None,
                       column_axis_title: str = DEFAULT_COLUMN_AXIS_TITLE,
                       row_axis_title: str = DEFAULT_ROW_AXIS_TITLE) -> tuple[int, int]:
    """(x, y) of the render image's top-left corner inside the chart built by compose_chart.

    The left margin always reserves room for a value label as wide as "0.00", so for plain
    value labels the result does not depend on the values.  When compose_chart gets
    ``row_names`` (or unusually wide values) pass the same ``row_values``/``row_names`` here,
    and likewise any non-default axis titles.  ``n_rows``/``n_cols`` are accepted for symmetry.
    """
    labels = row_label_texts(row_values, row_names) if row_values is not None else []
    layout = _layout(render_shape, title, footer, labels, column_axis_title, row_axis_title)
    return layout.x0, layout.y0


def _mean_centres(cells: Sequence[Cell], count: int, attr: str, key: str, extent: int) -> list[float]:
    """Mean cx (or cy) per column (or row); evenly spaced fallback for an index without cells."""
    centres = []
    for i in range(count):
        values = [getattr(c, attr) for c in cells if getattr(c, key) == i]
        centres.append(float(np.mean(values)) if values else (i + 0.5) * extent / count)
    return centres


def compose_chart(render_rgba: np.ndarray, cells: Sequence[Cell], column_values: Sequence[float],
                  row_values: Sequence[float], title: str, footer: str,
                  row_names: Sequence[str] | None = None, transparent: bool = False,
                  column_axis_title: str = DEFAULT_COLUMN_AXIS_TITLE,
                  row_axis_title: str = DEFAULT_ROW_AXIS_TITLE,
                  cell_names: Sequence[str] | None = None,
                  page_srgb: Sequence[float] | None = None) -> np.ndarray:
    """Return a new RGBA uint8 chart: the render pasted pixel-exactly, with all text in margins;
    ``cell_names`` (one per cell, row by row): a name under each sphere, over the render, for
    charts whose cells are named materials rather than axis values. The margins are the chart's
    dark ground, or nothing (``transparent``: text outlined to read on any page), or the page
    colour ``page_srgb`` (a render laid onto a backdrop) with text that contrasts with it."""
    render = np.asarray(render_rgba)
    if render.dtype != np.uint8 or render.ndim != 3 or render.shape[2] != 4:
        raise ValueError(f"expected an RGBA uint8 image, got {render.dtype} {render.shape}")
    chart, (x0, y0) = chart_canvas(render.shape, cells, column_values, row_values, title, footer, row_names,
                                   transparent, column_axis_title, row_axis_title, page_srgb=page_srgb)
    chart[y0:y0 + render.shape[0], x0:x0 + render.shape[1]] = render
    if cell_names:
        chart = name_cells(chart, cells, cell_names, (x0, y0), render.shape[:2], page_srgb)
    return chart


def chart_canvas(render_shape: Sequence[int], cells: Sequence[Cell], column_values: Sequence[float],
                 row_values: Sequence[float], title: str, footer: str,
                 row_names: Sequence[str] | None = None, transparent: bool = False,
                 column_axis_title: str = DEFAULT_COLUMN_AXIS_TITLE,
                 row_axis_title: str = DEFAULT_ROW_AXIS_TITLE,
                 on_disk: bool = False, page_srgb: Sequence[float] | None = None) -> tuple[np.ndarray, tuple[int, int]]:
    """A new RGBA uint8 chart without its render: the background and every label, and the
    (x, y) where a render of ``render_shape`` goes (a renderer may draw straight into it).
    ``on_disk``: the labels are also read from and kept in the disk cache (a still chart's; an
    animation's frames, each a layout of its own when the camera turns, are not kept)."""
    page = page_colour(page_srgb)
    transparent = transparent and page is None   # a page under the render is under its labels too
    key = (tuple(render_shape[:2]), tuple(cells), tuple(column_values), tuple(row_values), title, footer,
           tuple(row_names or ()), transparent, column_axis_title, row_axis_title, page)
    labels = _labels.pop(key, None)
    stored_key = _stored_key(key) if on_disk and labels is None else None
    if stored_key:
        labels = _read_labels(stored_key)
    if labels is None:
        labels = _draw_labels(render_shape, cells, column_values, row_values, title, footer, row_names,
                              transparent, column_axis_title, row_axis_title, page)
        if stored_key:
            ArrayCache().put(LABELS_CACHE_KIND, stored_key, labels.arrays())
    _labels[key] = labels   # the most recently used last
    while len(_labels) > LABELS_CACHE_SIZE:
        _labels.pop(next(iter(_labels)))
    return labels.canvas(), labels.origin


def _fitted(style: _Style, text: str, room: float) -> str:
    """``text``, or its longest start that fits ``room`` px with an ellipsis after it (found by
    bisection: a title may be thousands of characters)."""
    if _width(style, text) <= room:
        return text
    kept, over = 0, len(text)          # a start of ``kept`` characters fits, one of ``over`` does not
    while over - kept > 1:
        mid = (kept + over) // 2
        kept, over = (mid, over) if _width(style, text[:mid] + "…") <= room else (kept, mid)
    return text[:kept] + "…" if kept or _width(style, "…") <= room else ""


def name_cells(chart: np.ndarray, cells: Sequence[Cell], names: Sequence[str], origin: tuple[int, int],
               render_shape: Sequence[int], page_srgb: Sequence[float] | None = None) -> np.ndarray:
    """Each cell's name centred under its sphere, outlined so it reads over any floor, and cut
    to its column's width so that neighbours' names never run into each other. ``origin``: the
    render's (x, y) in the chart."""
    from PIL import Image, ImageDraw
    x0, y0 = origin
    style = _styles(max(render_shape[:2]))["label"]
    page = page_colour(page_srgb)   # the floor a name sits on is the page: plain text of its colour
    colour, stroke = _text_colour("label", page), (0 if page else max(1, style.size // 8))
    layer = Image.new("RGBA", (chart.shape[1], chart.shape[0]), _TRANSPARENT)
    draw = ImageDraw.Draw(layer)
    xs = sorted({round(c.cx, 3) for c in cells})
    room = min([b - a for a, b in zip(xs, xs[1:])] or [render_shape[1]]) - max(2, style.size // 3)
    cap_top = _ink(style, "H")[1]   # one baseline for every name, whether it has ascenders or not
    for cell in cells:
        name = names[cell.row * (max(c.col for c in cells) + 1) + cell.col]
        text = _fitted(style, drawable_text(" ".join(name.split("\n")), style.font), room)
        left, _, right, _ = _ink(style, text)
        baseline = y0 + cell.cy + 1.1 * cell.radius_px + 0.3 * style.size - cap_top
        draw_text(draw, (x0 + cell.cx - (left + right) / 2, baseline), text, style.font, colour,
                  anchor="ls", stroke_width=stroke, stroke_fill=_OUTLINE)
    return np.array(Image.alpha_composite(Image.fromarray(chart), layer))


# The text around a render depends on the layout alone, not on the pixels: an animation's
# frames and a build's repeated layouts draw it once (20 ms for a 1024² chart). What is kept is
# the text's own pixels, so a kept layout costs kilobytes whatever the chart's size.
LABELS_CACHE_SIZE = 8
_labels: dict[tuple, "_Labels"] = {}


def forget_layouts() -> None:
    """Drop the kept label layers and text patches (the next chart of each layout draws its
    labels from nothing, or reads them from the disk cache)."""
    _labels.clear()
    _text_patches.clear()


# A still chart's labels are kept in the disk cache too: a new process charting a layout drawn
# before reads them (a few hundred kilobytes) instead of importing Pillow and setting the text,
# 50 ms of a cold `sdfpbr chart`. Keyed by the layout and by all that decides how its text is
# drawn: the font files (main and fallbacks), Pillow's version and FreeType module, and this
# module's and text's source.
LABELS_CACHE_KIND = "labels"


@functools.lru_cache(maxsize=1)
def _drawing_identity() -> str | None:
    """What decides the labels' pixels besides the layout, found without importing Pillow; None
    where the font is not the system file (Pillow's search or its own font: drawn each time)."""
    try:
        font = os.stat(SYSTEM_FONTS[0])
        fallbacks = [(f, os.stat(f).st_size, os.stat(f).st_mtime_ns) for f in font_files()[1:]]
        pil = importlib.util.find_spec("PIL")
        where = Path(next(iter(pil.submodule_search_locations)))
        freetype = sorted((n, os.stat(where / n).st_size) for n in os.listdir(where) if n.startswith("_imagingft"))
        version = (where / "_version.py").read_text()
        code = [(Path(__file__).parent / name).read_text() for name in ("layout.py", "text.py")]
    except (OSError, AttributeError, StopIteration, ValueError, ImportError):
        return None
    return content_key(SYSTEM_FONTS[0], font.st_size, font.st_mtime_ns, fallbacks, version, freetype, code)


def _stored_key(key: tuple) -> str | None:
    identity = _drawing_identity()
    return content_key(identity, repr(key)) if identity else None


def _read_labels(stored_key: str) -> "_Labels | None":
    arrays = ArrayCache().get(LABELS_CACHE_KIND, stored_key)
    if arrays is None:
        return None
    try:
        return _Labels.from_arrays(arrays)
    except (KeyError, ValueError):   # a well-formed entry of another shape: drawn again
        return None


@dataclass(frozen=True)
class _Labels:
    """A chart without its render: its size, its background, where the render goes, and each
    piece of text as a small patch already composited over the background, with its top-left
    corner. Nothing chart-sized is held: an 8192² chart's labels are a few hundred kilobytes,
    not the 350 MB layers that drawing them on the whole chart took."""
    width: int
    height: int
    background: tuple[int, int, int, int]
    origin: tuple[int, int]
    patches: tuple[tuple[int, int, np.ndarray], ...]

    def arrays(self) -> dict[str, np.ndarray]:
        """The layers as the disk cache keeps them: a header, each patch's (x, y, height, width),
        and the patches' pixels end to end."""
        table = np.array([(x, y, p.shape[0], p.shape[1]) for x, y, p in self.patches], np.int64).reshape(-1, 4)
        pixels = [np.ascontiguousarray(p, np.uint8).reshape(-1) for _, _, p in self.patches]
        return {"head": np.array([self.width, self.height, *self.background, *self.origin], np.int64),
                "table": table, "pixels": np.concatenate(pixels) if pixels else np.zeros(0, np.uint8)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> "_Labels":
        head, table, pixels = arrays["head"], arrays["table"], arrays["pixels"]
        width, height, *rest = (int(v) for v in head)
        background, origin = tuple(rest[:4]), tuple(rest[4:6])
        patches, at = [], 0
        for x, y, h, w in table.tolist():
            patches.append((x, y, pixels[at:at + h * w * 4].reshape(h, w, 4)))
            at += h * w * 4
        if len(origin) != 2 or at != pixels.size or pixels.dtype != np.uint8:
            raise ValueError("labels entry of another form")
        return cls(width, height, background, origin, tuple(patches))

    def canvas(self) -> np.ndarray:
        """A new (height, width, 4) uint8 chart: the background with every label on it."""
        # Filled as one 32-bit word per pixel: broadcasting the 4 bytes is 40x slower.
        pixel = np.array(self.background, np.uint8).view(np.uint32)[0]
        chart = np.full((self.height, self.width), pixel, np.uint32).view(np.uint8).reshape(self.height, self.width, 4)
        for x, y, patch in self.patches:   # labels never collide (thinned), so patches do not overlap
            chart[y:y + patch.shape[0], x:x + patch.shape[1]] = patch
        return chart


@dataclass(frozen=True)
class _Text:
    """One piece of text as placed on the chart: its style, where its baseline starts, and its
    ink box (left, top, right, bottom) in chart pixels, outline included."""
    style: str
    text: str
    x: float
    baseline: float
    box: tuple[float, float, float, float]
    rotated: bool = False   # the row axis title, drawn turned 90° counter-clockwise


def _thinned(boxes: Sequence[tuple[float, float]], gap: float) -> list[int]:
    """Indices of the labels to draw along one axis, every k-th with the smallest k for which no
    two drawn labels (their extents along the axis, ``gap`` apart) collide; the last label is
    drawn too, in place of the k-th before it (which stood under k steps from it: "0.96 1" at
    the end of a 24-column axis read as one crowded label)."""
    n = len(boxes)

    def clear(a, b):
        return boxes[a][1] + gap <= boxes[b][0]

    for k in range(1, n + 1):
        shown = list(range(0, n, k))
        if shown[-1] != n - 1:
            shown = shown[:-1] + [n - 1] if len(shown) > 1 else shown + [n - 1]
        if all(clear(a, b) for a, b in zip(shown, shown[1:])):
            return shown
    return [0]


def _placements(lay: _Layout, render_shape, cells, column_values, row_labels) -> list[_Text]:
    """Every piece of text of the chart, placed; column and row labels thinned so that none collide."""
    rh, rw = render_shape[:2]
    x0, y0, width, height = lay.x0, lay.y0, lay.width, lay.height
    styles = lay.styles
    out: list[_Text] = []

    def at(key: str, text: str, x: float, baseline: float) -> _Text:
        left, top, right, bottom = _ink(styles[key], text)
        return _Text(key, text, x, baseline, (x + left, baseline + top, x + right, baseline + bottom))

    def centred(key: str, text: str, centre_x: float, baseline: float) -> _Text:
        left, _, right, _ = _ink(styles[key], text)
        return at(key, text, min(max(centre_x - (left + right) / 2, -left), width - right), baseline)  # inside

    centre_x = x0 + rw / 2
    for i, line in enumerate(lay.title):
        top = lay.title_top + i * _line_height(styles["title"])
        out.append(centred("title", line, centre_x, _baseline(styles["title"], top)))
    if lay.column_axis_title:
        out.append(centred("axis", lay.column_axis_title, centre_x, _baseline(styles["axis"], lay.axis_top)))
    for i, line in enumerate(lay.footer):
        top = lay.footer_top + i * _line_height(styles["footer"])
        out.append(centred("footer", line, centre_x, _baseline(styles["footer"], top)))

    label = styles["label"]
    spacing = max(2, label.size // 3)
    col_centres = _mean_centres(cells, len(column_values), "cx", "col", rw)
    columns = [centred("label", drawable_text(label_text(v), label.font), x0 + cx, _baseline(label, lay.labels_top))
               for v, cx in zip(column_values, col_centres)]
    out += [columns[i] for i in _thinned([(t.box[0], t.box[2]) for t in columns], spacing)] if columns else []

    # Row labels: right-aligned against the render area, digits centred on the row's cy.
    _, digit_top, _, digit_bottom = label.font.getbbox("0123456789", anchor="ls")
    row_centres = _mean_centres(cells, len(row_labels), "cy", "row", rh)
    rows = []
    for text, cy in zip(row_labels, row_centres):
        text = drawable_text(text, label.font)
        _, top, right, bottom = _ink(label, text)
        rows.append(at("label", text, x0 - lay.gap - right,
                       min(max(y0 + cy - (digit_top + digit_bottom) / 2, -top), height - bottom)))
    out += [rows[i] for i in _thinned([(t.box[1], t.box[3]) for t in rows], spacing)] if rows else []

    if lay.row_axis_title:  # rotated 90° counter-clockwise, centred on the render area
        axis = styles["axis"]
        left, _, right, _ = _ink(axis, lay.row_axis_title)
        w, h = right - left, _line_height(axis)
        top = max(0, round(y0 + rh / 2 - w / 2))
        x = lay.row_axis_x
        out.append(_Text("axis", lay.row_axis_title, x, top, (x, top, x + h, top + w), rotated=True))
    return out


def label_boxes(render_shape: Sequence[int], cells: Sequence[Cell], column_values: Sequence[float],
                row_values: Sequence[float], title: str, footer: str, row_names: Sequence[str] | None = None,
                column_axis_title: str = DEFAULT_COLUMN_AXIS_TITLE,
                row_axis_title: str = DEFAULT_ROW_AXIS_TITLE) -> list[tuple[str, tuple[float, float, float, float]]]:
    """(text, ink box in chart pixels) of every piece of text compose_chart draws for this layout."""
    row_labels = row_label_texts(row_values, row_names)
    lay = _layout(render_shape, title, footer, row_labels, column_axis_title, row_axis_title)
    return [(t.text, t.box) for t in _placements(lay, render_shape, cells, column_values, row_labels)]


# Label patches by all that decides their pixels: the charts of a gallery's bug pages differ
# in title and footer only, and drawing every axis value again was 0.8 s of a build. ResultCache
# within a byte budget (an 8192² chart's title alone is megabytes).
TEXT_PATCH_BYTES = 32 << 20
_text_patches = ResultCache(TEXT_PATCH_BYTES, lambda patch: patch.nbytes)


def _text_patch(style: _Style, text: str, stroke: int, size: tuple[int, int] | None,
                origin: tuple[float, float] | None) -> np.ndarray:
    """``text`` drawn on a transparent patch (read-only RGBA): ``size`` with the text's origin at
    ``origin``, or (both None) on a strip as tall as a line and turned a quarter left."""
    key = (style, text, stroke, size, origin)
    patch = _text_patches.get(key)
    if patch is None:
        patch = _drawn_text_patch(style, text, stroke, size, origin)
        _text_patches.put(key, patch)
    return patch


def _drawn_text_patch(style: _Style, text: str, stroke: int, size: tuple[int, int] | None,
                      origin: tuple[float, float] | None) -> np.ndarray:
    from PIL import Image, ImageDraw
    if size is None:
        left, _, right, _ = _ink(style, text)
        strip = Image.new("RGBA", (right - left, _line_height(style)), _TRANSPARENT)
        draw_text(ImageDraw.Draw(strip), (-left, _baseline(style, 0)), text, style.font, style.color,
                  anchor="ls", stroke_fill=_OUTLINE, stroke_width=stroke)
        patch = np.asarray(strip.transpose(Image.Transpose.ROTATE_90))
    else:
        layer = Image.new("RGBA", size, _TRANSPARENT)
        draw_text(ImageDraw.Draw(layer), origin, text, style.font, style.color,
                  anchor="ls", stroke_width=stroke, stroke_fill=_OUTLINE)
        patch = np.asarray(layer)
    patch.setflags(write=False)
    return patch


def _draw_labels(render_shape, cells, column_values, row_values, title, footer, row_names, transparent,
                 column_axis_title, row_axis_title, page) -> _Labels:
    """Every label of the layout drawn on its own patch, at the same sub-pixel position as on
    the whole chart (a patch's corner is a whole pixel: the fraction of the text's origin is kept)."""
    from PIL import Image
    row_labels = row_label_texts(row_values, row_names)
    lay = _layout(render_shape, title, footer, row_labels, column_axis_title, row_axis_title)
    width, height = lay.width, lay.height
    background = page or (_TRANSPARENT if transparent else BACKGROUND)
    patches = []
    for t in _placements(lay, render_shape, cells, column_values, row_labels):
        style = lay.styles[t.style]
        if page is not None:   # the styles' own colours are the chart's dark ground's
            style = replace(style, color=_text_colour(t.style, page))
        stroke = style.stroke if transparent else 0
        if t.rotated:
            x, y, patch = int(t.x), int(t.baseline), _text_patch(style, t.text, stroke, None, None)
        else:   # the ink box and a pixel of slack each side
            x, y = math.floor(t.box[0]) - 1, math.floor(t.box[1]) - 1
            size = (math.ceil(t.box[2]) + 1 - x, math.ceil(t.box[3]) + 1 - y)
            patch = _text_patch(style, t.text, stroke, size, (t.x - x, t.baseline - y))
        # Clipped to the chart: a label is placed inside it, its slack may not be.
        x1, y1 = min(x + patch.shape[1], width), min(y + patch.shape[0], height)
        patch = patch[max(0, -y):y1 - y, max(0, -x):x1 - x]
        x, y = max(x, 0), max(y, 0)
        if patch.size and patch[..., 3].any():
            under = Image.new("RGBA", (patch.shape[1], patch.shape[0]), background)
            patches.append((x, y, np.asarray(Image.alpha_composite(under, Image.fromarray(patch)))))
    return _Labels(width, height, background, (lay.x0, lay.y0), tuple(patches))
