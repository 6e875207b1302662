"""Sphinx extension: render sdfpbr charts while the docs build, through the build cache.

In ``conf.py``: ``extensions = ["sdfpbr.sphinxext"]``. Then, in reStructuredText::

    .. sdfpbr-chart:: charts/materials.toml
       :caption: Measured metals under the studio environment.
       :width: 80%

    .. sdfpbr-chart::
       :caption: Three tone mappers.
       :alt: the chart under none, Reinhard and ACES

       [sweep]
       field = "tonemap"
       values = ["none", "reinhard", "aces"]
       [spec]
       size = "256x256"

The argument is a gallery entry file (relative to the document, or to the source directory
when it starts with ``/``); the content is an entry written inline.

What a directive reads is confined to the docs source tree (Sphinx's ``env.srcdir``): the entry
file, and every file the entry names (``env``, textures, ``gltf``, ``[compare]`` a/b files and
what those name), each relative to the file naming it (an inline entry: its document), must lie
inside it with symlinks resolved (sdfpbr.inputs.confined, through entries.inside). A path that
leads out (``..``, an absolute path, a URI, a symlink) is the directive's error, in one line and
the same words whether or not the outside file exists; a FIFO or a device (``/dev/zero``) is
refused without being read (sdfpbr.inputs). Either is any entry
``sdfpbr build`` reads (a chart spec, a ``[compare]`` or a ``[sweep]``) that makes one image.
Options: ``:caption:`` (default: the entry's caption), ``:alt:``, ``:width:``, ``:align:``,
``:name:``, ``:class:``. The image comes from the same content-addressed cache as
``sdfpbr build`` (``$SDFPBR_CACHE_DIR/build``): a docs rebuild re-renders only charts whose key
changed, and a document whose chart key changed (e.g. a shader module was edited) is re-read.
"""
from __future__ import annotations

import os
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util.docutils import SphinxDirective

from . import __version__


def _align(argument: str) -> str:
    return directives.choice(argument, ("left", "center", "right"))


def _entry(directive: "SdfpbrChart") -> tuple[dict, Path, str, list[Path]]:
    """The entry document, the directory its paths are relative to, a name for messages, and
    the files it was read from. The file lies inside the source tree (module docstring)."""
    from .errors import SpecError
    from .spec.toml_file import parse_toml_text, read_toml
    from .features.gallery.entries import inside
    env = directive.env
    if directive.arguments:
        if directive.content:
            raise SpecError("give a spec file or inline TOML, not both")
        name = directive.arguments[0]
        # Sphinx's rule (env.relfn2path): '/x' is srcdir/x, 'x' is beside the document.
        base, rel = (env.srcdir, name[1:]) if name.startswith("/") else (_doc_dir(env), name)
        path = inside(env.srcdir, base, rel, "spec file")
        return read_toml(path, "spec file"), path.parent, str(path), [path]
    if not directive.content:
        raise SpecError("needs a spec file argument or inline TOML content")
    where = f"{env.doc2path(env.docname)}:{directive.lineno}"
    data = parse_toml_text("\n".join(directive.content), where)
    return data, _doc_dir(env), where, []


def _doc_dir(env) -> Path:
    return Path(env.doc2path(env.docname)).parent


def _one_item(data: dict, base_dir: Path, where: str, srcdir):
    """The one image of an entry; what it names is confined to the source tree ``srcdir``."""
    from .features.gallery.entries import parse_entry
    from .errors import SpecError
    items = parse_entry(data, where, base_dir, "chart", root=srcdir)
    if len(items) != 1:
        raise SpecError(f"{where}: the entry makes {len(items)} images; a directive shows one "
                        f"(one bug: bug = NAME; one page of a bug catalog: add page = N)")
    return items[0]


def _referenced_files(data: dict, base_dir: Path, srcdir) -> list[Path]:
    """Files a [compare] a/b entry reads, so that editing them re-reads the document (those
    inside the source tree: one outside is refused when the entry is read)."""
    from .errors import SpecError
    from .features.gallery.entries import inside
    table = data.get("compare")
    if not isinstance(table, dict):
        return []
    files = []
    for k in ("a", "b"):
        if isinstance(table.get(k), str):
            try:
                files.append(inside(srcdir, base_dir, table[k], f"[compare] {k}"))
            except SpecError:
                pass
    return files


def _log(line: str) -> None:
    """A line of progress through Sphinx's own logger (shown at its default verbosity)."""
    from sphinx.util import logging
    logging.getLogger(__name__).info(f"sdfpbr-chart: {line}")


