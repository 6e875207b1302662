"""The docs' reference pages, made from the code while the docs build, and equations as MathML.

A page asks for a generated part with a marker line of its own::

    <!-- sdfpbr:fields -->            every spec field, from the field table (sdfpbr.spec.fields)
    <!-- sdfpbr:presets -->           the quality presets' knobs and the material presets
    <!-- sdfpbr:tonemappers -->       the tone mappers and what each is
    <!-- sdfpbr:bugs -->              every bug of the catalog, its comparison drawn at build time
    <!-- sdfpbr:commands -->          every command's --help
    <!-- sdfpbr:bench bench/*.json -->   the benchmark report of committed `sdfpbr bench --json`
                                      output (files or patterns relative to the page), as
                                      BENCHMARKS.md

The marker is replaced by Markdown before the page is parsed (Sphinx's source-read event), so
what it makes is headings, tables and ``sdfpbr-chart`` directives like any hand-written part.
Each generated page depends on the files it was made from: editing one reads the page again.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

from docutils import nodes

MARKER = re.compile(r"^<!-- sdfpbr:(\w+)((?: [^ >]+)*) -->$", re.M)
# Bug comparisons in the catalog page: panels small enough for a page, drawn once and cached.
BUG_PANEL_SIZE = "224x224"
# Command help is laid out for this many columns, whatever the terminal building the docs.
HELP_COLUMNS = "80"


# ---- Markdown helpers --------------------------------------------------------------------------

def _cell(text) -> str:
    """Text for a Markdown table cell: pipes escaped, newlines folded."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _code(text) -> str:
    text = str(text)
    tick = "``" if "`" in text else "`"
    pad = " " if "`" in text else ""
    return f"{tick}{pad}{text}{pad}{tick}"


def _table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


# ---- the generated parts -----------------------------------------------------------------------

def _default_text(field) -> str:
    """The default as the command line writes it (as `sdfpbr chart --help` shows it)."""
    if field.default in (None, "", ()):
        return "(none)" if field.default is not None else "–"
    if field.kind == "lights":
        return "default"
    return field.to_text(field.default)


def _value(field) -> str:
    """What the field takes, as its flag's help names it."""
    if field.kind == "bool":
        return "`true` / `false`"
    return _code(field.metavar) if field.metavar else ""


def fields_markdown(app, docname, args) -> tuple[str, list[Path]]:
    """Every spec field, in the groups of `sdfpbr chart --help`."""
    import sdfpbr.spec.fields as fields_module
    from sdfpbr.spec.fields import FIELDS, HELP_GROUPS
    by_name = {f.name: f for f in FIELDS}
    grouped = [name for _, names in HELP_GROUPS for name in names]
    groups = list(HELP_GROUPS) + [("other", tuple(f.name for f in FIELDS if f.name not in grouped))]
    parts = [f"{len(FIELDS)} fields. One name on every surface: the TOML key, the Python keyword, and "
             "the flag without its dashes (`-` and `_` alike): `base_color` is `--base-color`. A "
             "`true` / `false` field has a flag each way: `--shadows` and `--no-shadows`. Names in "
             "brackets are older aliases that still work."]
    for title, names in groups:
        if not names:
            continue
        rows = []
        for f in (by_name[n] for n in names):
            key = _code(f.name) + "".join(f" ({_code(a)})" for a in f.aliases)
            rows.append([key, _value(f), _code(_default_text(f)), f.help])
        parts.append(f"## {title[:1].upper() + title[1:]}\n\n"
                     + _table(["key", "value", "default", "what it sets"], rows))
    return "\n\n".join(parts), [Path(fields_module.__file__)]


