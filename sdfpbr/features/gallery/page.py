"""The static gallery page: the images in sections by kind, each with its caption and
parameters; all text escaped.

A card is as wide as its image needs to be read (up to the whole row), never wider than the
image itself, and only as tall as its own content: a tall card does not stretch its row."""
from __future__ import annotations

import html
import json
import math
from typing import Any
from urllib.parse import quote


RANGES = ("roughness", "metallic")   # (lo, hi) pairs: one value when lo == hi


def param_text(value: Any, key: str = "") -> str:
    if isinstance(value, (list, tuple)):
        if not value:
            return "none"
        if key in RANGES and len(value) == 2 and value[0] == value[1]:
            return param_text(value[0])
        return ", ".join(param_text(v) for v in value)
    if isinstance(value, dict):
        return "; ".join(f"{k} = {param_text(v, k)}" for k, v in value.items())
    return str(value)


# The page's sections, in order (an image kind each): what a newcomer wants first, the charts
# (the default chart leads), then sweeps and comparisons, the bug catalog's pages last.
SECTIONS = (
    ("chart", "Charts", "One chart each."),
    ("sweep", "Sweeps", "The same chart across the values of one setting."),
    ("compare-specs", "Comparisons", "Two charts and their LDR-FLIP difference."),
    ("compare", "Bug comparisons",
     "One bug of the catalog each: the correct chart, the chart with the bug, and their LDR-FLIP difference."),
    ("bug-sheet", "Bug catalog", "The catalog on page-sized sheets, a row per bug."),
)
KIND_ORDER = tuple(kind for kind, _, _ in SECTIONS)
OTHER = ("Other images", "")

# Grid columns are at least COLUMN_PX wide; an image spans as many as its own width needs (a
# sweep or a comparison sheet is read near its own size), the whole row past FULL_ROW_COLUMNS.
COLUMN_PX = 420
FULL_ROW_COLUMNS = 3


def page_order(images: list[dict]) -> list[dict]:
    def key(image):
        kind = KIND_ORDER.index(image["kind"]) if image["kind"] in KIND_ORDER else len(KIND_ORDER)
        return (kind, image["name"] != "default")
    return sorted(images, key=key)   # stable: the manifest's order within a kind


def columns_needed(width: int) -> int:
    """Grid columns an image of ``width`` px spans: 1, 2, or FULL_ROW_COLUMNS (the whole row)."""
    return min(FULL_ROW_COLUMNS, max(1, math.ceil(width / (COLUMN_PX * 1.25))))


_CSS = f"""
body {{ background: #181818; color: #ddd; font: 15px/1.45 system-ui, sans-serif; margin: 2em; }}
h1 {{ font-weight: 500; margin-bottom: 0.2em; }}
h2 {{ font-weight: 500; margin: 1.6em 0 0.2em; border-bottom: 1px solid #333; padding-bottom: 0.2em; }}
nav a, h2 a {{ color: #9cf; text-decoration: none; }} nav a {{ margin-right: 1.2em; }}
.intro {{ color: #aaa; margin: 0 0 0.9em; }}
.gallery {{ display: grid; grid-template-columns: repeat(auto-fill, minmax({COLUMN_PX}px, 1fr)); gap: 1.5em;
           align-items: start; grid-auto-flow: row dense; }}
.span2 {{ grid-column: span 2; }} .span{FULL_ROW_COLUMNS} {{ grid-column: 1 / -1; }}
@media (max-width: {2 * COLUMN_PX + 120}px) {{ .span2, .span{FULL_ROW_COLUMNS} {{ grid-column: auto; }} }}
figure {{ margin: 0; background: #222; padding: 0.8em; border-radius: 6px; min-width: 0; }}
figure img {{ width: 100%; height: auto; display: block; margin: 0 auto; }}
figcaption {{ margin-top: 0.6em; }}
dl {{ display: grid; grid-template-columns: max-content 1fr; gap: 0.1em 0.8em; font-size: 13px; color: #aaa; }}
dt {{ color: #888; }} dd {{ margin: 0; word-break: break-word; }}
.name {{ font-family: monospace; color: #9cf; }}
details {{ font-size: 12px; color: #999; }} summary {{ cursor: pointer; }}
pre {{ white-space: pre-wrap; word-break: break-all; }}
"""


def _figure(image: dict) -> str:
    e = html.escape
    params = "".join(
        f"<dt>{e(str(k))}</dt><dd>{e(param_text(v))}</dd>"
        for k, v in image["params"].items() if v not in ({}, [], "")
    )
    specs = e("\n".join(json.dumps(spec, ensure_ascii=False) for spec in image["specs"]))   # a line each
    src = e(quote(image["image"]))
    span = columns_needed(int(image["width"]))
    wide = f' class="span{span}"' if span > 1 else ""
    return (
        f'<figure id="{e(image["name"])}"{wide}>\n'
        f'  <a href="{src}" title="full size ({image["width"]} x {image["height"]} px)">'
        f'<img src="{src}" loading="lazy" width="{image["width"]}" height="{image["height"]}" '
        f'style="max-width: {int(image["width"])}px" alt="{e(image["caption"] or image["name"])}"></a>\n'
        f'  <figcaption><span class="name">{e(image["name"])}</span> '
        f'<small>({e(image["entry"])})</small><br>{e(image["caption"])}\n'
        f'    <details><summary>parameters</summary><dl>{params}</dl><pre>{specs}</pre></details></figcaption>\n'
        f'</figure>'
    )


def gallery_html(manifest: dict) -> str:
    """A static page: the images in sections by kind (SECTIONS), each with its caption and
    parameters; all text escaped."""
    e = html.escape
    titles = {kind: (title, intro) for kind, title, intro in SECTIONS}
    sections: dict[str, list[dict]] = {}
    for image in page_order(manifest["images"]):
        sections.setdefault(image["kind"] if image["kind"] in titles else "other", []).append(image)
    nav, body = [], []
    for kind, images in sections.items():
        title, intro = titles.get(kind, OTHER)
        anchor = f"section-{kind}"
        nav.append(f'<a href="#{anchor}">{e(title)} ({len(images)})</a>')
        body.append(f'<h2 id="{anchor}">{e(title)}</h2>\n' + (f'<p class="intro">{e(intro)}</p>\n' if intro else "")
                    + '<div class="gallery">\n' + "\n".join(_figure(i) for i in images) + "\n</div>")
    renderers = e(", ".join(manifest["gl_renderers"]))
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
        f"<title>sdfpbr gallery</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f"<h1>sdfpbr gallery</h1>\n<p>{len(manifest['images'])} images from {e(manifest['charts'])}, "
        f"sdfpbr {e(manifest['sdfpbr'])}, rendered with {renderers}. Click an image for its full size.</p>\n"
        f"<nav>{' '.join(nav)}</nav>\n" + "\n".join(body) + "\n</body>\n</html>\n"
    )
