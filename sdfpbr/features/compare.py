"""Comparison sheets: two renders and their FLIP difference, bug demos, contact sheets, sweeps.

A sheet is a grid of panels (laid out by ``sdfpbr.image.sheet``). Each panel is a render made at
panel size and pasted unresampled (the difference panel is the per-pixel FLIP map, pixel-aligned
with the renders); all text lives in bands around the panels, except the mean FLIP per sphere
printed on each sphere of a difference panel. FLIP is LDR-FLIP of the unlabeled display images,
so it measures what a viewer sees, tone mapping and encoding included.
"""
from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field
from dataclasses import replace as dc_replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .. import __version__
from ..errors import SpecError
from ..result_cache import ResultCache
from ..progress import Progress
from ..workers import helper_pool
from ..image.io import check_writable, png_bytes, write_png
from ..image.layout import FOOTER_SEPARATOR, Cell
from ..image.layout import label_text
from ..image.sheet import (Axes, CellValue, Panel, assemble, flatten, number_style, panel, print_numbers,
                           sheet_text_size)
from ..image.chart_labels import axis_title, chart_cells, row_names, footer_text
from ..spec.chart_spec import SPEC_KEYS, ChartSpec, as_spec, make_spec
from ..spec.bugs import BUG_MEASURE_SIZE
from ..spec.checks import text as check_text
from ..spec.presets import MAX_CAPTION, MAX_TITLE
from ..spec.fields import resolve_field, sweep_defaults
from ..shading.plan import ChartFrame, chart_frame

__all__ = ["Sheet", "Difference", "RenderedChart", "compare_specs", "compare_bug", "bug_contact_sheet", "bug_catalog",
           "catalog_pages", "sweep", "bug_pair", "spec_differences", "at_panel_size", "check_comparable",
           "render_chart", "chart_axes", "chart_panel", "sheet_page"]


# ---------------------------------------------------------------------------------------------
# Results.

@dataclass
class Difference:
    test_label: str
    reference_label: str
    mean: float                         # mean LDR-FLIP over the image but the cells' page-colour borders
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
class RenderedChart:
    spec: ChartSpec
    result: Any                         # render.RenderResult
    renderer: str

    @functools.cached_property
    def display(self) -> np.ndarray:
        """The unlabeled display image, flattened onto the sheet background: made once and
        read-only (a FLIP of the same two renders is then known by the arrays)."""
        image = flatten(self.result.image)
        image.setflags(write=False)
        return image


# Renders a process keeps by spec for the sheets: the catalog's rows and a gallery's per-bug
# pages render the same correct chart again and again (renders are deterministic). ResultCache arrays
# are read-only; the oldest go first past the budget.
KEPT_RENDER_BYTES = 96 << 20
SHEET_AOVS = ("row", "col")   # what the sheets measure cells by
_kept = ResultCache(KEPT_RENDER_BYTES, lambda r: sum(a.nbytes for a in [r.result.image, *r.result.aov.values()]))


# The radiance of kept renders that measure cells (a bug pair's correct chart): a chart that
# differs from one of them in display fields and display bugs alone (fields.same_radiance) is
# that radiance through its own display pass (gpu.render.redisplay: the same pixels), not
# drawn again: the catalog's five display bugs and gamma-2.2's darker chart. Read only where it
# fits the budget (512²: 4 MB).
KEPT_RADIANCE_BYTES = 32 << 20
_radiance = ResultCache(KEPT_RADIANCE_BYTES, lambda result: result.hdr.nbytes + result.alpha.nbytes)


