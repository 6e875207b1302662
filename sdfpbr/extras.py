"""The optional extras (pyproject.toml's [project.optional-dependencies]): the module each one
brings, and the command that adds it to the sdfpbr that is running. A missing extra is named
with that command: pip for this interpreter (a virtual environment's, whether activated or
not), from where this sdfpbr came (the checkout it was installed from, or PyPI), since
``pip install 'sdfpbr[exr]'`` fails for an install made from a checkout."""
from __future__ import annotations

import shlex
import sys
from pathlib import Path

from .errors import SpecError

# extra -> (the module it brings, the package pip installs): what a message names.
EXTRAS = {
    "exr": ("OpenEXR", "OpenEXR"),
    "progress": ("tqdm", "tqdm"),
    "metrics": ("matplotlib", "matplotlib"),
    "video": ("imageio_ffmpeg", "imageio-ffmpeg"),
    "docs": ("sphinx", "sphinx"),
    "peer": ("mitsuba", "mitsuba"),
}


def _source() -> str:
    """What pip installs sdfpbr from: the checkout this sdfpbr runs from (an editable install,
    or none), else the folder a local install came from, else the name (PyPI)."""
    import json
    from importlib.metadata import PackageNotFoundError, distribution
    from urllib.parse import unquote, urlsplit
    here = Path(__file__).resolve().parents[1]
    if (here / "pyproject.toml").is_file():
        return str(here)
    try:
        text = distribution("sdfpbr").read_text("direct_url.json")
        url = json.loads(text).get("url", "") if text else ""
    except (PackageNotFoundError, ValueError, AttributeError):
        url = ""
    return unquote(urlsplit(url).path) if url.startswith("file://") else "sdfpbr"


def install_command(extra: str) -> str:
    """The shell command that adds ``extra`` to this sdfpbr."""
    python = sys.executable or "python3"
    return f"{shlex.quote(python)} -m pip install {shlex.quote(f'{_source()}[{extra}]')}"


def missing_extra(extra: str, needs: str, instead: str = "") -> SpecError:
    """The one-line error for a feature (``needs``: 'writing .exr') whose extra is missing;
    ``instead``: what works without it ('or use .npy')."""
    _, package = EXTRAS[extra]
    return SpecError(f"{needs} needs {package} (the {extra!r} extra): {install_command(extra)}"
                     + (f" ({instead})" if instead else ""))
