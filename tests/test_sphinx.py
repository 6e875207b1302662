"""The Sphinx extension, through a real `sphinx-build -b html` of a tiny docs project."""
import os
import shutil
import subprocess
import sys
import tomllib
from html.parser import HTMLParser
from pathlib import Path

import pytest
from PIL import Image

from sdfpbr.features.gallery.entries import parse_entry
from sdfpbr.features.gallery.images import KEY_FIELD, ImageCache, ensure_image

pytestmark = pytest.mark.requires_extra("sphinx")   # every test runs `python -m sphinx`

FILE_SPEC = 'rows = 2\ncols = 2\nsize = "64x48"\nlabels = false\ncaption = "From the <file> & its caption"\n'
INLINE_SPEC = 'rows = 1\ncols = 3\nsize = "96x32"\nlabels = false\ntonemap = "neutral"'

INDEX = f"""\
Charts
======

.. sdfpbr-chart:: specs/small.toml
   :width: 50%
   :name: file-chart

.. sdfpbr-chart::
   :caption: Inline *chart* & <more>
   :alt: three spheres

{chr(10).join('   ' + line for line in INLINE_SPEC.splitlines())}
"""


class Figures(HTMLParser):
    """(img attributes, caption text) of every figure in a page."""

    def __init__(self):
        super().__init__()
        self.figures, self._caption = [], None

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.figures.append([dict(attrs), ""])
        elif tag == "figcaption":
            self._caption = []

    def handle_endtag(self, tag):
        if tag == "figcaption":
            self.figures[-1][1] = "".join(self._caption).replace("¶", "").strip()
            self._caption = None

    def handle_data(self, data):
        if self._caption is not None:
            self._caption.append(data)


def make_project(root: Path, index: str = INDEX) -> Path:
    src = root / "src"
    (src / "specs").mkdir(parents=True)
    (src / "conf.py").write_text('extensions = ["sdfpbr.sphinxext"]\nproject = "charts"\n')
    (src / "specs" / "small.toml").write_text(FILE_SPEC)
    (src / "index.rst").write_text(index)
    return src


def sphinx_build(src: Path, out: Path, quiet: bool = True, **env_extra):
    env = {**os.environ, **env_extra}
    return subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-W", *(["-q"] if quiet else []),
                           str(src), str(out)], capture_output=True, text=True, env=env, timeout=300)


def figures(out: Path) -> list:
    parser = Figures()
    parser.feed((out / "index.html").read_text())
    return parser.figures


def test_sphinx_build_renders_file_and_inline_charts(tmp_path, monkeypatch):
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    src = make_project(tmp_path)
    out = tmp_path / "html"
    r = sphinx_build(src, out, quiet=False)
    assert r.returncode == 0, r.stderr
    # Each render is said through Sphinx's logger as it starts and ends (a docs build drew silently).
    assert r.stdout.count("sdfpbr-chart: drawing ") == 2 and r.stdout.count("sdfpbr-chart: drew ") == 2, r.stdout

    (file_img, file_caption), (inline_img, inline_caption) = figures(out)
    assert file_caption == "From the <file> & its caption"           # the entry's caption
    assert inline_caption == "Inline chart & <more>"                  # :caption:, inline markup applied
    assert "<em>chart</em> &amp; &lt;more&gt;" in (out / "index.html").read_text()
    assert file_img["alt"] == "From the <file> & its caption" and inline_img["alt"] == "three spheres"
    assert "width: 50%" in file_img["style"]
    assert 'id="file-chart"' in (out / "index.html").read_text()

    # The images are the build cache's images for these entries: same key, same bytes.
    for img, text, base in ((file_img, FILE_SPEC, src / "specs"), (inline_img, INLINE_SPEC, src)):
        path = out / img["src"]
        item = parse_entry(tomllib.loads(text), "test", base, "chart")[0]
        key, data, cached = ensure_image(item, ImageCache())
        assert cached, "sphinx-build rendered through the same cache"
        assert path.read_bytes() == data and Image.open(path).text[KEY_FIELD] == key
        spec = item.specs[0]
        assert Image.open(path).size == (spec.width, spec.height)   # labels off: the render itself


def test_sphinx_rebuild_rereads_only_when_a_chart_key_changes(tmp_path, monkeypatch):
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    from sdfpbr.shading.compose import shader_dir
    shaders = tmp_path / "shaders"
    shutil.copytree(shader_dir(), shaders)
    src = make_project(tmp_path)
    out = tmp_path / "html"
    assert sphinx_build(src, out, SDFPBR_SHADER_DIR=str(shaders)).returncode == 0
    first = [img["src"] for img, _ in figures(out)]
    assert len(first) == 2 and len(set(first)) == 2

    def rendered():   # a render writes its image anew (a new file); a cache hit only reads it
        return {p.name: p.stat().st_ino for p in (tmp_path / "cache" / "build").glob("*.png")}
    before = rendered()
    r = sphinx_build(src, out, SDFPBR_SHADER_DIR=str(shaders))
    assert r.returncode == 0 and [img["src"] for img, _ in figures(out)] == first
    assert rendered() == before and len(before) == 2      # nothing rendered again

    # Both charts use the display program; editing its tone-map module changes both keys.
    tonemap = shaders / "tonemap.glsl"
    tonemap.write_text(tonemap.read_text() + "\n// edited\n")
    r = sphinx_build(src, out, SDFPBR_SHADER_DIR=str(shaders))
    assert r.returncode == 0, r.stderr
    second = [img["src"] for img, _ in figures(out)]
    assert len(second) == 2 and not set(first) & set(second) and all((out / s).is_file() for s in second)


@pytest.mark.parametrize("body, needle", [
    ('   [compare]\n   bug = "no-such-bug"\n', "unknown bug"),
    ('   rows = = 2\n', "malformed inline TOML"),
    ('   [compare]\n   bugs = "each"\n', "a directive shows one"),
])
def test_sphinx_bad_entry_is_a_docs_error_not_a_crash(tmp_path, monkeypatch, body, needle):
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    src = make_project(tmp_path, "Bad\n===\n\n.. sdfpbr-chart::\n\n" + body)
    r = sphinx_build(src, tmp_path / "html")
    assert r.returncode != 0
    assert needle in r.stderr and "index.rst" in r.stderr and "Traceback" not in r.stderr