def render_chart(spec: ChartSpec, aovs: bool = False, keep: bool = False) -> RenderedChart:
    """Render on the process's renderer (the one place this module reaches GL): the display
    image, and the AOVs (sphere row / col) only where cells are measured. ``keep``: take a kept
    render of the same spec (or its radiance: _radiance), and keep this one (sheets; not
    animation frames, which never repeat and would hold memory)."""
    from ..gpu.session import default_session
    from ..spec.fields import radiance_fields
    for key in ((spec, True), (spec, aovs)) if keep else ():
        kept = _kept.get(key)
        if kept is not None:
            return kept
    session = default_session(spec.backend, spec.device_index)
    radiance = radiance_fields(spec) if keep else None
    source = _radiance.get(radiance) if keep else None
    if source is not None:
        result = session.redisplay(spec, source)
        result.aov = {name: source.aov[name] for name in SHEET_AOVS} if aovs else {}   # the same geometry
    else:
        read = keep and aovs and spec.width * spec.height * 16 <= KEPT_RADIANCE_BYTES
        result = session.render(spec, aovs=aovs, hdr=read)
        for name in set(result.aov) - set(SHEET_AOVS):   # kept small: a catalog's renders fit
            del result.aov[name]
        if read:
            _radiance.put(radiance, result)
    rendered = RenderedChart(spec, dc_replace(result, hdr=None, alpha=None), session.renderer)
    if keep:
        _keep(rendered, aovs)
    return rendered


def _keep(rendered: RenderedChart, aovs: bool) -> None:
    for array in [rendered.result.image, *rendered.result.aov.values()]:
        array.setflags(write=False)
    _kept.put((rendered.spec, aovs), rendered)


def render_charts(specs: Sequence[ChartSpec], progress: Progress | None = None) -> list[RenderedChart]:
    """Each spec's render (as render_chart's); the specs that differ from the first in display
    fields or display bugs alone (a tone-map or exposure sweep) take its radiance through their
    own display pass, with the same pixels as drawing each (gpu.render.redisplay). ``progress``
    hears of each chart drawn."""
    from ..gpu.session import default_session
    from ..spec.fields import same_radiance
    progress = progress or Progress(len(specs), "", enabled=False)
    first = specs[0]
    from_first = [i > 0 and same_radiance(first, s) for i, s in enumerate(specs)]
    if not any(from_first):
        out = []
        for s in specs:
            out.append(render_chart(s))
            progress.update()
        return out
    session = default_session(first.backend, first.device_index)
    source = session.render(first, aovs=False, hdr=True)
    out = [RenderedChart(first, source, session.renderer)]
    progress.update()
    for s, shared in zip(specs[1:], from_first[1:]):
        result = session.redisplay(s, source) if shared else session.render(s, aovs=False, hdr=False)
        out.append(RenderedChart(s, result, session.renderer))
        progress.update()
    return out


def at_panel_size(spec: ChartSpec, panel_size: int | None) -> ChartSpec:
    """The spec rendered so that its longer edge is ``panel_size`` px (aspect kept)."""
    if panel_size is None:
        return spec
    if isinstance(panel_size, bool) or not isinstance(panel_size, int) or not 16 <= panel_size <= 8192:
        raise SpecError(f"panel size must be a whole number of pixels in [16, 8192], got {panel_size!r}")
    scale = panel_size / max(spec.width, spec.height)
    return make_spec(spec, width=max(1, round(spec.width * scale)), height=max(1, round(spec.height * scale)))


def _digests(spec: ChartSpec, result) -> tuple[str, str]:
    return result.chart_source.digest, result.display_source.digest


# ---------------------------------------------------------------------------------------------
# Panels.

def chart_axes(frame: ChartFrame) -> Axes:
    """The roughness / metallic labels of a chart (its frame), for a sheet panel."""
    spec = frame.spec
    return Axes(chart_cells(frame), spec.axis_values("x"), spec.axis_values("y"), row_names(spec),
                axis_title(spec, "x"), axis_title(spec, "y"))


def sheet_page(spec: ChartSpec) -> tuple[float, ...] | None:
    """The page a sheet of ``spec``'s charts lies on: the backdrop they are laid onto (sRGB
    0..1), so a dark sheet does not frame charts made for a light page; None: the dark ground."""
    return tuple(spec.backdrop) if spec.backdrop else None


