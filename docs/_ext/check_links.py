"""Checks every link between the pages of a built HTML site: each relative ``href`` and ``src``
must name a file of the site, and each ``#fragment`` an id on the page it points to. Links to
other sites are not followed (the build machine may have no network).

    python docs/_ext/check_links.py build/docs

Prints one line per broken link and exits 1 if there is any; 0 and a count otherwise.
"""
from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

# Files the theme's search writes at run time, and pages Sphinx links before they exist.
SKIPPED_PAGES = ("_static/", "_sources/")


class Page(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[tuple[str, int]] = []

    def handle_starttag(self, tag, attrs) -> None:
        for name, value in attrs:
            if name in ("id", "name") and value:
                self.ids.add(value)
            if value and ((name == "href" and tag in ("a", "link")) or (name == "src" and tag in ("img", "script"))):
                self.links.append((value, self.getpos()[0]))


def parse(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8", errors="replace"))
    return page


def broken_links(site: Path) -> tuple[list[str], int]:
    pages = {p: parse(p) for p in sorted(site.rglob("*.html"))
             if not any(part in p.relative_to(site).as_posix() for part in SKIPPED_PAGES)}
    broken, count = [], 0
    for path, page in pages.items():
        for link, line in page.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith("//"):
                continue   # another site
            count += 1
            target = path if not parts.path else (path.parent / unquote(parts.path)).resolve()
            if target.is_dir():
                target = target / "index.html"
            where = f"{path.relative_to(site)}:{line}: {link}"
            if not target.is_file():
                broken.append(f"{where}: no such file")
                continue
            fragment = unquote(parts.fragment)
            if fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else parse(target).ids
                if fragment not in ids:
                    broken.append(f"{where}: no id {fragment!r} on {target.relative_to(site.resolve())}")
    return broken, count


def main(argv: list[str]) -> int:
    if len(argv) != 1 or not Path(argv[0]).is_dir():
        print("usage: python docs/_ext/check_links.py BUILT_HTML_DIR", file=sys.stderr)
        return 2
    site = Path(argv[0]).resolve()
    broken, count = broken_links(site)
    for line in broken:
        print(line)
    print(f"{count} links checked, {len(broken)} broken", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
