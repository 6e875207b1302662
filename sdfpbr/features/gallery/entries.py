"""Gallery entries: a TOML document (a chart spec, a [compare] or a [sweep]) -> the images it
makes, fully resolved and validated before anything is rendered.

What an entry may read is confined to a tree (``root``): for ``sdfpbr build ENTRIES`` the
entries folder (``collect``), for the Sphinx directive the docs source tree (sphinxext). Every
file an entry names (``env``, a texture, ``gltf``, a ``[compare]`` a/b file, a ``[sweep]`` value
of such a field, and the files an a/b file names in turn) is a path relative to the file that
names it (the entry's folder; an a/b file's own folder), which must lie inside the tree with
symlinks resolved (``inside``: sdfpbr.inputs.confined). An absolute path, a URI, a '..' or a
symlink that leads out is refused in one line, in the same words whether the outside file
exists or not; nothing is looked up from the working directory. An entry file in the entries
folder that is a symlink out is refused the same way."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from ...errors import SpecError
from ...inputs import check_input, confined, outside_refusal, plain_relative
from ...spec.chart_spec import ChartSpec, entry_refusal, spec_from_mapping
from ...spec.checks import text
from ...spec.presets import MAX_CAPTION
from ...spec.fields import (ENTRY_SECTIONS, field_value, names_file, read_entry_document, resolve_field, split_entry,
                            sweep_defaults)
from ...spec.toml_file import read_toml


@dataclass(frozen=True)
class Item:
    """One image of a gallery, fully resolved: what to render and everything its key covers."""
    name: str                       # output stem: OUT/<name>.png
    entry: str                      # where it came from (file name, or docname:line)
    kind: str                       # chart, compare, compare-specs, bug-sheet or sweep
    document: dict                  # the entry document this image is made from
    specs: tuple[ChartSpec, ...]    # every spec the image renders
    caption: str
    params: dict                    # what the gallery prints beside the image
    base: ChartSpec | None = None   # comparisons and sweeps: the [spec] base
    bug: str = ""                   # compare: the bug
    bug_names: tuple[str, ...] = ()
    page: int = 0                   # bug-sheet: its page of the catalog of bug_names (compare.catalog_pages)
    labels: tuple[str, ...] = ()
    sweep_field: str = ""
    sweep_values: tuple = ()

    @property
    def canonical(self) -> str:
        return json.dumps(self.document, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)


def spec_identity(spec: ChartSpec) -> str:
    """A spec as canonical JSON text: two specs with the same text render the same chart."""
    return json.dumps(spec.to_dict(), sort_keys=True, default=str)


def _catalog():
    try:
        from ...spec import bugs
    except ImportError:
        raise SpecError("comparison entries need the bug catalog (sdfpbr.bugs), which this install lacks") from None
    return bugs


def _spec_overrides(spec: ChartSpec) -> dict:
    """The keys where ``spec`` differs from the defaults: a short parameter list for people."""
    default = ChartSpec().to_dict()
    return {k: v for k, v in spec.to_dict().items() if default.get(k) != v}


def _table(data: dict, key: str, where: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise SpecError(f"{where}: {key} must be a table ([{key}]), got {value!r}")
    return value


def _text(value, what: str, where: str) -> str:
    """An entry's text (a caption): spec.checks.text's rules, at most MAX_CAPTION characters."""
    try:
        return text(value, what, MAX_CAPTION)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None


def inside(root: str | Path, base_dir: str | Path, name: str, what: str) -> Path:
    """``base_dir / name`` (``name`` as an entry gives it, relative to ``base_dir``, a folder in
    the tree ``root``) if it lies inside ``root`` with symlinks resolved; a SpecError otherwise,
    in the same words whether or not the outside file exists (sdfpbr.inputs.confined). The
    path is returned as named, not resolved: specs and messages show it as before."""
    refusal = outside_refusal(root, name, what)
    if not plain_relative(name):
        raise refusal
    tree, base = os.path.realpath(root), os.path.realpath(base_dir)
    rel = os.path.relpath(base, tree)
    if rel == os.pardir or rel.startswith(os.pardir + os.sep) or os.path.isabs(rel):
        raise refusal          # the folder itself lies outside (an entries folder outside the tree)
    try:
        confined(tree, name if rel == os.curdir else os.path.join(rel, name), what)
    except SpecError:
        raise refusal from None
    return Path(base_dir) / name


def named_files(mapping: dict, base_dir: Path, root: Path, where: str) -> dict:
    """``mapping`` with every file a spec key names (env, a texture, gltf: fields.names_file,
    under any spelling of the key) replaced by its path beside ``base_dir``, confined to
    ``root`` (``inside``)."""
    out = dict(mapping)
    for key, value in mapping.items():
        try:
            field = resolve_field(key).name if isinstance(key, str) else key
        except SpecError:
            continue           # an unknown key: spec_from_mapping names it
        if names_file(field, value):
            out[key] = str(inside(root, base_dir, value, f"{where}: {key}"))
    return out


def parse_entry(data: dict, where: str, base_dir: Path, stem: str, root: str | Path | None = None) -> list[Item]:
    """The images one entry document describes. Raises SpecError naming ``where``. Files it
    names are relative to ``base_dir`` and confined to ``root`` (default: ``base_dir``)."""
    root = Path(base_dir if root is None else root)
    spec_keys, entry = split_entry(data, where)
    caption = _text(entry.get("caption", ""), "caption", where)
    section = next((k for k in ENTRY_SECTIONS if k in entry), None)
    if section is None:
        spec = spec_from_mapping(named_files(spec_keys, base_dir, root, where), where=where)
        return [Item(stem, where, "chart", data, (spec,), caption or spec.title,
                     {"spec": _spec_overrides(spec)})]
    base = spec_from_mapping(named_files(spec_keys, base_dir, root, f"{where} [spec]"), where=f"{where} [spec]")
    table = _table(entry, section, where)
    if section == "sweep":
        return [_sweep_item(data, table, base, caption, where, stem, base_dir, root)]
    return _compare_items(data, table, base, caption, where, base_dir, stem, root)


def _sweep_defaults(attr: str, where: str) -> list:
    try:
        return list(sweep_defaults(attr))
    except SpecError:
        raise SpecError(f"{where}: [sweep] over {attr} needs values") from None


def _sweep_item(data, table, base, caption, where, stem, base_dir, root) -> Item:
    unknown = sorted(set(table) - {"field", "values"})
    if unknown:
        raise SpecError(f"{where}: unknown [sweep] key {unknown[0]!r}; allowed: field, values")
    name = _text(table.get("field"), "[sweep] field", where)
    try:   # the field first: a misspelt one is the mistake to name, whatever its values
        attr = resolve_field(name).name
    except SpecError as exc:
        raise SpecError(f"{where}: [sweep] {exc}") from None
    # No values: the field's own (a tone mapper added to the table joins the gallery's sweep).
    values = table["values"] if "values" in table else _sweep_defaults(attr, where)
    if not isinstance(values, list) or not values:
        raise SpecError(f"{where}: [sweep] values must be a non-empty list, got {values!r}")
    if attr == "size":
        raise SpecError(f"{where}: sweep width or height, not size")
    specs, parsed = [], []
    for value in values:
        if names_file(attr, value):   # a file, as any the entry names: beside it, inside the tree
            value = str(inside(root, base_dir, value, f"{where}: [sweep] values"))
        spec = spec_from_mapping({name: value}, base, where=f"{where} [sweep]")
        specs.append(spec)
        parsed.append(field_value(spec, attr))
    default = caption or f"The same chart across {attr.replace('_', ' ')}: {', '.join(map(str, values))}."
    return Item(stem, where, "sweep", data, tuple(specs), default,
                {"sweep": attr, "values": values, "spec": _spec_overrides(base)}, base,
                sweep_field=attr, sweep_values=tuple(parsed))


def _compare_items(data, table, base, caption, where, base_dir, stem, root) -> list[Item]:
    unknown = sorted(set(table) - {"bug", "bugs", "a", "b", "labels", "page"})
    if unknown:
        raise SpecError(f"{where}: unknown [compare] key {unknown[0]!r}; allowed: bug, bugs, a, b, labels, page")
    if "page" in table and (table.get("bugs") in (None, "each")):
        raise SpecError(f"{where}: [compare] page goes with bugs = \"all\" or a list of bug names")
    forms = [k for k in ("bug", "bugs", "a") if k in table]
    if len(forms) != 1 or (("a" in table) != ("b" in table)):
        raise SpecError(f"{where}: [compare] needs exactly one of bug = NAME, bugs = \"all\"|\"each\"|[NAMES], "
                        f"or a = FILE and b = FILE")
    overrides = _spec_overrides(base)
    if "a" in table:
        paths = [_text(table[k], f"[compare] {k}", where) for k in ("a", "b")]
        labels = table.get("labels", [Path(p).stem for p in paths])
        if not (isinstance(labels, list) and len(labels) == 2 and all(isinstance(s, str) for s in labels)):
            raise SpecError(f"{where}: [compare] labels must be two strings, got {labels!r}")
        specs = tuple(_compare_spec(p, k, base_dir, root, where, base) for p, k in zip(paths, "ab"))
        from ..compare import check_comparable   # here: its renders need not load to collect charts
        try:
            check_comparable(*specs)             # at collection, before anything renders
        except SpecError as exc:
            raise SpecError(f"{where}: {exc}") from None
        default = caption or f"{labels[0]} vs {labels[1]}."
        return [Item(stem, where, "compare-specs", data, specs, default,
                     {"a": paths[0], "b": paths[1], "spec": overrides}, base, labels=tuple(labels))]
    if "labels" in table:
        raise SpecError(f"{where}: [compare] labels go with a and b")
    bugs = _catalog()
    if "bug" in table:
        bug = _bug(bugs, table["bug"], where)
        return [_bug_item(stem, where, data, base, bug, caption, overrides)]
    names = table["bugs"]
    if names == "each":
        items = []
        for bug in bugs.BUGS.values():
            doc = {**data, "compare": {"bug": bug.name}}
            items.append(_bug_item(f"{stem}-{bug.name}", where, doc, base, bug, caption, overrides))
        return items
    if names == "all":
        chosen = list(bugs.BUGS.values())
    elif isinstance(names, list) and names:
        chosen = [_bug(bugs, n, where) for n in names]
    else:
        raise SpecError(f"{where}: [compare] bugs must be \"all\", \"each\" or a list of bug names, got {names!r}")
    from ..compare import catalog_pages   # here: its renders need not load to collect charts
    names = tuple(b.name for b in chosen)
    pages = catalog_pages(names)
    default = caption or "Every bug of the catalog against the correct chart."
    chosen_page = table.get("page")
    if chosen_page is not None and (isinstance(chosen_page, bool) or chosen_page not in range(1, len(pages) + 1)):
        raise SpecError(f"{where}: [compare] page must be a whole number from 1 to {len(pages)}, got {chosen_page!r}")
    items = []
    for i, page in enumerate(pages, 1):   # a page-sized sheet each: STEM.png, or STEM-1.png, STEM-2.png, ...
        if chosen_page is not None and i != chosen_page:
            continue
        specs = [s for name in page for s in _bug_specs(base, name)]
        unique = tuple({spec_identity(s): s for s in specs}.values())
        doc = data if len(pages) == 1 or chosen_page else {**data, "compare": {**table, "page": i}}
        one = len(pages) == 1 or chosen_page
        items.append(Item(stem if one else f"{stem}-{i}", where, "bug-sheet", doc, unique, default,
                          {"bugs": page, "spec": overrides}, base, bug_names=names, page=i))
    return items


def _bug(bugs, name, where):
    if not isinstance(name, str):
        raise SpecError(f"{where}: a bug name must be text, got {name!r}")
    try:
        return bugs.get_bug(name)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None


def _bug_specs(base: ChartSpec, name: str) -> tuple[ChartSpec, ChartSpec]:
    """(correct, buggy) exactly as the comparison renders them."""
    from ..compare import bug_pair
    _, correct, buggy = bug_pair(base, name)
    return correct, buggy


def _bug_item(name, where, doc, base, bug, caption, overrides) -> Item:
    specs = _bug_specs(base, bug.name)
    return Item(name, where, "compare", doc, specs, caption or bug.caption,
                {"bug": bug.name, "summary": bug.summary, "spec": overrides}, base, bug=bug.name)


def _compare_spec(name: str, key: str, base_dir: Path, root: Path, where: str, base: ChartSpec) -> ChartSpec:
    """The spec a [compare] a/b file describes over ``base`` (as chart_spec.load_spec reads it),
    the file and every file it names confined to ``root``."""
    path = inside(root, base_dir, name, f"{where}: [compare] {key}")
    check_input(path, f"{where}: [compare] file", "spec")   # missing, a FIFO, a device: one line
    spec_mapping, entry = read_entry_document(path)
    refusal = entry_refusal(path, entry)   # a [compare] or [sweep] entry is no spec to compare
    if refusal is not None:
        raise SpecError(f"{where}: [compare] {key}: {refusal}")
    inner = f"{path} [spec]" if "spec" in entry else str(path)
    return spec_from_mapping(named_files(spec_mapping, path.parent, root, inner), base, where=inner)


def load_entry(path: Path, root: str | Path | None = None) -> list[Item]:
    """The images of the entry file ``path``; the files it names are confined to ``root``
    (default: its folder)."""
    return parse_entry(read_toml(path, "entry"), str(path), path.parent, path.stem, root)


def collect(chart_dir: str | Path, root: str | Path | None = None) -> list[Item]:
    """Every image of the gallery in ``chart_dir``, validated before anything is rendered.
    What the entries read is confined to ``root`` (default, and what ``sdfpbr build`` uses:
    ``chart_dir`` itself; module docstring)."""
    folder = Path(chart_dir)
    if not folder.is_dir():
        raise SpecError(f"chart directory {folder} does not exist" if not folder.exists()
                        else f"{folder} is not a directory of chart entries")
    tree = folder if root is None else Path(root)
    real_tree, real_folder = os.path.realpath(tree), os.path.realpath(folder)
    if real_folder != real_tree and not real_folder.startswith(real_tree.rstrip(os.sep) + os.sep):
        raise SpecError(f"chart directory {folder} is outside the folder {str(tree)!r}; only files inside it are read")
    files = []
    for path in sorted(folder.glob("*.toml")):
        if path.is_symlink():   # refused if it leads out, whether or not its target exists
            inside(tree, folder, path.name, f"{folder}: entry")
        if path.is_file():
            files.append(path)
    if not files:
        raise SpecError(f"{folder} holds no *.toml chart entries")
    items, seen = [], {}
    for path in files:
        for item in load_entry(path, tree):
            if item.name in seen:
                raise SpecError(f"{path}: image {item.name}.png is also made by {seen[item.name]}")
            seen[item.name] = path.name
            items.append(item)
    return items