def chart_panel(label: str, rendered: RenderedChart, axes: bool, text_size: int,
                spec_index: int | None = None, page_srgb: Sequence[float] | None = None) -> Panel:
    """A render's display image as a sheet panel, with the chart's axis labels when ``axes``."""
    return panel(label, rendered.display, text_size, spec_index=spec_index, page_srgb=page_srgb,
                 axes=chart_axes(rendered.result.frame) if axes else None)


def _heatmap(error_map: np.ndarray, page_srgb: Sequence[float] | None) -> tuple[np.ndarray, tuple[int, int]]:
    """metrics.heatmap of the map and where the map's pixels lie inside it."""
    from ..image.metrics import heatmap
    heat = heatmap(error_map, vmin=0.0, vmax=1.0, page_srgb=page_srgb)
    image, x, y = heat.image, heat.x, heat.y
    # Trim the plain margin above and left of the map, so the panel's label sits as close to
    # the map as the other panels' labels sit to their renders.
    plain = np.all(image == image[0, 0], axis=-1)
    top = int(np.argmin(plain[:y].all(axis=1))) if y and not plain[:y].all() else y
    left = int(np.argmin(plain[:, :x].all(axis=0))) if x and not plain[:, :x].all() else x
    return image[top:, left:], (x - left, y - top)


def _difference(reference: RenderedChart, test: RenderedChart, reference_label: str, test_label: str,
                axes: bool, text_size: int, shown: ChartSpec | None = None, short: bool = False) -> Difference:
    """FLIP of ``test`` against ``reference``, measured on the renders; its panel (map, axes and
    the numbers' cells) at the renders' size, or shrunk to ``shown``'s size (same grid), on the
    reference's page (sheet_page). ``short``: a short label, for a small panel."""
    from ..image.metrics import flip_ldr, per_cell_mean
    spec = reference.spec
    # Where both renders frame their cells in the page colour, the pixels are the same: left out
    # of the mean, a mean over the cells. Only where both do: a spec without borders (or with
    # another grid) differs from the other there.
    borders = [r.result.frame.border_mask() for r in (reference, test)]
    framed = borders[0] & borders[1]
    mean, error_map = flip_ldr(test.display, reference.display, mask=~framed if framed.any() else None)
    aov = reference.result.aov
    per_cell = per_cell_mean(error_map, aov["row"], aov["col"], spec.rows, spec.cols)
    shown = shown or spec
    size = (shown.width, shown.height)
    page = sheet_page(spec)
    heat, offset = _heatmap(error_map if shown is spec else _shrunk(error_map, size), page)
    label = f"FLIP, mean {mean:.3f}" if short else f"FLIP difference, mean {mean:.3f}"
    framed = reference.result.frame if shown is spec else chart_frame(shown)
    heat_panel = panel(label, heat, text_size, axes=chart_axes(framed) if axes else None,
                       offset=offset, area_size=size, page_srgb=page)
    cells = _numbered_cells(per_cell, framed)
    style = number_style([float(per_cell[c.row, c.col]) for c in cells], min(c.radius_px for c in cells)) \
        if cells else None
    return Difference(test_label, reference_label, mean, error_map, per_cell, heat_panel, style)


def _numbered_cells(per_cell: np.ndarray, frame: ChartFrame) -> list[Cell]:
    """Spheres with a mean (some pixel visible) whose centre lies inside the render."""
    spec = frame.spec
    return [c for c in chart_cells(frame)
            if math.isfinite(per_cell[c.row, c.col]) and 0 <= c.cx < spec.width and 0 <= c.cy < spec.height]


def _print_cells(sheet, d: Difference, frame: ChartFrame) -> None:
    """Each visible sphere's mean FLIP, centred on the sphere."""
    if d.number_style is None:
        return
    cells = _numbered_cells(d.per_cell, frame)
    d.cells += print_numbers(sheet, d.panel.box, cells, [float(d.per_cell[c.row, c.col]) for c in cells],
                             d.number_style)


# ---------------------------------------------------------------------------------------------
# Sheets.

