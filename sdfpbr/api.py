"""The Python API: ``chart(...)`` renders a labeled chart and returns a ``Chart``."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .files import write_group
from .image.io import check_outputs, hdr_writer, npz_writer, png_bytes, png_writer
from .image.chart_labels import finish_labels, labelled_canvas
from .shading.plan import render_plan
from .gpu.render import RenderResult, check_memory
from .gpu.session import Session, default_session
from .spec.chart_spec import ChartSpec, as_spec, make_spec

@dataclass
class Chart:
    spec: ChartSpec
    result: RenderResult
    image: np.ndarray          # labeled chart, (H, W, 4) uint8 sRGB
    renderer: str
    session: Session | None = field(default=None, repr=False, compare=False)   # renders what is read later

    @property
    def hdr(self) -> np.ndarray:
        """Linear radiance (H, W, 3) float32: read with the image when chart(hdr=True), else
        rendered again on first use (renders are deterministic: the same pixels)."""
        if self.result.hdr is None:
            self._read_back(aovs=bool(self.result.aov))
        return self.result.hdr

    @property
    def aov(self) -> dict:
        """The AOV images (see RenderResult): read with the image when chart(aovs=True), else
        rendered again on first use."""
        if not self.result.aov:
            self._read_back(aovs=True)
        return self.result.aov

    def _read_back(self, aovs: bool) -> None:
        session = self.session or default_session(self.spec.backend, self.spec.device_index)
        check_memory(self.spec, aovs)
        self.result = session.render(self.spec, aovs=aovs, hdr=True)

    def metadata(self) -> dict[str, str]:
        return {"Software": f"sdfpbr {__version__}",
                "sdfpbr:spec": json.dumps(self.spec.to_dict(), sort_keys=True),
                "sdfpbr:shader-sha256": self.result.chart_source.digest,
                "sdfpbr:gl-renderer": self.renderer}

    def save(self, path: str | Path, hdr: str | Path | None = None, aov: str | Path | None = None) -> None:
        """The labeled PNG at ``path``, and linear radiance (.npy/.exr) and the AOVs (.npz)
        when given; all written or none."""
        check_outputs(self.spec, path, hdr, aov)
        # All or none: an .exr without OpenEXR, a full disk, a failed rename leave every old file.
        items = [(path, png_writer(self.image, self.metadata()))]
        if hdr is not None:
            items.append((hdr, hdr_writer(hdr, self.hdr)))
        if aov is not None:
            items.append((aov, npz_writer(self.aov)))
        write_group(items)

    def _repr_png_(self) -> bytes:
        return png_bytes(self.image)


def chart(spec: ChartSpec | str | Path | None = None, *, hdr: bool = False, aovs: bool = False,
          session: Session | None = None, **options) -> Chart:
    """Render a chart. ``spec`` is a ChartSpec or a TOML path; keywords override it.

    Only the display image is read back unless asked: hdr=True also reads linear radiance,
    aovs=True the AOVs, in the same draw. Without them, ``Chart.hdr`` and ``Chart.aov`` still
    work: their first use renders the chart again to read them.
    ``session``: the GL session to render on (default: the process's for the spec's backend
    and device, created on first use)."""
    spec = make_spec(as_spec(spec), **options)
    check_memory(spec, aovs, hdr)   # before a GL context is made (some drivers reserve much address space)
    session = session or default_session(spec.backend, spec.device_index)
    plan = render_plan(spec)   # the labels read its frame, the render all of it
    canvas = labelled_canvas(spec, plan.frame)
    if canvas is None:
        result = session.render(spec, aovs=aovs, hdr=hdr, plan=plan)
        return Chart(spec, result, result.image, session.renderer, session)
    # The render is drawn straight into the labelled chart's render area: no second image.
    image, (x, y) = canvas
    result = session.render(spec, aovs=aovs, hdr=hdr, image=image[y:y + spec.height, x:x + spec.width], plan=plan)
    return Chart(spec, result, finish_labels(spec, image, result.frame, (x, y)), session.renderer, session)
