"""Sphinx configuration of the sdfpbr documentation.

Build: ``python -m sphinx -W -b html docs build/docs`` (the ``docs`` extra installs what it
needs). The charts are drawn while the docs build, by sdfpbr's own ``sdfpbr-chart`` directive,
through the same cache as ``sdfpbr build``; the reference pages (spec fields, bug catalog,
command help, accuracy and speed) are made from the code at build time (``_ext/sdfpbr_docs.py``).
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

project = "sdfpbr"
author = "the sdfpbr authors"
copyright = "the sdfpbr authors"

from sdfpbr import __version__ as release  # noqa: E402

version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sdfpbr.sphinxext",
    "sdfpbr_docs",
]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store"]
# Equations become MathML, which browsers draw themselves: no script, no network.
html_math_renderer = "mathml"

html_theme = "furo"
html_title = f"sdfpbr {release}"
html_static_path = ["_static"]
html_css_files = ["sdfpbr.css"]
html_js_files = ["light-first.js"]
html_theme_options = {"source_repository": "", "navigation_with_keys": True}

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False}

# Internal links are checked by -W (a missing document or label is a warning); `make linkcheck`
# style checks of outside links are left out: the build machine may have no network.
nitpicky = False
