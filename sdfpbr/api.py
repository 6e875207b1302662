"""The Python API: ``chart(...)`` renders a labeled chart and returns a ``Chart``."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .errors import SpecError
from .image.io import HDR_SUFFIXES, check_writable, png_bytes, write_hdr, write_npz, write_png
from .image.layout import Cell, compose_chart
from .gpu.render import RenderResult
from .gpu.session import Session, default_session
from .shading.plan import brdf_model
from .spec.chart_spec import ChartSpec, load_spec, make_spec
from .shading.camera import sphere_centers

@dataclass
class Chart:
    spec: ChartSpec
    result: RenderResult
    image: np.ndarray          # labeled chart, (H, W, 4) uint8 sRGB
    renderer: str

    @property
    def hdr(self) -> np.ndarray:
        return self.result.hdr

    @property
    def aov(self) -> dict:
        return self.result.aov

    def metadata(self) -> dict[str, str]:
        return {"Software": f"sdfpbr {__version__}",
                "sdfpbr:spec": json.dumps(self.spec.to_dict(), sort_keys=True),
                "sdfpbr:shader-sha256": self.result.chart_source.digest,
                "sdfpbr:gl-renderer": self.renderer}

    def save(self, path: str | Path, hdr: str | Path | None = None, aov: str | Path | None = None) -> None:
        check_writable(path, (".png",), "output")
        if hdr is not None:
            check_writable(hdr, HDR_SUFFIXES, "--hdr")
        if aov is not None:
            check_writable(aov, (".npz",), "--aov")
            if not self.aov:
                raise SpecError("this chart was rendered with aovs=False; render it with aovs=True to save AOVs")
        write_png(path, self.image, self.metadata())
        if hdr is not None:
            write_hdr(hdr, self.hdr)
        if aov is not None:
            write_npz(aov, self.aov)

    def _repr_png_(self) -> bytes:
        return png_bytes(self.image)


def footer_scene_parts(spec: ChartSpec, brdf: str) -> list[str]:
    """What the chart and the reference footers share: display and scene settings."""
    env = spec.env if len(spec.env) < 40 else "…" + spec.env[-38:]
    return [f"tone map {spec.tonemap}", f"exposure {spec.exposure:+g} EV", f"env {env}",
            f"BRDF {brdf}" + ("" if spec.multiscatter else " (single scatter)")]


def footer_text(spec: ChartSpec) -> str:
    parts = footer_scene_parts(spec, brdf_model(spec)) + [f"{spec.spp} spp"]
    if spec.quality != "default":
        parts.append(f"quality {spec.quality}")
    if spec.bugs:
        parts.append("BUG: " + ", ".join(spec.bugs))
    return "  |  ".join(parts)


def label(spec: ChartSpec, result, title: str | None = None, footer: str | None = None) -> np.ndarray:
    """The labeled layout around a render (anything with .image and .camera)."""
    if not spec.labels:
        return result.image
    centers = sphere_centers(spec).reshape(-1, 3)
    px, scale = result.camera.project(centers)
    cells = [Cell(i // spec.cols, i % spec.cols, float(x), float(y), float(spec.sphere_radius * s))
             for i, ((x, y), s) in enumerate(zip(px, scale))]
    title = spec.title or title or f"Roughness × metallic — {spec.rows}×{spec.cols}"
    return compose_chart(result.image, cells, spec.column_roughness(), spec.row_metallic(), title,
                         footer if footer is not None else footer_text(spec), row_names=list(spec.row_materials) or None,
                         transparent=spec.transparent)


def chart(spec: ChartSpec | str | Path | None = None, *, aovs: bool = True, session: Session | None = None,
          **options) -> Chart:
    """Render a chart. ``spec`` is a ChartSpec or a TOML path; keywords override it.
    aovs=False skips reading back the AOVs (faster when only the image is wanted).
    ``session``: the GL session to render on (default: the process's for the spec's backend
    and device, created on first use)."""
    if isinstance(spec, (str, Path)):
        spec = load_spec(spec)
    elif spec is not None and not isinstance(spec, ChartSpec):
        raise SpecError(f"spec must be a ChartSpec or a TOML path, got {type(spec).__name__}")
    spec = make_spec(spec, **options)
    session = session or default_session(spec.backend, spec.device_index)
    result = session.render(spec, aovs=aovs)
    return Chart(spec, result, label(spec, result), session.renderer)