class SdfpbrChart(SphinxDirective):
    optional_arguments = 1
    final_argument_whitespace = True
    has_content = True
    option_spec = {
        "caption": directives.unchanged,
        "alt": directives.unchanged,
        "width": directives.length_or_percentage_or_unitless,
        "align": _align,
        "name": directives.unchanged,
        "class": directives.class_option,
    }

    def run(self) -> list[nodes.Node]:
        from .files import write_bytes
        from .features.gallery.images import ImageCache, ensure_image
        from .features.gallery.keys import gl_renderers
        from .errors import SdfpbrError
        try:
            data, base_dir, where, files = _entry(self)
            for path in files + _referenced_files(data, base_dir, self.env.srcdir):
                self.env.note_dependency(str(path))
            item = _one_item(data, base_dir, where, self.env.srcdir)
            renderers = gl_renderers([item])
            key, png, _cached = ensure_image(item, ImageCache(), renderers=renderers, log=_log)
            target = Path(self.env.app.doctreedir) / "sdfpbr" / f"{key}.png"
            if not (target.is_file() and target.read_bytes() == png):
                target.parent.mkdir(parents=True, exist_ok=True)
                write_bytes(target, png)
        except SdfpbrError as exc:
            raise self.error(f"sdfpbr-chart: {exc}") from None
        except MemoryError:   # what the reader's limits could not foresee: one line all the same
            raise self.error("sdfpbr-chart: out of memory reading or rendering the chart") from None
        except OSError as exc:
            raise self.error(f"sdfpbr-chart: cannot write the chart image: {exc}") from None

        records = self.env.__dict__.setdefault("sdfpbr_charts", {})
        records.setdefault(self.env.docname, []).append(
            {"document": data, "base_dir": str(base_dir), "where": where, "key": key,
             "renderers": [[b, d, s] for (b, d), s in renderers.items()]})

        # Image URIs are relative to the document's directory; the builder copies the file.
        doc_dir = Path(self.env.doc2path(self.env.docname)).parent
        image = nodes.image(uri=os.path.relpath(target, doc_dir))
        caption_text = self.options.get("caption", item.caption)
        image["alt"] = self.options.get("alt", caption_text or item.name)
        if "width" in self.options:
            image["width"] = self.options["width"]
        figure = nodes.figure("", image, classes=["sdfpbr-chart"] + self.options.get("class", []))
        if "align" in self.options:
            figure["align"] = self.options["align"]
        self.add_name(figure)
        messages: list[nodes.Node] = []
        if caption_text:
            text_nodes, messages = self.state.inline_text(caption_text, self.lineno)
            caption = nodes.caption(caption_text, "", *text_nodes)
            caption.source, caption.line = self.get_source_info()
            figure += caption
        return [figure, *messages]


def _purge(app, env, docname) -> None:
    getattr(env, "sdfpbr_charts", {}).pop(docname, None)


def _merge(app, env, docnames, other) -> None:
    mine = env.__dict__.setdefault("sdfpbr_charts", {})
    theirs = getattr(other, "sdfpbr_charts", {})
    for docname in docnames:
        if docname in theirs:
            mine[docname] = theirs[docname]


def _outdated(app, env, added, changed, removed) -> list[str]:
    """Documents whose charts would get a new key now (a shader module or sdfpbr itself
    changed) are read again, so their images are re-rendered. The GL renderer string is the one
    recorded at reading: making a context here, in the process Sphinx forks its parallel
    readers from, would hand them GL state across a fork."""
    from .features.gallery.keys import item_key
    from .errors import SdfpbrError
    stale = []
    for docname, records in getattr(env, "sdfpbr_charts", {}).items():
        if docname in changed or docname in removed:
            continue
        for record in records:
            try:
                item = _one_item(record["document"], Path(record["base_dir"]), record["where"], env.srcdir)
                key = item_key(item, {(b, d): s for b, d, s in record["renderers"]})
            except (SdfpbrError, KeyError):
                key = None              # re-read: the directive reports the problem
            if key != record["key"]:
                stale.append(docname)
                break
    return stale


def setup(app) -> dict:
    app.add_directive("sdfpbr-chart", SdfpbrChart)
    app.connect("env-purge-doc", _purge)
    app.connect("env-merge-info", _merge)
    app.connect("env-get-outdated", _outdated)
    return {"version": __version__, "parallel_read_safe": True, "parallel_write_safe": True,
            "env_version": 1}