def _sheet_renderer(rendered: Sequence[RenderedChart]) -> str:
    return " | ".join(dict.fromkeys(r.renderer for r in rendered))


def _comparison(reference: RenderedChart, test: RenderedChart, labels: tuple[str, str], *, title: str,
                caption: str, axes: bool | None, kind: str) -> Sheet:
    """reference | test | FLIP of test against reference, one row, captioned."""
    spec = reference.spec
    axes = spec.labels if axes is None else axes
    text_size = sheet_text_size(spec.height)
    page = sheet_page(spec)
    panels = [chart_panel(labels[0], reference, axes, text_size, spec_index=0, page_srgb=page),
              chart_panel(labels[1], test, axes, text_size, spec_index=1, page_srgb=page)]
    diff = _difference(reference, test, labels[0], labels[1], axes, text_size)
    panels.append(diff.panel)
    caption = f"{caption}\n" if caption else ""
    caption += (f"Right: LDR-FLIP of {labels[1]} against {labels[0]} (0 = identical, 1 = maximal), "
                f"mean {diff.mean:.4f}" + ("; the number on each sphere is that sphere's mean."
                                           if diff.number_style else "."))
    image = assemble([panels], title=title, caption=caption, text_size=text_size, page_srgb=page)
    _print_cells(image, diff, reference.result.frame)
    return Sheet(np.array(image), caption, [reference.spec, test.spec], title, kind, panels, [diff],
                 [_digests(r.spec, r.result) for r in (reference, test)], _sheet_renderer([reference, test]))


# How far (px) a sphere of B may lie from A's for the per-sphere FLIP to be measured on it.
SPHERE_TOLERANCE_PX = 0.5


def check_comparable(a: ChartSpec, b: ChartSpec) -> None:
    """Refuse, before anything is rendered, two specs whose renders cannot be compared pixel by
    pixel and sphere by sphere: the FLIP map is per pixel (the same size), and each sphere's
    mean is taken over A's sphere (its row / col AOV) at (row, col) of A's grid (the same rows
    and cols, each sphere of B where A's is: camera, spacing, sphere radius and stage place
    them)."""
    if (a.width, a.height) != (b.width, b.height):
        raise SpecError(f"cannot compare a {a.width}x{a.height} render with a {b.width}x{b.height} one; "
                        f"give both specs the same size")
    if (a.rows, a.cols) != (b.rows, b.cols):
        raise SpecError(f"cannot compare a {a.rows}x{a.cols} grid of spheres (rows x cols) with a {b.rows}x{b.cols} "
                        f"one: each sphere is measured against the sphere at the same row and column; "
                        f"give both specs the same rows and cols")
    cells = [chart_cells(chart_frame(s)) for s in (a, b)]
    for ca, cb in zip(*cells):
        if max(abs(ca.cx - cb.cx), abs(ca.cy - cb.cy), abs(ca.radius_px - cb.radius_px)) > SPHERE_TOLERANCE_PX:
            moved = [f for f in ("camera", "camera_azimuth", "camera_elevation", "camera_distance_scale",
                                 "sphere_radius", "spacing", "stage") if getattr(a, f) != getattr(b, f)]
            why = f" ({', '.join(moved)} {'differs' if len(moved) == 1 else 'differ'})" if moved else ""
            raise SpecError(f"cannot compare the two charts sphere by sphere: the sphere at row {ca.row + 1}, "
                            f"column {ca.col + 1} lies at ({ca.cx:.0f}, {ca.cy:.0f}) px, radius {ca.radius_px:.0f} "
                            f"in A and ({cb.cx:.0f}, {cb.cy:.0f}), radius {cb.radius_px:.0f} in B{why}; "
                            f"give both specs the same framing")


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
    a, b = as_spec(a, "spec A"), as_spec(b, "spec B")
    if len(labels) != 2 or not all(isinstance(s, str) for s in labels):
        raise SpecError(f"labels must be two strings, got {labels!r}")
    for value, what, longest in ((labels[0], "label A", MAX_TITLE), (labels[1], "label B", MAX_TITLE),
                                 (caption, "caption", MAX_CAPTION), (title or "", "title", MAX_TITLE)):
        check_text(value, what, longest)
    check_comparable(a, b)
    if not caption:
        diffs = spec_differences(a, b)
        caption = (f"{labels[1]} differs from {labels[0]} in: {'; '.join(diffs)}." if diffs
                   else f"{labels[0]} and {labels[1]} are the same spec.")
    ra, rb = render_chart(a, aovs=True, keep=True), render_chart(b, keep=True)
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


