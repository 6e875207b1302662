"""The static gallery page: every image with its caption and parameters; all text escaped."""
from __future__ import annotations

import html
import json
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


_CSS = """
body { background: #181818; color: #ddd; font: 15px/1.4 system-ui, sans-serif; margin: 2em; }
h1 { font-weight: 500; }
.gallery { display: grid; grid-template-columns: repeat(auto-fill, minmax(340px, 1fr)); gap: 1.5em; }
figure { margin: 0; background: #222; padding: 0.8em; border-radius: 6px; }
figure img { width: 100%; height: auto; display: block; }
figcaption { margin-top: 0.6em; }
dl { display: grid; grid-template-columns: max-content 1fr; gap: 0.1em 0.8em; font-size: 13px; color: #aaa; }
dt { color: #888; } dd { margin: 0; word-break: break-word; }
.name { font-family: monospace; color: #9cf; }
details { font-size: 12px; color: #999; } pre { white-space: pre-wrap; }
"""


# The page leads with what a newcomer wants first: the default chart, then the other single
# charts and sweeps, then the bug comparisons, and the contact sheet of them all last.
KIND_ORDER = ("chart", "sweep", "compare", "bug-sheet")


def page_order(images: list[dict]) -> list[dict]:
    def key(image):
        kind = KIND_ORDER.index(image["kind"]) if image["kind"] in KIND_ORDER else len(KIND_ORDER)
        return (image["name"] != "default", kind)
    return sorted(images, key=key)   # stable: the manifest's order within a kind


def gallery_html(manifest: dict) -> str:
    """A static page: every image with its caption and parameters; all text escaped."""
    e = html.escape
    figures = []
    for image in page_order(manifest["images"]):
        params = "".join(
            f"<dt>{e(str(k))}</dt><dd>{e(param_text(v))}</dd>"
            for k, v in image["params"].items() if v not in ({}, [], "")
        )
        specs = e("\n".join(json.dumps(spec, ensure_ascii=False) for spec in image["specs"]))   # a line each
        src = e(quote(image["image"]))
        figures.append(
            f'<figure id="{e(image["name"])}">\n'
            f'  <a href="{src}"><img src="{src}" loading="lazy" width="{image["width"]}" height="{image["height"]}" '
            f'alt="{e(image["caption"] or image["name"])}"></a>\n'
            f'  <figcaption><span class="name">{e(image["name"])}</span> '
            f'<small>({e(image["entry"])}, {e(image["kind"])})</small><br>{e(image["caption"])}\n'
            f'    <dl>{params}</dl>\n'
            f'    <details><summary>specs</summary><pre>{specs}</pre></details></figcaption>\n'
            f'</figure>'
        )
    renderers = e(", ".join(manifest["gl_renderers"]))
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>sdfpbr gallery</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f"<h1>sdfpbr gallery</h1>\n<p>{len(manifest['images'])} images from {e(manifest['charts'])}, "
        f"sdfpbr {e(manifest['sdfpbr'])}, rendered with {renderers}.</p>\n"
        f"<div class=\"gallery\">\n" + "\n".join(figures) + "\n</div>\n</body>\n</html>\n"
    )
