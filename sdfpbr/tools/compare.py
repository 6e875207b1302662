"""Comparison sheets: two renders and their FLIP difference, bug demos, contact sheets, sweeps.

A sheet is a grid of panels. Each panel is a render made at panel size and pasted unresampled
(the difference panel is the per-pixel FLIP map, pixel-aligned with the renders); all text
lives in bands around the panels, except the mean FLIP per sphere printed on each sphere of a
difference panel. FLIP is LDR-FLIP of the unlabeled display images, so it measures what a
viewer sees, tone mapping and encoding included.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from PIL import Image, ImageDraw

from .. import __version__
from ..shading.camera import sphere_centers
from ..errors import SpecError
from ..image.io import check_writable, png_bytes, write_png
from ..image.layout import Cell, _drawable, _load_font, compose_chart, render_area_offset
from ..spec.chart_spec import (BRDF_MODELS, CAMERAS, ENV_PRESETS, QUALITY_PRESETS, SPEC_KEYS, TONEMAPPERS, ChartSpec,
                   load_spec, make_spec, parse_color, parse_range)

__all__ = ["Sheet", "Panel", "Box", "Difference", "CellValue", "compare_specs", "compare_bug",
           "bug_contact_sheet", "sweep", "sweep_defaults", "parse_sweep_values", "bug_pair",
           "spec_differences", "at_panel_size", "flatten"]

BACKGROUND = (24, 24, 24, 255)          # as layout.py's chart background
_TITLE_COLOR = (240, 240, 240, 255)
_TEXT_COLOR = (215, 215, 215, 255)
_CELL_TEXT = (255, 255, 255, 255)
_CELL_OUTLINE = (0, 0, 0, 255)


# ---------------------------------------------------------------------------------------------
# Results.

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
    spec_index: int | None              # into Sheet.specs; None for a difference panel
    box: Box | None = None              # render / FLIP map in sheet coordinates, once placed


@dataclass(frozen=True)
class CellValue:
    """One number printed on a difference panel: the mean FLIP of a sphere, at (x, y) in the sheet."""
    row: int
    col: int
    value: float
    text: str
    x: float
    y: float


@dataclass
class Difference:
    test_label: str
    reference_label: str
    mean: float                         # mean LDR-FLIP over the whole image
    error_map: np.ndarray               # (H, W) float32 in [0, 1]
    per_cell: np.ndarray                # (rows, cols) mean FLIP per sphere (NaN: sphere not visible)
    panel: Panel
    number_style: tuple[int, int] | None = None   # (format, font size) of the printed numbers; None: too small
    cells: list[CellValue] = field(default_factory=list)   # the numbers printed, once placed


@dataclass
class Sheet:
    image: np.ndarray                   # (H, W, 4) uint8 sRGB
    caption: str
    specs: list[ChartSpec]              # every spec rendered, in order
    title: str = ""
    kind: str = "sheet"
    panels: list[Panel] = field(default_factory=list)
    differences: list[Difference] = field(default_factory=list)
    shader_digests: list[tuple[str, str]] = field(default_factory=list)   # (chart, display) per spec
    renderer: str = ""

    def metadata(self) -> dict[str, str]:
        meta = {"Software": f"sdfpbr {__version__}", "Title": self.title, "Description": self.caption,
                "sdfpbr:sheet": self.kind, "sdfpbr:gl-renderer": self.renderer,
                "sdfpbr:panels": json.dumps([p.label for p in self.panels])}
        for i, spec in enumerate(self.specs):
            meta[f"sdfpbr:spec:{i}"] = json.dumps(spec.to_dict(), sort_keys=True)
            chart_digest, display_digest = self.shader_digests[i]
            meta[f"sdfpbr:shader-sha256:{i}"] = chart_digest
            meta[f"sdfpbr:display-shader-sha256:{i}"] = display_digest
        for i, d in enumerate(self.differences):
            meta[f"sdfpbr:flip-mean:{i}"] = f"{d.test_label} vs {d.reference_label}: {d.mean:.6f}"
        return meta

    def save(self, path: str | Path) -> None:
        check_writable(path, (".png",), "output")
        write_png(path, self.image, self.metadata())

    def summary(self) -> str:
        """Mean and per-sphere FLIP of every difference, as text (the CLI's -v)."""
        lines = []
        for d in self.differences:
            lines.append(f"{d.test_label} vs {d.reference_label}: mean FLIP {d.mean:.4f}")
            for r, row in enumerate(d.per_cell):
                cells = " ".join("   -  " if not np.isfinite(v) else f"{v:.4f}" for v in row)
                lines.append(f"  row {r}: {cells}")
        return "\n".join(lines)

    def _repr_png_(self) -> bytes:
        return png_bytes(self.image)


# ---------------------------------------------------------------------------------------------
# Rendering.

@dataclass
class _Rendered:
    spec: ChartSpec
    result: Any                         # render.RenderResult
    renderer: str

    @property
    def display(self) -> np.ndarray:
        """The unlabeled display image, flattened onto the sheet background."""
        return flatten(self.result.image)


def _render(spec: ChartSpec, aovs: bool = False) -> _Rendered:
    """Render on the process's renderer; AOVs (sphere row / col) only where cells are measured."""
    from ..api import get_renderer
    from ..gpu.gl import renderer_string
    renderer = get_renderer(spec.backend, spec.device_index)
    return _Rendered(spec, renderer.render(spec, aovs=aovs), renderer_string(renderer.ctx))


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


def _as_spec(spec: ChartSpec | str | Path | None, what: str) -> ChartSpec:
    if spec is None:
        return ChartSpec()
    if isinstance(spec, (str, Path)):
        return load_spec(spec)
    if not isinstance(spec, ChartSpec):
        raise SpecError(f"{what} must be a ChartSpec or a TOML path, got {type(spec).__name__}")
    return spec


def at_panel_size(spec: ChartSpec, panel_size: int | None) -> ChartSpec:
    """The spec rendered so that its longer edge is ``panel_size`` px (aspect kept)."""
    if panel_size is None:
        return spec
    if isinstance(panel_size, bool) or not isinstance(panel_size, int) or not 16 <= panel_size <= 8192:
        raise SpecError(f"panel size must be a whole number of pixels in [16, 8192], got {panel_size!r}")
    scale = panel_size / max(spec.width, spec.height)
    return make_spec(spec, width=max(1, round(spec.width * scale)), height=max(1, round(spec.height * scale)))


def _digests(spec: ChartSpec, result) -> tuple[str, str]:
    from ..gpu.render import display_source
    return result.chart_source.digest, display_source(spec).digest


# ---------------------------------------------------------------------------------------------
# Text.

def _font(size: int):
    return _load_font(int(size))


def _text_size(panel_height: int) -> int:
    """Sheet text grows with the panels but stays readable on small contact sheets."""
    return max(14, min(22, round(panel_height / 40)))


def _wrap(text: str, font, width: float) -> list[str]:
    """Greedy word wrap; explicit newlines start new paragraphs."""
    lines: list[str] = []
    for paragraph in _drawable(text, font).split("\n"):
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


def _line_height(font) -> int:
    ascent, descent = font.getmetrics()
    return ascent + descent + 2


# ---------------------------------------------------------------------------------------------
# Panels.

def _cells(spec: ChartSpec, camera) -> list[Cell]:
    """Projected sphere centres, as chart.label places its labels."""
    px, scale = camera.project(sphere_centers(spec).reshape(-1, 3))
    return [Cell(i // spec.cols, i % spec.cols, float(x), float(y), float(spec.sphere_radius * s))
            for i, ((x, y), s) in enumerate(zip(px, scale))]


def _panel(label: str, image: np.ndarray, spec: ChartSpec, camera, axes: bool, text_size: int,
           offset: tuple[int, int] = (0, 0), area_size: tuple[int, int] | None = None,
           spec_index: int | None = None) -> Panel:
    """``image`` with a label above; with ``axes`` also the roughness / metallic values, laid out
    by layout.compose_chart exactly as on a chart. ``offset``/``area_size``: where the render (or
    FLIP map) sits inside ``image`` when the image has more than the render (a colour bar)."""
    h, w = image.shape[:2]
    aw, ah = area_size or (w, h)
    ox, oy = offset
    if axes:
        cells = [Cell(c.row, c.col, c.cx + ox, c.cy + oy, c.radius_px) for c in _cells(spec, camera)]
        names = list(spec.row_materials) or None
        rows = spec.row_metallic()
        out = compose_chart(image, cells, spec.column_roughness(), rows, label, "", row_names=names)
        x0, y0 = render_area_offset(image.shape, spec.rows, spec.cols, label, "", row_values=rows, row_names=names)
        return Panel(label, out, Box(x0 + ox, y0 + oy, aw, ah), spec_index)
    font = _font(text_size)
    pad = max(4, text_size // 3)
    text = _drawable(label, font)
    width = max(w, math.ceil(font.getlength(text)) + 2 * pad)
    header = _line_height(font) + pad
    out = Image.new("RGBA", (width, header + h), BACKGROUND)
    ImageDraw.Draw(out).text((width / 2, pad + font.getmetrics()[0]), text, font=font, fill=_TITLE_COLOR,
                             anchor="ms")
    arr = np.array(out)
    x0 = (width - w) // 2
    arr[header:, x0:x0 + w] = image
    return Panel(label, arr, Box(x0 + ox, header + oy, aw, ah), spec_index)


def _heatmap(error_map: np.ndarray) -> tuple[np.ndarray, tuple[int, int]]:
    """metrics.heatmap_image of the map and where the map's pixels lie inside it."""
    from ..image.metrics import apply_colormap, heatmap_image
    image = heatmap_image(error_map, vmin=0.0, vmax=1.0)
    x, y = _locate(image, apply_colormap(error_map))
    # Trim the plain margin above and left of the map, so the panel's label sits as close to
    # the map as the other panels' labels sit to their renders.
    plain = np.all(image == image[0, 0], axis=-1)
    top = int(np.argmin(plain[:y].all(axis=1))) if y and not plain[:y].all() else y
    left = int(np.argmin(plain[:, :x].all(axis=0))) if x and not plain[:, :x].all() else x
    return image[top:, left:], (x - left, y - top)


def _locate(image: np.ndarray, patch: np.ndarray) -> tuple[int, int]:
    """(x, y) of ``patch`` (RGB) inside ``image``: the heat map's layout is the metrics module's
    business, so find the map's exact pixels instead of repeating its margins here."""
    H, W = patch.shape[:2]
    rgb = image[..., :3]
    ys, xs = np.nonzero(np.all(rgb[:rgb.shape[0] - H + 1, :rgb.shape[1] - W + 1] == patch[0, 0], axis=-1))
    for y, x in zip(ys, xs):   # the first row rules out most candidates cheaply
        if np.array_equal(rgb[y, x:x + W], patch[0]) and np.array_equal(rgb[y:y + H, x:x + W], patch):
            return int(x), int(y)
    raise RuntimeError("heat map image does not contain the error map unscaled")


def _difference(reference: _Rendered, test: _Rendered, reference_label: str, test_label: str,
                axes: bool, text_size: int) -> Difference:
    from ..image.metrics import flip_ldr, per_cell_mean
    spec = reference.spec
    mean, error_map = flip_ldr(test.display, reference.display)
    aov = reference.result.aov
    per_cell = per_cell_mean(error_map, aov["row"], aov["col"], spec.rows, spec.cols)
    heat, offset = _heatmap(error_map)
    label = f"FLIP difference, mean {mean:.3f}"
    camera = reference.result.camera
    panel = _panel(label, heat, spec, camera, axes, text_size, offset, (spec.width, spec.height))
    cells = _numbered_cells(per_cell, spec, camera)
    style = _cell_style([float(per_cell[c.row, c.col]) for c in cells], min(c.radius_px for c in cells)) \
        if cells else None
    return Difference(test_label, reference_label, mean, error_map, per_cell, panel, style)


def _numbered_cells(per_cell: np.ndarray, spec: ChartSpec, camera) -> list[Cell]:
    """Spheres with a mean (some pixel visible) whose centre lies inside the render."""
    return [c for c in _cells(spec, camera)
            if math.isfinite(per_cell[c.row, c.col]) and 0 <= c.cx < spec.width and 0 <= c.cy < spec.height]


def _cell_style(values: Sequence[float], radius_px: float) -> tuple[int, int] | None:
    """(format index, font size) with which every value fits inside the smallest sphere; None
    if none does. One style per panel, so numbers of neighbouring spheres read alike."""
    for size in range(int(max(9, min(28, round(0.42 * radius_px)))), 8, -1):
        font = _font(size)
        for style in range(3):
            if all(font.getlength(_cell_number(v, style)) + 2 <= 1.8 * radius_px for v in values):
                return style, size
    return None


def _cell_number(value: float, style: int) -> str:
    """style 0: 0.123, 1: 0.12, 2: .12 (no leading zero, for small spheres)."""
    if style < 2:
        return f"{value:.{3 - style}f}"
    text = f"{value:.2f}"
    return text[1:] if text.startswith("0") else text


def _print_cells(sheet: Image.Image, d: Difference, spec: ChartSpec, camera) -> None:
    """Each visible sphere's mean FLIP, centred on the sphere, white with a black outline."""
    if d.number_style is None:
        return
    box = d.panel.box
    number_style, size = d.number_style
    font, draw = _font(size), ImageDraw.Draw(sheet)
    for cell in _numbered_cells(d.per_cell, spec, camera):
        value = float(d.per_cell[cell.row, cell.col])
        text = _cell_number(value, number_style)
        x, y = box.x + cell.cx, box.y + cell.cy
        draw.text((x, y), text, font=font, fill=_CELL_TEXT, anchor="mm",
                  stroke_width=max(1, size // 9), stroke_fill=_CELL_OUTLINE)
        d.cells.append(CellValue(cell.row, cell.col, value, text, x, y))


# ---------------------------------------------------------------------------------------------
# Assembly.

def _assemble(grid: Sequence[Sequence[Panel | None]], *, title: str, caption: str, text_size: int,
              notes: Sequence[tuple[str, str]] | None = None) -> Image.Image:
    """Place panels in a grid (render areas of one row top-aligned, each centred in its column),
    with an optional notes column at the right (heading + wrapped text per row),
    a title above and a wrapped caption below. Sets each panel's ``box``."""
    title_font, text_font, head_font = _font(round(text_size * 1.3)), _font(text_size), _font(round(text_size * 1.1))
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
            lines = [(head_font, _TITLE_COLOR, line) for line in _wrap(heading, head_font, notes_w)]
            lines += [(text_font, _TEXT_COLOR, line) for line in _wrap(body, text_font, notes_w)]
            h = max(h, sum(_line_height(f) for f, _, _ in lines) + pad)
        row_tops.append(top)
        row_h.append(h)
        note_lines.append(lines)

    title_lines = _wrap(title, title_font, content_w) if title else []
    caption_lines = _wrap(caption, text_font, content_w) if caption else []
    y = pad
    title_h = sum(_line_height(title_font) for _ in title_lines) + (gap if title_lines else 0)
    body_h = sum(row_h) + gap * (len(grid) - 1)
    caption_h = (gap + len(caption_lines) * _line_height(text_font)) if caption_lines else 0
    height = pad + title_h + body_h + caption_h + pad

    sheet = Image.new("RGBA", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    x_panels = pad + (content_w - panels_w - (gap * 2 + notes_w if notes else 0)) // 2
    col_x = [x_panels + sum(col_w[:j]) + gap * j for j in range(n_cols)]
    for line in title_lines:
        draw.text((width / 2, y + title_font.getmetrics()[0]), line, font=title_font, fill=_TITLE_COLOR, anchor="ms")
        y += _line_height(title_font)
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
            draw.text((nx, ny + font.getmetrics()[0]), line, font=font, fill=color, anchor="ls")
            ny += _line_height(font)
        y += row_h[i] + gap
    y = pad + title_h + body_h + gap
    for line in caption_lines:
        draw.text((pad, y + text_font.getmetrics()[0]), line, font=text_font, fill=_TEXT_COLOR, anchor="ls")
        y += _line_height(text_font)
    return sheet


def _sheet_renderer(rendered: Sequence[_Rendered]) -> str:
    return " | ".join(dict.fromkeys(r.renderer for r in rendered))


def _comparison(reference: _Rendered, test: _Rendered, labels: tuple[str, str], *, title: str,
                caption: str, axes: bool | None, kind: str) -> Sheet:
    """reference | test | FLIP of test against reference, one row, captioned."""
    spec = reference.spec
    axes = spec.labels if axes is None else axes
    text_size = _text_size(spec.height)
    panels = [_panel(labels[0], reference.display, spec, reference.result.camera, axes, text_size, spec_index=0),
              _panel(labels[1], test.display, test.spec, test.result.camera, axes, text_size, spec_index=1)]
    diff = _difference(reference, test, labels[0], labels[1], axes, text_size)
    panels.append(diff.panel)
    caption = f"{caption}\n" if caption else ""
    caption += (f"Right: LDR-FLIP of {labels[1]} against {labels[0]} (0 = identical, 1 = maximal), "
                f"mean {diff.mean:.4f}" + ("; the number on each sphere is that sphere's mean."
                                           if diff.number_style else "."))
    image = _assemble([panels], title=title, caption=caption, text_size=text_size)
    _print_cells(image, diff, spec, reference.result.camera)
    return Sheet(np.array(image), caption, [reference.spec, test.spec], title, kind, panels, [diff],
                 [_digests(r.spec, r.result) for r in (reference, test)], _sheet_renderer([reference, test]))


def _check_comparable(a: ChartSpec, b: ChartSpec) -> None:
    if (a.width, a.height) != (b.width, b.height):
        raise SpecError(f"cannot compare a {a.width}x{a.height} render with a {b.width}x{b.height} one; "
                        f"give both specs the same size")


def spec_differences(a: ChartSpec, b: ChartSpec) -> list[str]:
    """'name: a -> b' for every field that differs (lights summarised)."""
    out = []
    da, db = a.to_dict(), b.to_dict()
    for name in SPEC_KEYS:
        if da[name] != db[name]:
            va, vb = ((f"{len(v)} lights" if name == "lights" else _value_text(v)) for v in (da[name], db[name]))
            out.append(f"{name} {va} -> {vb}" if name != "lights" or va != vb else "lights changed")
    return out


def _value_text(v) -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return ",".join(_value_text(x) for x in v) or "none"
    return str(v) if v != "" else '""'


def compare_specs(a: ChartSpec | str | Path, b: ChartSpec | str | Path, labels: tuple[str, str] = ("A", "B"),
                  caption: str = "", *, title: str | None = None, axes: bool | None = None) -> Sheet:
    """A | B | FLIP difference of B against A, with the mean FLIP printed on each sphere.

    ``a``/``b``: ChartSpecs or TOML paths, rendered at their own (equal) size. ``caption`` goes
    under the panels; left empty, it lists the fields in which the specs differ. ``axes``:
    roughness / metallic labels on the panels (default: ``a.labels``)."""
    a, b = _as_spec(a, "spec A"), _as_spec(b, "spec B")
    if len(labels) != 2 or not all(isinstance(s, str) for s in labels):
        raise SpecError(f"labels must be two strings, got {labels!r}")
    _check_comparable(a, b)
    if not caption:
        diffs = spec_differences(a, b)
        caption = (f"{labels[1]} differs from {labels[0]} in: {'; '.join(diffs)}." if diffs
                   else f"{labels[0]} and {labels[1]} are the same spec.")
    ra, rb = _render(a, aovs=True), _render(b)
    return _comparison(ra, rb, (labels[0], labels[1]), title=title or f"{labels[0]} vs {labels[1]}",
                       caption=caption, axes=axes, kind="compare")


def bug_pair(spec: ChartSpec, bug_name: str) -> tuple[Any, ChartSpec, ChartSpec]:
    """(bug, correct spec, buggy spec): the correct one has what the bug needs to show (e.g.
    textures) and not the bug itself, the buggy one differs from it by the bug alone."""
    from ..spec.bugs import get_bug
    bug = get_bug(bug_name)
    correct = bug.correct(spec) if hasattr(bug, "correct") else spec
    if bug.name in correct.bugs:
        correct = make_spec(correct, bugs=tuple(n for n in correct.bugs if n != bug.name))
    return bug, correct, bug.apply(correct)


def compare_bug(spec: ChartSpec | str | Path | None, bug_name: str, *, axes: bool | None = None,
                panel_size: int | None = None) -> Sheet:
    """correct | buggy | FLIP difference for one catalog bug, titled with its name and summary
    and captioned with what goes wrong, why, and the fix. ``panel_size``: render so the longer
    edge is this many pixels (default: the spec's size)."""
    spec = at_panel_size(_as_spec(spec, "spec"), panel_size)
    bug, correct, buggy = bug_pair(spec, bug_name)
    rc, rb = _render(correct, aovs=True), _render(buggy)
    return _comparison(rc, rb, ("correct", f"buggy: {bug.name}"), title=f"{bug.name}: {bug.summary}",
                       caption=bug.caption, axes=axes, kind="bug")


def bug_contact_sheet(spec: ChartSpec | str | Path | None = None, names: Sequence[str] | None = None, *,
                      panel_size: int = 192) -> Sheet:
    """The bug catalog (or ``names`` from it) as one sheet: a row per bug with correct | buggy |
    FLIP difference at ``panel_size`` px and the bug's name, summary, caption and mean FLIP."""
    from ..spec.bugs import BUGS, get_bug
    spec = at_panel_size(_as_spec(spec, "spec"), panel_size)
    names = list(BUGS) if names is None else [get_bug(n).name for n in names]   # all checked first
    if not names:
        raise SpecError(f"no bugs named; allowed: {', '.join(BUGS)}")
    pairs = [bug_pair(spec, n) for n in names]
    text_size = _text_size(spec.height)
    rendered: dict[ChartSpec, _Rendered] = {}     # the correct chart is shared by most bugs
    specs: list[ChartSpec] = []

    def render(s: ChartSpec, aovs: bool) -> tuple[_Rendered, int]:
        if s not in rendered:
            rendered[s] = _render(s, aovs)
            specs.append(s)
        return rendered[s], specs.index(s)

    grid, notes, diffs, panels = [], [], [], []
    for bug, correct, buggy in pairs:
        (rc, ic), (rb, ib) = render(correct, True), render(buggy, False)
        d = _difference(rc, rb, "correct", f"buggy: {bug.name}", False, text_size)
        row = [_panel("correct", rc.display, correct, rc.result.camera, False, text_size, spec_index=ic),
               _panel(f"buggy: {bug.name}", rb.display, buggy, rb.result.camera, False, text_size, spec_index=ib),
               d.panel]
        grid.append(row)
        panels += row
        diffs.append(d)
        notes.append((bug.name, f"{bug.summary[:1].upper()}{bug.summary[1:]}. {bug.caption}\nMean FLIP {d.mean:.3f}"))
    title = f"PBR bug catalog: {len(names)} bugs"
    caption = ("Each row: the correct chart, the same chart with one bug switched on, and the LDR-FLIP "
               "difference (0 = identical, 1 = maximal)"
               + (" with each sphere's mean printed on it." if any(d.number_style for d in diffs) else "."))
    image = _assemble(grid, title=title, caption=caption, text_size=text_size, notes=notes)
    for d, (_, correct, _) in zip(diffs, pairs):
        _print_cells(image, d, correct, rendered[correct].result.camera)
    ordered = [rendered[s] for s in specs]
    return Sheet(np.array(image), caption, specs, title, "bugs", panels, diffs,
                 [_digests(r.spec, r.result) for r in ordered], _sheet_renderer(ordered))


# ---------------------------------------------------------------------------------------------
# Sweeps.

_SWEEP_DEFAULTS: dict[str, tuple] = {
    "tonemap": TONEMAPPERS,
    "exposure": (-2.0, -1.0, 0.0, 1.0, 2.0),
    "env": ENV_PRESETS,
    "brdf": BRDF_MODELS,
    "camera": CAMERAS,
    "quality": tuple(QUALITY_PRESETS),
    "multiscatter": (True, False),
    "camera_azimuth": (0.0, 30.0, 60.0, 90.0),
}
# The footer part (chart.footer_text) that names a field, left out of a sweep's caption.
_FOOTER_PART = {"tonemap": "tone map", "exposure": "exposure", "env": "env", "brdf": "BRDF",
                "multiscatter": "BRDF", "spp": "spp"}


def _field_name(name: str) -> str:
    field_name = name.replace("-", "_")
    if field_name not in SPEC_KEYS:
        import difflib
        close = difflib.get_close_matches(field_name, SPEC_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise SpecError(f"cannot sweep {name!r}: not a spec field{hint}; e.g. {', '.join(_SWEEP_DEFAULTS)}")
    return field_name


def sweep_defaults(name: str) -> tuple:
    """The values a sweep over ``name`` uses when none are given."""
    field_name = _field_name(name)
    if field_name not in _SWEEP_DEFAULTS:
        raise SpecError(f"sweeping {name} needs values (--values); fields with defaults: {', '.join(_SWEEP_DEFAULTS)}")
    return _SWEEP_DEFAULTS[field_name]


def parse_sweep_values(name: str, text: str) -> list:
    """Command-line values for a sweep: comma separated (semicolons when a value is a vector
    such as base_color "1,0,0;0,1,0"); items of a list field joined with '+'."""
    field_name = _field_name(name)
    default = next(f.default for f in fields(ChartSpec) if f.name == field_name)
    sep = ";" if ";" in text or field_name in ("base_color", "ground_color") else ","
    items = [t.strip() for t in str(text).split(sep)]
    if not text.strip() or not all(items):
        raise SpecError(f"--values must list values separated by '{sep}', got {text!r}")
    out = []
    for item in items:
        if isinstance(default, bool):
            if item.lower() not in ("true", "false", "on", "off", "yes", "no", "1", "0"):
                raise SpecError(f"{field_name} values must be true or false, got {item!r}")
            out.append(item.lower() in ("true", "on", "yes", "1"))
        elif isinstance(default, (int, float)):
            try:
                out.append(int(item) if isinstance(default, int) else float(item))
            except ValueError:
                kind = "whole numbers" if isinstance(default, int) else "numbers"
                raise SpecError(f"{field_name} values must be {kind}, got {item!r}") from None
        elif field_name in ("roughness", "metallic"):
            out.append(parse_range(item, field_name))
        elif field_name in ("base_color", "ground_color"):
            out.append(parse_color(item))
        elif field_name == "lights":
            out.append(item)
        elif isinstance(default, tuple):
            out.append(tuple(s.strip() for s in item.split("+") if s.strip()))
        else:
            out.append(item)
    return out


def _sweep_label(field_name: str, value) -> str:
    if field_name == "exposure":
        return f"exposure {value:+g} EV"
    if field_name in ("camera_azimuth", "camera_elevation"):
        return f"{field_name.replace('_', ' ')} {value:g} deg"
    if field_name == "env" and isinstance(value, str) and len(value) > 24:
        return f"env ...{value[-21:]}"
    return f"{field_name} {_value_text(value)}"


def sweep(spec: ChartSpec | str | Path | None, name: str, values: Sequence | None = None, *,
          columns: int | None = None, panel_size: int | None = None, title: str | None = None,
          axes: bool | None = None) -> Sheet:
    """The same chart once per value of one spec field (tonemap, exposure, env, or any other),
    as a grid of panels, each labeled with its value. ``values`` default to sweep_defaults(name);
    ``columns`` default to at most four per row; ``panel_size`` as in compare_bug."""
    from ..api import footer_text
    base = at_panel_size(_as_spec(spec, "spec"), panel_size)
    field_name = _field_name(name)
    values = list(sweep_defaults(field_name) if values is None else values)
    if not values:
        raise SpecError(f"a sweep over {field_name} needs at least one value")
    specs = [make_spec(base, **{field_name: v}) for v in values]      # every value checked first
    if columns is None:
        columns = math.ceil(len(specs) / math.ceil(len(specs) / 4))
    if isinstance(columns, bool) or not isinstance(columns, int) or columns < 1:
        raise SpecError(f"columns must be a positive whole number, got {columns!r}")
    axes = base.labels if axes is None else axes
    text_size = _text_size(max(s.height for s in specs))
    rendered = [_render(s) for s in specs]
    panels = [_panel(_sweep_label(field_name, v), r.display, s, r.result.camera, axes, text_size, spec_index=i)
              for i, (v, s, r) in enumerate(zip(values, specs, rendered))]
    grid = [panels[i:i + columns] for i in range(0, len(panels), columns)]
    part = _FOOTER_PART.get(field_name)
    fixed = "  |  ".join(p for p in footer_text(base).split("  |  ") if not (part and p.startswith(part)))
    caption = f"The same chart across {field_name}. Everything else: {fixed}."
    title = title or f"{field_name} sweep"
    image = _assemble(grid, title=title, caption=caption, text_size=text_size)
    return Sheet(np.array(image), caption, specs, title, "sweep", panels, [],
                 [_digests(r.spec, r.result) for r in rendered], _sheet_renderer(rendered))