def presets_markdown(app, docname, args) -> tuple[str, list[Path]]:
    import dataclasses

    import sdfpbr.spec.presets as presets_module
    from sdfpbr.spec.presets import MATERIAL_PRESETS, QUALITY_PRESETS, Quality
    names = list(QUALITY_PRESETS)
    rows = []
    for f in dataclasses.fields(Quality):
        values = [getattr(QUALITY_PRESETS[n], f.name) for n in names]
        if all(v == values[0] for v in values):
            continue   # a knob no preset moves says nothing here
        rows.append([_code(f.name)] + [_code(_short(v)) for v in values])
    quality = ("The knobs the quality presets set differently (the others are the same in all of "
               "them).\n\n" + _table(["knob"] + [_code(n) for n in names], rows))
    metals = _table(["name", "linear F0 (R, G, B)"],
                    [[_code(n), ", ".join(f"{c:.3f}" for c in rgb)] for n, rgb in MATERIAL_PRESETS.items()])
    return quality + "\n\n## Material presets\n\n" + metals, [Path(presets_module.__file__)]


def tonemappers_markdown(app, docname, args) -> tuple[str, list[Path]]:
    """The tone mappers a spec can name, as the preset table describes them."""
    import sdfpbr.spec.presets as presets_module
    rows = [[_code(t.name), t.label] for t in presets_module.TONE_MAPPERS]
    return _table(["`tonemap`", "what it is"], rows), [Path(presets_module.__file__)]


def _short(v) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, tuple):
        return ", ".join(map(str, v)) or "(none)"
    if v == "":
        return "(spec)"
    return str(v)


def bugs_markdown(app, docname, args) -> tuple[str, list[Path]]:
    import sdfpbr.spec.bugs as bugs_module
    from sdfpbr.spec.bugs import BUGS
    parts = [f"{len(BUGS)} bugs. Each comparison below is drawn while the docs build, "
             f"at {BUG_PANEL_SIZE} a panel (`sdfpbr compare --bug NAME` draws them at "
             f"{bugs_module.BUG_MEASURE_SIZE}², where the mean FLIP the catalog quotes is measured)."]
    for bug in BUGS.values():
        value = str(bug.value).lower() if isinstance(bug.value, bool) else bug.value
        option = _code(f"{bug.option} = {value}" if bug.value is not True else bug.option)
        needs = ", ".join(f"{k} = {_requirement(v)}" for k, v in bug.requires.items())
        parts.append(
            f"## {bug.name}\n\n**{bug.summary}.** {bug.caption}\n\n"
            f"Program: {_code(bug.program)}, option {option}"
            + (f"; shown with {_code(needs)}" if needs else "") + ".\n\n"
            f"```{{sdfpbr-chart}}\n:caption: `sdfpbr compare --bug {bug.name} -o {bug.name}.png`\n"
            f":alt: {bug.name}: the correct chart, the chart with the bug, and their FLIP difference\n\n"
            f"[compare]\nbug = \"{bug.name}\"\n[spec]\nsize = \"{BUG_PANEL_SIZE}\"\n```")
    return "\n\n".join(parts), [Path(bugs_module.__file__)]


def _requirement(value) -> str:
    """A bug's spec override in words: lights by their count, ranges as LO:HI."""
    from sdfpbr.spec.presets import Light
    if isinstance(value, tuple) and value and all(isinstance(v, Light) for v in value):
        return f"({len(value)} lights)"
    if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
        return f"{value[0]:g}" if value[0] == value[1] else f"{value[0]:g}:{value[1]:g}"
    if isinstance(value, tuple):
        return ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    return str(value)


def _wrapped(text: str) -> str:
    """Help text with its unindented long lines (descriptions argparse leaves as written)
    wrapped to HELP_COLUMNS."""
    import textwrap
    width = int(HELP_COLUMNS)
    return "\n".join(textwrap.fill(line, width) if len(line) > width and not line.startswith(" ") else line
                     for line in text.splitlines())


def _without_chart_groups(text: str) -> tuple[str, bool]:
    """A command's help without the chart option groups it shares with `sdfpbr chart` (their
    headings start with 'chart: '), and whether it had any."""
    blocks = text.split("\n\n")
    kept = [b for b in blocks if not b.lstrip().startswith("chart: ")]
    return "\n\n".join(kept), len(kept) < len(blocks)


