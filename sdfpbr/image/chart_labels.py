"""The labels around a chart render: where each sphere landed (its frame's discs: the camera's
projection of the grid), the title, the axis values and the footer of scene settings. The chart,
the reference, sheets and animations all label through here, from the plan's frame."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..shading.plan import ChartFrame
from ..spec.chart_spec import ChartSpec
from ..spec.material import axis_param
from .layout import FOOTER_SEPARATOR, Cell, chart_canvas, compose_chart, name_cells


def chart_cells(frame: ChartFrame) -> list[Cell]:
    """Each sphere's projected centre and radius in pixels, row by row."""
    centers, radii = frame.sphere_discs
    rows, cols = radii.shape
    return [Cell(r, c, float(centers[r, c, 0]), float(centers[r, c, 1]), float(radii[r, c]))
            for r in range(rows) for c in range(cols)]


def footer_scene_parts(frame: ChartFrame) -> list[str]:
    """What the chart and the reference footers share: display and scene settings."""
    spec, axis = frame.spec, frame.exposure_axis
    # A map file by its name: the folder it was read from is the machine's, not the chart's.
    env = Path(spec.env).name if Path(spec.env).suffix else spec.env
    env = env if len(env) < 40 else "…" + env[-38:]
    exposure = f"exposure {spec.exposure:+g} EV" if not axis else f"exposure per {'column' if axis == 'x' else 'row'}"
    return [f"tone map {spec.tonemap}", exposure, f"env {env}",
            f"BRDF {frame.brdf_model}" + ("" if spec.multiscatter else " (single scatter)")]


def footer_text(frame: ChartFrame) -> str:
    spec = frame.spec
    parts = footer_scene_parts(frame) + [f"{spec.spp} spp"]
    if spec.quality != "default":
        parts.append(f"quality {spec.quality}")
    if spec.bugs:
        parts.append("BUG: " + ", ".join(spec.bugs))
    return FOOTER_SEPARATOR.join(parts)


def _number(x: float) -> str:
    return f"{x:g}"


def default_title(spec: ChartSpec) -> str:
    """What the chart shows: the axes that vary, then those held at one value, and the grid
    (measured-metal rows are named as such); a glTF chart: its file and material count."""
    if spec.gltf:
        count = spec.rows * spec.cols
        return f"{Path(spec.gltf).name} — {count} material{'s' * (count != 1)}"
    def axis(which):
        name, values = axis_param(spec, which).label, spec.axis_values(which)
        return (name, True) if len(set(values)) > 1 else (f"{name} {_number(values[0])}", False)
    axes = [axis("x")]
    if spec.row_materials:
        axes.append(("measured metals", True))
        if spec.metallic != (1.0, 1.0) or spec.y_axis != "metallic":
            axes.append(axis("y"))
    else:
        axes.append(axis("y"))
    varying = " × ".join(a for a, v in axes if v)
    text = ", ".join([varying] * bool(varying) + [a for a, v in axes if not v])
    return f"{text[0].upper()}{text[1:]} — {grid_words(spec.rows, spec.cols)}"


def grid_words(rows: int, cols: int) -> str:
    """'5 rows × 4 columns': a bare 5×4 read as width × height beside --size W×H."""
    return f"{rows} row{'s' * (rows != 1)} × {cols} column{'s' * (cols != 1)}"


def label(spec: ChartSpec, result, title: str | None = None, footer: str | None = None) -> np.ndarray:
    """The labeled layout around a render (anything with .image and .frame)."""
    if not spec.labels:
        return result.image
    layout = _layout(spec, result.frame, title, footer)
    return compose_chart(result.image, cell_names=cell_names(spec), **layout)


def labelled_canvas(spec: ChartSpec, frame: ChartFrame, title: str | None = None,
                    footer: str | None = None) -> tuple[np.ndarray, tuple[int, int]] | None:
    """The labelled chart before its render (``frame``: its plan's), for a renderer to draw
    into: (chart, (x, y) of the render area), or None for a spec without labels. finish_labels
    completes it."""
    if not spec.labels:
        return None
    layout = _layout(spec, frame, title, footer)
    return chart_canvas((spec.height, spec.width), **layout, on_disk=True)


def finish_labels(spec: ChartSpec, chart: np.ndarray, frame: ChartFrame, origin: tuple[int, int]) -> np.ndarray:
    """A labelled_canvas chart with its render drawn in: the glTF cells' names over it."""
    names = cell_names(spec)
    return name_cells(chart, chart_cells(frame), names, origin, (spec.height, spec.width),
                      spec.backdrop or None) if names else chart


def _layout(spec: ChartSpec, frame: ChartFrame, title: str | None, footer: str | None) -> dict:
    """compose_chart's layout arguments for ``spec`` (everything but the render)."""
    title = spec.title or title or default_title(spec)
    footer = footer if footer is not None else footer_text(frame)
    cells = chart_cells(frame)
    if spec.gltf:   # named cells, no axes
        return dict(cells=cells, column_values=[], row_values=[], title=title, footer=footer,
                    transparent=spec.transparent, column_axis_title="", row_axis_title="",
                    page_srgb=spec.backdrop or None)
    names, row_title = row_names(spec), row_axis_title(spec)
    return dict(cells=cells, column_values=spec.axis_values("x"), row_values=spec.axis_values("y"), title=title,
                footer=footer, row_names=names, transparent=spec.transparent,
                column_axis_title=axis_title(spec, "x"), row_axis_title=row_title,
                page_srgb=spec.backdrop or None)


def axis_title(spec: ChartSpec, axis: str) -> str:
    """The title of the "x" or "y" axis: its parameter's, or the one a bug in the spec gives it
    (unsquared roughness is no longer α = r²)."""
    from ..spec.bugs import get_bug
    param = axis_param(spec, axis)
    titles = [get_bug(b).axis_titles.get(param.name) for b in spec.bugs]
    return next((t for t in titles if t), param.title)


def row_axis_title(spec: ChartSpec) -> str:
    """The rows' title: the y axis's, or for measured metals at one value of it (their labels
    then name the metal alone: layout.row_labels) the value they share."""
    values = spec.axis_values("y")
    if row_names(spec) and len(set(values)) == 1:
        return f"measured metals, {axis_param(spec, 'y').label} {_number(values[0])}"
    return axis_title(spec, "y")


def cell_names(spec: ChartSpec) -> list[str] | None:
    """A glTF chart names its cells by material (its axes do not apply)."""
    if not spec.gltf:
        return None
    return [m.name for row in spec.cell_materials() for m in row]


def row_names(spec: ChartSpec) -> list[str] | None:
    """Measured-metal rows are named (one material per row)."""
    return list(spec.row_materials) if spec.row_materials and len(spec.row_materials) == spec.rows else None