def bug_renders(spec: ChartSpec, names: Sequence[str]) -> list[tuple[RenderedChart, RenderedChart]]:
    """Each named bug's (correct, buggy) renders of ``spec``, kept, as compare_bug and
    bug_contact_sheet render them."""
    pairs = []
    for name in names:
        _, correct, buggy = bug_pair(spec, name)
        pairs.append((render_chart(correct, aovs=True, keep=True), render_chart(buggy, keep=True)))
    return pairs


def keep_renders(rendered: Sequence[RenderedChart]) -> None:
    """Renders made in another process (kept there, then pickled), kept here as render_chart
    keeps its own: a worker process composes sheets from them without a GL context."""
    for r in rendered:
        r.display.setflags(write=False)
        _keep(r, bool(r.result.aov))


def submit_bug_pairs(spec: ChartSpec, names: Sequence[str], batch) -> None:
    """Render each named bug's correct and buggy charts of ``spec`` (bug_renders) and submit
    their FLIP to ``batch`` (an open FlipBatch): a build measures them while it renders other
    images."""
    for rc, rb in bug_renders(spec, names):
        batch.submit(rb.display, rc.display)


def compare_bug(spec: ChartSpec | str | Path | None, bug_name: str, *, axes: bool | None = None,
                panel_size: int | None = None) -> Sheet:
    """correct | buggy | FLIP difference for one catalog bug, titled with its name and summary
    and captioned with what goes wrong, why, and the fix. ``panel_size``: render so the longer
    edge is this many pixels (default: the spec's size)."""
    spec = at_panel_size(as_spec(spec, "spec"), panel_size)
    bug, correct, buggy = bug_pair(spec, bug_name)
    rc, rb = render_chart(correct, aovs=True, keep=True), render_chart(buggy, keep=True)
    return _comparison(rc, rb, ("correct", f"buggy: {bug.name}"), title=f"{bug.name}: {bug.summary}",
                       caption=bug.caption, axes=axes, kind="bug")


