"""Sheets: panels (an image with a label above, or with a chart's axis labels around it) laid
out in a grid with a title, an optional notes column and a wrapped caption, and numbers
printed on the cells of a panel. Pure image layout: what the panels show is the caller's.

A sheet is on the charts' dark ground, or on a page colour (``page_srgb``: sRGB 0..1, the
backdrop the charts were laid onto), with text that contrasts with it as a chart's labels do.

A panel's image is pasted unresampled; ``Panel.area`` is where its render (or map) lies inside
it, and ``assemble`` sets ``Panel.box``, where that area landed on the sheet."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw

from .layout import (BACKGROUND, DEFAULT_COLUMN_AXIS_TITLE, DEFAULT_ROW_AXIS_TITLE, Cell, compose_chart,
                     page_colour, render_area_offset, text_colour)
from .text import draw_text, drawable_text, load_font, text_length, wrap_text

TITLE_COLOR = (240, 240, 240, 255)
TEXT_COLOR = (215, 215, 215, 255)
CELL_TEXT = (255, 255, 255, 255)
CELL_OUTLINE = (0, 0, 0, 255)


def _inks(page_srgb: Sequence[float] | None) -> tuple[tuple, tuple, tuple]:
    """(ground, title colour, text colour) of a sheet on the dark ground or on a page colour."""
    if page_srgb is None:
        return BACKGROUND, TITLE_COLOR, TEXT_COLOR
    return page_colour(page_srgb), text_colour("title", page_srgb), text_colour("label", page_srgb)


@dataclass(frozen=True)
class Box:
    """A rectangle in sheet pixels (origin top-left)."""
    x: int
    y: int
    w: int
    h: int

    def crop(self, image: np.ndarray) -> np.ndarray:
        return image[self.y:self.y + self.h, self.x:self.x + self.w]


@dataclass
class Panel:
    label: str
    image: np.ndarray                   # the panel as pasted: render (or FLIP map) plus its labels
    area: Box                           # render / FLIP map inside ``image``
    spec_index: int | None              # into the sheet's specs; None for a difference panel
    box: Box | None = None              # render / FLIP map in sheet coordinates, once placed


@dataclass(frozen=True)
class CellValue:
    """One number printed on a panel's cell (e.g. a sphere's mean FLIP), at (x, y) in the sheet."""
    row: int
    col: int
    value: float
    text: str
    x: float
    y: float


@dataclass(frozen=True)
class Axes:
    """What a chart's axis labels need: the projected spheres and the values of each column
    and row (``row_names``: material presets beside the row values)."""
    cells: Sequence[Cell]
    column_values: Sequence[float]
    row_values: Sequence[float]
    row_names: Sequence[str] | None = None
    column_axis_title: str = DEFAULT_COLUMN_AXIS_TITLE
    row_axis_title: str = DEFAULT_ROW_AXIS_TITLE


def flatten(rgba: np.ndarray, background=BACKGROUND) -> np.ndarray:
    """RGBA over an opaque background (a no-op copy for opaque images)."""
    rgba = np.asarray(rgba, np.uint8)
    if rgba[..., 3].min() == 255:
        return rgba.copy()
    a = rgba[..., 3:4].astype(np.float32) / 255.0
    bg = np.asarray(background[:3], np.float32)
    rgb = rgba[..., :3].astype(np.float32) * a + bg * (1.0 - a)   # display values, straight alpha
    out = np.empty_like(rgba)
    out[..., :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    out[..., 3] = 255
    return out


def sheet_text_size(panel_height: int) -> int:
    """Sheet text grows with the panels but stays readable on small contact sheets."""
    return max(14, min(22, round(panel_height / 40)))


def line_height(font) -> int:
    ascent, descent = font.getmetrics()
    return ascent + descent + 2


def panel(label: str, image: np.ndarray, text_size: int, *, axes: Axes | None = None,
          offset: tuple[int, int] = (0, 0), area_size: tuple[int, int] | None = None,
          spec_index: int | None = None, page_srgb: Sequence[float] | None = None) -> Panel:
    """``image`` with a label above; with ``axes`` also the column / row values, laid out by
    layout.compose_chart exactly as on a chart. ``offset``/``area_size``: where the render (or
    map) sits inside ``image`` when the image has more than the render (a colour bar).
    ``page_srgb``: the sheet's page colour (module docstring)."""
    h, w = image.shape[:2]
    aw, ah = area_size or (w, h)
    ox, oy = offset
    if axes is not None:
        cells = [Cell(c.row, c.col, c.cx + ox, c.cy + oy, c.radius_px) for c in axes.cells]
        names = list(axes.row_names) if axes.row_names else None
        rows = axes.row_values
        titles = dict(column_axis_title=axes.column_axis_title, row_axis_title=axes.row_axis_title)
        out = compose_chart(image, cells, axes.column_values, rows, label, "", row_names=names,
                            page_srgb=page_srgb, **titles)
        x0, y0 = render_area_offset(image.shape, len(rows), len(axes.column_values), label, "",
                                    row_values=rows, row_names=names, **titles)
        return Panel(label, out, Box(x0 + ox, y0 + oy, aw, ah), spec_index)
    font = load_font(text_size)
    pad = max(4, text_size // 3)
    text = drawable_text(label, font)
    width = max(w, math.ceil(text_length(font, text)) + 2 * pad)
    header = line_height(font) + pad
    ground, title_ink, _ = _inks(page_srgb)
    out = Image.new("RGBA", (width, header + h), ground)
    draw_text(ImageDraw.Draw(out), (width / 2, pad + font.getmetrics()[0]), text, font, title_ink, anchor="ms")
    arr = np.array(out)
    x0 = (width - w) // 2
    arr[header:, x0:x0 + w] = image
    return Panel(label, arr, Box(x0 + ox, header + oy, aw, ah), spec_index)


# ---------------------------------------------------------------------------------------------
# Numbers on cells.

def number_style(values: Sequence[float], radius_px: float) -> tuple[int, int] | None:
    """(format index, font size) with which every value fits inside the smallest sphere; None
    if none does. One style per panel, so numbers of neighbouring spheres read alike."""
    for size in range(int(max(9, min(28, round(0.42 * radius_px)))), 8, -1):
        font = load_font(size)
        for style in range(3):
            if all(font.getlength(number_text(v, style)) + 2 <= 1.8 * radius_px for v in values):
                return style, size
    return None


def number_text(value: float, style: int) -> str:
    """style 0: 0.123, 1: 0.12, 2: .12 (no leading zero, for small spheres)."""
    if style < 2:
        return f"{value:.{3 - style}f}"
    text = f"{value:.2f}"
    return text[1:] if text.startswith("0") else text


def print_numbers(sheet: Image.Image, box: Box, cells: Sequence[Cell], values: Sequence[float],
                  style: tuple[int, int]) -> list[CellValue]:
    """Each value centred on its cell (cell coordinates inside ``box``), white with a black
    outline; returns what was printed where."""
    number_format, size = style
    font, draw = load_font(size), ImageDraw.Draw(sheet)
    printed = []
    for cell, value in zip(cells, values):
        text = number_text(value, number_format)
        x, y = box.x + cell.cx, box.y + cell.cy
        draw.text((x, y), text, font=font, fill=CELL_TEXT, anchor="mm",
                  stroke_width=max(1, size // 9), stroke_fill=CELL_OUTLINE)
        printed.append(CellValue(cell.row, cell.col, float(value), text, x, y))
    return printed


# ---------------------------------------------------------------------------------------------
# Assembly.

def assemble(grid: Sequence[Sequence[Panel | None]], *, title: str, caption: str, text_size: int,
             notes: Sequence[tuple[str, str]] | None = None,
             page_srgb: Sequence[float] | None = None) -> Image.Image:
    """Place panels in a grid (render areas of one row top-aligned, each centred in its column),
    with an optional notes column at the right (heading + wrapped text per row),
    a title above and a wrapped caption below, on the page ``page_srgb`` (module docstring).
    Sets each panel's ``box``."""
    ground, title_ink, text_ink = _inks(page_srgb)
    title_font, head_font = load_font(round(text_size * 1.3)), load_font(round(text_size * 1.1))
    text_font = load_font(text_size)
    pad, gap = text_size, max(8, text_size // 2)
    n_cols = max(len(r) for r in grid)
    col_w = [max((r[j].image.shape[1] for r in grid if j < len(r) and r[j] is not None), default=0)
             for j in range(n_cols)]
    panels_w = sum(col_w) + gap * (n_cols - 1)
    notes_w = text_size * 30 if notes else 0
    content_w = max(panels_w + (gap * 2 + notes_w if notes else 0), text_size * 32)
    width = content_w + 2 * pad

    # Rows: align the tops of the render areas, so labels of different heights sit above.
    row_tops, row_h, note_lines = [], [], []
    for i, row in enumerate(grid):
        placed = [p for p in row if p is not None]
        top = max(p.area.y for p in placed)
        h = max(top - p.area.y + p.image.shape[0] for p in placed)
        lines = []
        if notes:
            heading, body = notes[i]
            lines = [(head_font, title_ink, line) for line in wrap_text(heading, head_font, notes_w)]
            lines += [(text_font, text_ink, line) for line in wrap_text(body, text_font, notes_w)]
            h = max(h, sum(line_height(f) for f, _, _ in lines) + pad)
        row_tops.append(top)
        row_h.append(h)
        note_lines.append(lines)

    title_lines = wrap_text(title, title_font, content_w) if title else []
    caption_lines = wrap_text(caption, text_font, content_w) if caption else []
    y = pad
    title_h = sum(line_height(title_font) for _ in title_lines) + (gap if title_lines else 0)
    body_h = sum(row_h) + gap * (len(grid) - 1)
    caption_h = (gap + len(caption_lines) * line_height(text_font)) if caption_lines else 0
    height = pad + title_h + body_h + caption_h + pad

    sheet = Image.new("RGBA", (width, height), ground)
    draw = ImageDraw.Draw(sheet)
    x_panels = pad + (content_w - panels_w - (gap * 2 + notes_w if notes else 0)) // 2
    col_x = [x_panels + sum(col_w[:j]) + gap * j for j in range(n_cols)]
    y = _draw_lines(draw, title_lines, title_font, width / 2, y, title_ink, "ms")
    y += gap if title_lines else 0
    canvas = np.array(sheet)
    for i, row in enumerate(grid):
        for j, p in enumerate(row):
            if p is None:
                continue
            ph, pw = p.image.shape[:2]
            px = col_x[j] + (col_w[j] - pw) // 2
            py = y + row_tops[i] - p.area.y
            canvas[py:py + ph, px:px + pw] = p.image
            p.box = Box(px + p.area.x, py + p.area.y, p.area.w, p.area.h)
        y += row_h[i] + gap
    sheet = Image.fromarray(canvas, "RGBA")
    draw = ImageDraw.Draw(sheet)
    y = pad + title_h
    for i in range(len(grid)):
        ny, nx = y, x_panels + panels_w + gap * 2
        for font, color, line in note_lines[i]:
            draw_text(draw, (nx, ny + font.getmetrics()[0]), line, font, color, anchor="ls")
            ny += line_height(font)
        y += row_h[i] + gap
    _draw_lines(draw, caption_lines, text_font, pad, pad + title_h + body_h + gap, text_ink, "ls")
    return sheet


def _draw_lines(draw, lines: Sequence[str], font, x: float, y: float, color, anchor: str) -> float:
    """Lines of text one under the other from ``y`` (their top), at ``x`` by ``anchor`` ("ms":
    centred, "ls": left); returns the y below the last."""
    for line in lines:
        draw_text(draw, (x, y + font.getmetrics()[0]), line, font, color, anchor=anchor)
        y += line_height(font)
    return y