def commands_markdown(app, docname, args) -> tuple[str, list[Path]]:
    import sdfpbr.cli as cli_package
    from sdfpbr.cli.main import build_parser
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        parser = build_parser()
        top = parser.format_help()
        helps = {name: p.format_help() for name, p in parser.subcommands.items()}
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    parts = ["## sdfpbr\n\n```text\n" + _wrapped(top).rstrip() + "\n```"]
    for name, text in helps.items():
        own, shared = _without_chart_groups(text) if name != "chart" else (text, False)
        own = _wrapped(own)
        note = (f"\n\n`sdfpbr {name}` also takes every chart option, grouped as in "
                "[`sdfpbr chart`](#sdfpbr-chart), for the spec it draws." if shared else "")
        parts.append(f"## sdfpbr {name}\n\n```text\n{own.rstrip()}\n```{note}")
    files = sorted(Path(cli_package.__file__).parent.rglob("*.py"))
    return "\n\n".join(parts), files


def bench_markdown(app, docname, args) -> tuple[str, list[Path]]:
    from sdfpbr.devtools.bench import markdown
    doc_dir = Path(app.env.doc2path(docname)).parent
    # Each argument a file or a pattern (bench/*.json: a newly committed run needs no edit here).
    paths = [p for a in args for p in (sorted(doc_dir.glob(a)) if any(c in a for c in "*?[") else [doc_dir / a])]
    if not paths:
        raise ValueError(f"{docname}: no bench JSON matches {' '.join(args)}")
    reports = [markdown.load_report(p) for p in paths]
    out = Path(app.doctreedir) / "sdfpbr-bench"
    figures = markdown.write_figures(reports, out)

    def link(name: str) -> str:
        return os.path.relpath(figures[name], doc_dir)
    text = markdown.report_markdown(reports,
                                    [Path(os.path.relpath(p, Path(app.srcdir).parent)).as_posix() for p in paths],
                                    link, title=False, figures=figures)
    return text, paths + [Path(markdown.__file__)]


GENERATORS = {"fields": fields_markdown, "presets": presets_markdown, "tonemappers": tonemappers_markdown,
              "bugs": bugs_markdown,
              "commands": commands_markdown, "bench": bench_markdown}


def _source_read(app, docname, source) -> None:
    def generate(match):
        name, args = match.group(1), match.group(2).split()
        if name not in GENERATORS:
            raise ValueError(f"{docname}: unknown generated part {name!r}; known: {', '.join(GENERATORS)}")
        text, files = GENERATORS[name](app, docname, args)
        for path in files:
            app.env.note_dependency(str(path))
        return text
    source[0] = MARKER.sub(generate, source[0])


# ---- equations as MathML -----------------------------------------------------------------------

def _mathml(latex: str, block: bool, node=None) -> str:
    """MathML for a TeX formula; one it cannot read is a warning (an error under -W) and shows
    as its TeX."""
    import html

    from docutils.utils.math import latex2mathml
    from sphinx.util import logging
    try:
        return latex2mathml.tex2mathml(latex, as_block=block)
    except Exception as exc:   # latex2mathml's errors are SyntaxError, KeyError, ...
        logging.getLogger(__name__).warning(f"cannot draw {latex!r} as MathML: {exc}", location=node)
        return f"<code>{html.escape(latex)}</code>"


def _visit_math(self, node) -> None:
    self.body.append(f'<span class="math">{_mathml(node.astext(), False, node)}</span>')
    raise nodes.SkipNode


def _visit_displaymath(self, node) -> None:
    number = node.get("number")
    label = (f'<span class="eqno">({number})<a class="headerlink" href="#{node["ids"][0]}">#</a></span>'
             if number and node.get("ids") else "")
    latex = node.astext()
    # Equations a blank line apart are set one by one.
    equations = [latex] if node.get("nowrap") else [e for e in re.split(r"\n\s*\n", latex) if e.strip()]
    body = "".join(_mathml(e, True, node) for e in equations)
    ids = f' id="{node["ids"][0]}"' if node.get("ids") else ""
    self.body.append(f'<div class="math"{ids}>{label}{body}</div>')
    raise nodes.SkipNode


def setup(app) -> dict:
    app.connect("source-read", _source_read)
    app.add_html_math_renderer("mathml", (_visit_math, None), (_visit_displaymath, None))
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