def _shrunk(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """An image (uint8 RGBA or a float map) box-filtered down to ``size`` = (width, height)."""
    from PIL import Image
    if image.dtype == np.uint8:
        return np.array(Image.fromarray(image).resize(size, Image.Resampling.BOX))
    return np.array(Image.fromarray(image.astype(np.float32), "F").resize(size, Image.Resampling.BOX))


# A catalog page: one bug a row (correct | buggy | FLIP map, then its name, summary and caption),
# BUGS_PER_PAGE rows at CATALOG_PANEL px with CATALOG_TEXT px text: about 1030 x 1600 px, read at
# its own size on a docs page (the whole catalog on one sheet was 2244 x 5900 px in 14 px text).
BUGS_PER_PAGE = 8
CATALOG_PANEL = 144
CATALOG_TEXT = 16


def catalog_pages(names: Sequence[str], per_page: int = BUGS_PER_PAGE) -> list[list[str]]:
    """``names`` in pages of at most ``per_page``, as even as they can be (22 bugs: 8, 7, 7)."""
    if isinstance(per_page, bool) or not isinstance(per_page, int) or per_page < 1:
        raise SpecError(f"bugs per page must be a positive whole number, got {per_page!r}")
    count = math.ceil(len(names) / per_page)
    size, longer = divmod(len(names), count) if count else (0, 0)
    pages, start = [], 0
    for i in range(count):
        end = start + size + (1 if i < longer else 0)
        pages.append(list(names[start:end]))
        start = end
    return pages


def _bug_panels(rc: RenderedChart, rb: RenderedChart, panel_size: int, text_size: int) -> list[Panel]:
    """The correct and buggy panels of a bug's row, shown at ``panel_size`` (no axes: the
    page's caption names them once)."""
    page = sheet_page(rc.spec)
    shown = [at_panel_size(r.spec, panel_size) for r in (rc, rb)]
    return [panel(label, _shrunk(r.display, (s.width, s.height)), text_size, page_srgb=page)
            for label, r, s in (("correct", rc, shown[0]), ("buggy", rb, shown[1]))]


def _bug_row(bug, rc: RenderedChart, rb: RenderedChart, panels: list[Panel], panel_size: int, text_size: int):
    """A bug's row of a catalog page: ``panels`` (_bug_panels') and its FLIP map, measured on the
    renders and shown at ``panel_size``; returns (the three panels, the Difference)."""
    shown = at_panel_size(rc.spec, panel_size)
    diff = _difference(rc, rb, "correct", f"buggy: {bug.name}", False, text_size, shown=shown, short=True)
    return panels + [diff.panel], diff


# What a helper composing comparisons imports (workers.helper_pool): the rows here, a
# gallery's pages (tools.gallery.images).
HELPER_IMPORTS = ("sdfpbr.features.compare", "sdfpbr.image.metrics", "sdfpbr.image.flip")


def _whole_row(bug, rc: RenderedChart, rb: RenderedChart, panel_size: int, text_size: int):
    """A bug's row, its panels included (_bug_panels, _bug_row)."""
    return _bug_row(bug, rc, rb, _bug_panels(rc, rb, panel_size, text_size), panel_size, text_size)


def _helper_row(name: str, rc: RenderedChart, rb: RenderedChart, panel_size: int, text_size: int):
    """A helper's part (module level, for the pool): the row, from renders made in the parent;
    its FLIP measured here."""
    from ..spec.bugs import get_bug
    keep_renders([rc, rb])
    return _whole_row(get_bug(name), rc, rb, panel_size, text_size)


def _helped(future):
    """A helper's result, or None where there is none (its helper died: killed, out of memory)."""
    from concurrent.futures.process import BrokenProcessPool
    try:
        return future.result() if future is not None else None
    except BrokenProcessPool:
        return None


def _axes_text(spec: ChartSpec) -> str:
    """"roughness r (α = r²) 0 to 1 across, metallic 0 to 1 down": what a panel without axis
    labels shows."""
    def axis(name: str) -> str:
        values = spec.axis_values(name)
        return f"{axis_title(spec, name)} {label_text(values[0])} to {label_text(values[-1])}"
    return f"{axis('x')} across, {axis('y')} down"


def _catalog_caption(spec: ChartSpec, numbered: bool) -> str:
    return ("Each row: the correct chart, the same chart with one bug switched on, and their LDR-FLIP "
            "difference (0 = identical, 1 = maximal)" + (", each sphere's mean printed on it" if numbered else "")
            + f". Charts: {_axes_text(spec)}, unless a row says otherwise; figures measured at "
              f"{spec.width}x{spec.height}.")


def bug_catalog(spec: ChartSpec | str | Path | None = None, names: Sequence[str] | None = None, *,
                per_page: int = BUGS_PER_PAGE, panel_size: int = CATALOG_PANEL,
                measure_size: int | None = BUG_MEASURE_SIZE, progress: bool = False,
                pages: Sequence[int] | None = None) -> list[Sheet]:
    """The bug catalog (or ``names`` from it) as page-sized sheets (catalog_pages): each page a
    row per bug, its correct | buggy | FLIP difference at ``panel_size`` px beside its name,
    summary and caption. The figures are measured on renders at ``measure_size`` (the size
    ``compare --bug`` uses, so both quote the same figure; None: the spec's own size). Only
    the ``pages`` listed (numbered from 1) are drawn (default: all). ``progress``: say on
    stderr how many bugs are drawn (sdfpbr.progress)."""
    from concurrent.futures.process import BrokenProcessPool
    from ..image.metrics import FlipBatch
    from ..spec.bugs import BUGS, get_bug
    spec = at_panel_size(as_spec(spec, "spec"), measure_size)
    at_panel_size(spec, panel_size)   # checks panel_size
    names = list(BUGS) if names is None else [get_bug(n).name for n in names]   # all checked first
    if not names:
        raise SpecError(f"no bugs named; allowed: {', '.join(BUGS)}")
    paged = catalog_pages(names, per_page)
    wanted = range(1, len(paged) + 1) if pages is None else list(pages)
    if any(isinstance(i, bool) or not isinstance(i, int) or not 1 <= i <= len(paged) for i in wanted):
        raise SpecError(f"pages are numbered 1 to {len(paged)}, got {list(wanted)!r}")
    drawn_names = [n for i in wanted for n in paged[i - 1]]
    pairs = {n: bug_pair(spec, n) for n in drawn_names}
    text_size = CATALOG_TEXT
    rendered: dict[ChartSpec, RenderedChart] = {}     # the correct chart is shared by most bugs

    def render(s: ChartSpec, aovs: bool) -> RenderedChart:
        if s not in rendered:
            rendered[s] = render_chart(s, aovs, keep=True)
        return rendered[s]

    with helper_pool(len(pairs), HELPER_IMPORTS) as pool, \
            Progress(len(pairs), "bug catalog", "bugs drawn", enabled=progress) as bar:
        if pool is not None:   # each row made by a helper process as soon as its pair is drawn
            futures = []
            for bug, correct, buggy in pairs.values():
                render_chart(correct, aovs=True, keep=True)   # drawn first: its radiance serves display bugs
                rc, rb = render(correct, True), render(buggy, False)
                try:
                    futures.append(pool.submit(_helper_row, bug.name, rc, rb, panel_size, text_size))
                except BrokenProcessPool:
                    futures.append(None)
                bar.update(note=bug.name)
            made = [_helped(future) or _whole_row(bug, render(correct, True), render(buggy, False),
                                                  panel_size, text_size)
                    for (bug, correct, buggy), future in zip(pairs.values(), futures)]
        else:
            # Every pair rendered first, each measured (in worker processes) while the next
            # renders and the rows' chart panels are drawn.
            with FlipBatch(len(pairs)) as batch:
                submit_bug_pairs(spec, list(pairs), batch)
                for bug, correct, buggy in pairs.values():
                    render(correct, True), render(buggy, False)
                    bar.update(note=bug.name)
                chart_panels = [_bug_panels(render(correct, True), render(buggy, False), panel_size, text_size)
                                for bug, correct, buggy in pairs.values()]
            made = [_bug_row(bug, render(correct, True), render(buggy, False), drawn, panel_size, text_size)
                    for (bug, correct, buggy), drawn in zip(pairs.values(), chart_panels)]
    rows = dict(zip(pairs, made))
    return [_catalog_page(spec, [(pairs[n], *rows[n]) for n in paged[i - 1]], rendered, panel_size,
                          f"PBR bug catalog: {len(names)} bugs"
                          + (f", page {i} of {len(paged)}" if len(paged) > 1 else ""))
            for i in wanted]


def _catalog_page(spec: ChartSpec, rows: list, rendered: dict, panel_size: int, title: str) -> Sheet:
    """One page of the catalog from its rows: ((bug, correct, buggy), panels, Difference) each."""
    specs: list[ChartSpec] = []
    for (_, correct, buggy), panels, _ in rows:   # the page's specs: each bug's buggy, then its correct
        for s, p in ((buggy, panels[1]), (correct, panels[0])):
            if s not in specs:
                specs.append(s)
        panels[0].spec_index, panels[1].spec_index = specs.index(correct), specs.index(buggy)
    diffs = [diff for _, _, diff in rows]
    # The mean is over its map; a bug shown on other axes (its correct chart's) says which.
    notes = [(f"{bug.name}: {bug.summary}", bug.caption + ("" if _axes_text(correct) == _axes_text(spec)
                                                           else f" Chart: {_axes_text(correct)}."))
             for (bug, correct, _), _, _ in rows]
    caption = _catalog_caption(spec, any(d.number_style for d in diffs))
    image = assemble([panels for _, panels, _ in rows], title=title, caption=caption, text_size=CATALOG_TEXT,
                     notes=notes, page_srgb=sheet_page(spec))
    shown = chart_frame(at_panel_size(spec, panel_size))
    for diff in diffs:
        _print_cells(image, diff, shown)
    ordered = [rendered[s] for s in specs]
    return Sheet(np.array(image), caption, specs, title, "bugs", [p for _, panels, _ in rows for p in panels], diffs,
                 [_digests(r.spec, r.result) for r in ordered], _sheet_renderer(ordered))


def bug_contact_sheet(spec: ChartSpec | str | Path | None = None, names: Sequence[str] | None = None, *,
                      panel_size: int = CATALOG_PANEL, measure_size: int | None = BUG_MEASURE_SIZE,
                      progress: bool = False) -> Sheet:
    """``names`` of the catalog (default: all) on one sheet, however many: bug_catalog's rows."""
    from ..spec.bugs import BUGS
    count = len(BUGS) if names is None else max(1, len(names))
    return bug_catalog(spec, names, per_page=count, panel_size=panel_size, measure_size=measure_size,
                       progress=progress)[0]


# ---------------------------------------------------------------------------------------------
# Sweeps.

# The footer part (chart_labels.footer_text) that names a field, left out of a sweep's caption.
_FOOTER_PART = {"tonemap": "tone map", "exposure": "exposure", "env": "env", "brdf": "BRDF",
                "multiscatter": "BRDF", "spp": "spp"}


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
          axes: bool | None = None, progress: bool = False) -> Sheet:
    """The same chart once per value of one spec field (tonemap, exposure, env, or any other),
    as a grid of panels, each labeled with its value. ``values`` default to sweep_defaults(name);
    ``columns`` default to at most four per row; ``panel_size`` as in compare_bug; ``progress``:
    say on stderr how many charts are drawn."""
    base = at_panel_size(as_spec(spec, "spec"), panel_size)
    field_name = resolve_field(name).name
    values = list(sweep_defaults(field_name) if values is None else values)
    if not values:
        raise SpecError(f"a sweep over {field_name} needs at least one value")
    specs = [make_spec(base, **{field_name: v}) for v in values]      # every value checked first
    if columns is None:
        columns = math.ceil(len(specs) / math.ceil(len(specs) / 4))
    if isinstance(columns, bool) or not isinstance(columns, int) or columns < 1:
        raise SpecError(f"columns must be a positive whole number, got {columns!r}")
    axes = base.labels if axes is None else axes
    text_size = sheet_text_size(max(s.height for s in specs))
    with Progress(len(specs), f"{field_name} sweep", "charts drawn", enabled=progress) as bar:
        rendered = render_charts(specs, bar)
    page = sheet_page(base)
    panels = [chart_panel(_sweep_label(field_name, v), r, axes, text_size, spec_index=i, page_srgb=page)
              for i, (v, r) in enumerate(zip(values, rendered))]
    grid = [panels[i:i + columns] for i in range(0, len(panels), columns)]
    part = _FOOTER_PART.get(field_name)
    parts = footer_text(chart_frame(base)).split(FOOTER_SEPARATOR)
    fixed = FOOTER_SEPARATOR.join(p for p in parts if not (part and p.startswith(part)))
    caption = f"The same chart across {field_name}. Everything else: {fixed}."
    title = title or f"{field_name} sweep"
    image = assemble(grid, title=title, caption=caption, text_size=text_size, page_srgb=page)
    return Sheet(np.array(image), caption, specs, title, "sweep", panels, [],
                 [_digests(r.spec, r.result) for r in rendered], _sheet_renderer(rendered))
