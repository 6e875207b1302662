"""The Python API: ``chart(...)`` renders a labeled chart and returns a ``Chart``."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__
from .errors import SpecError
from .files import write_group
from .image.io import check_outputs, hdr_writer, npz_writer, png_bytes, png_writer
from .image.chart_labels import label
from .gpu.render import RenderResult, check_memory
from .gpu.session import Session, default_session
from .spec.chart_spec import ChartSpec, as_spec, make_spec

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
        check_outputs(self.spec, path, hdr, aov)
        if aov is not None:
            if not self.aov:
                raise SpecError("this chart was rendered with aovs=False; render it with aovs=True to save AOVs")
        # All or none: an .exr without OpenEXR, a full disk, a failed rename leave every old file.
        items = [(path, png_writer(self.image, self.metadata()))]
        if hdr is not None:
            items.append((hdr, hdr_writer(hdr, self.hdr)))
        if aov is not None:
            items.append((aov, npz_writer(self.aov)))
        write_group(items)

    def _repr_png_(self) -> bytes:
        return png_bytes(self.image)


def chart(spec: ChartSpec | str | Path | None = None, *, aovs: bool = True, session: Session | None = None,
          **options) -> Chart:
    """Render a chart. ``spec`` is a ChartSpec or a TOML path; keywords override it.
    aovs=False skips reading back the AOVs (faster when only the image is wanted).
    ``session``: the GL session to render on (default: the process's for the spec's backend
    and device, created on first use)."""
    spec = make_spec(as_spec(spec), **options)
    check_memory(spec, aovs)   # before a GL context is made (some drivers reserve much address space)
    session = session or default_session(spec.backend, spec.device_index)
    result = session.render(spec, aovs=aovs)
    return Chart(spec, result, label(spec, result), session.renderer)
