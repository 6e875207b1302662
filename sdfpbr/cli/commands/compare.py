"""``sdfpbr compare``: two specs, one catalogued bug, or the catalog, as a captioned sheet.

    sdfpbr compare A.toml B.toml -o out.png        A | B | FLIP difference
    sdfpbr compare --bug NAME -o cmp.png           correct | buggy | FLIP difference
    sdfpbr compare --bug NAME --frames 36 -o cmp.gif   the pair, orbiting
    sdfpbr compare --bugs all -o bugs.png          the catalog, pages bugs-1.png ... (or --bugs NAME,NAME)
"""
from __future__ import annotations

import argparse

from ...spec.bugs import BUG_MEASURE_SIZE as DEFAULT_PANEL   # --bug: three panels at the bug figures' size


def register(subparsers) -> None:
    from ...features.compare import BUGS_PER_PAGE, CATALOG_PANEL
    from ..main import add_animation_options, add_chart_options
    p = subparsers.add_parser(
        "compare", help="compare two specs, or a catalogued bug with the correct chart (FLIP difference)",
        description="Render two charts side by side with their LDR-FLIP difference map and the mean "
                    "FLIP printed on each sphere. Chart flags set the base spec (for two spec files "
                    "they override both files).",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n", 1)[1])
    p.add_argument("specs", nargs="*", metavar="SPEC.toml", help="two spec files: A (reference) and B")
    p.add_argument("--bugs", dest="bugs_sheet", metavar="all|NAME,...",
                   help="contact sheet of the whole catalog or of these bugs, a row per bug")
    p.add_argument("--per-page", type=int, metavar="N", default=BUGS_PER_PAGE,
                   help=f"--bugs: at most N bugs a page; more make pages OUT-1.png, OUT-2.png, ... "
                        f"(default {BUGS_PER_PAGE}; 0: every bug on one sheet)")
    p.add_argument("-o", "--output", help="PNG (or .gif/.webp/.mp4 with --frames); "
                                          "default compare.png, compare-NAME.png or bugs.png")
    p.add_argument("--labels", metavar="A,B", help="panel labels for two spec files (default: the file names)")
    p.add_argument("--caption", help="caption for two spec files (default: the fields that differ)")
    p.add_argument("--panel-size", type=int, metavar="PX",
                   help=f"render each panel with this longer edge (--bug default {DEFAULT_PANEL} unless "
                        f"--size/--spec give one; --bugs default {CATALOG_PANEL})")
    add_animation_options(p, "with --bug: an N-frame orbit animation of the pair")
    p.add_argument("-v", "--verbose", action="store_true", help="print the mean and per-sphere FLIP")
    add_chart_options(p)   # its --bug NAME (repeatable) names the bug to compare
    p.set_defaults(run=run)


def _mode(args) -> str:
    from ...errors import SpecError
    from ..main import check_still_options
    chosen = [m for m, on in (("files", bool(args.specs)), ("bug", bool(args.bugs)), ("bugs", args.bugs_sheet))
              if on]
    if not chosen:
        raise SpecError("nothing to compare: give A.toml B.toml, --bug NAME or --bugs all|NAME,...")
    if len(chosen) > 1:
        raise SpecError("give only one of: two spec files, --bug NAME, --bugs all|NAME,...")
    if args.specs and len(args.specs) != 2:
        raise SpecError(f"compare takes two spec files (A.toml B.toml), got {len(args.specs)}")
    if args.bugs and len(args.bugs) != 1:
        raise SpecError("--bug compares one bug; for several use --bugs NAME,NAME")
    if args.frames is not None and chosen[0] != "bug":
        raise SpecError("--frames animates a --bug comparison only")
    check_still_options(args)
    if args.specs and args.spec:
        raise SpecError("--spec sets the base of --bug/--bugs; with two spec files leave it out")
    return chosen[0]


def _panel_size(args, default: int) -> int | None:
    """Explicit --panel-size wins; else the spec's size if --size/--spec chose one; else ``default``."""
    if args.panel_size is not None:
        return args.panel_size
    return None if (args.size or args.spec) else default


def run(args) -> int:
    import time

    from ...shading.compose import modules_fixed
    start = time.perf_counter()
    mode = _mode(args)
    if mode == "bug" and args.frames is not None:
        return _animate_bug(args, start)
    with modules_fixed():   # a catalog composes each of its ~50 charts' programs several times
        sheets = {"files": _files, "bug": _bug, "bugs": _contact_sheet}[mode](args)
    for sheet, output in sheets:
        sheet.save(output)
    if len(sheets) > 1:   # the outputs are not the -o name: say what they are
        import sys
        print(f"sdfpbr: note: {len(sheets)} pages: {', '.join(str(o) for _, o in sheets)}", file=sys.stderr)
    for sheet, output in sheets if args.verbose else ():
        h, w = sheet.image.shape[:2]
        print(f"{output}: {w}x{h}, {len(sheet.specs)} renders, {time.perf_counter() - start:.2f} s "
              f"on {sheet.renderer}")
        print(sheet.summary())
    return 0


def _files(args):
    """A.toml | B.toml | difference; the chart flags override both files."""
    from pathlib import Path

    from ..main import spec_from_args
    from ...features.compare import at_panel_size, compare_specs
    from ...errors import SpecError
    from ...image.io import check_writable
    labels = (Path(args.specs[0]).stem, Path(args.specs[1]).stem)
    if args.labels:
        labels = tuple(s.strip() for s in args.labels.split(","))
        if len(labels) != 2 or not all(labels):
            raise SpecError(f"--labels must be two labels A,B, got {args.labels!r}")
    specs = []
    for path in args.specs:
        args.spec = path
        specs.append(at_panel_size(spec_from_args(args), args.panel_size))
    output = args.output or "compare.png"
    check_writable(output, (".png",), "output")
    return [(compare_specs(specs[0], specs[1], labels, args.caption or ""), output)]


def _bug_spec(args):
    """(bug name, base spec): the chart flags without the --bug, which names the comparison."""
    from ...spec.bugs import get_bug
    from ..main import spec_from_args
    from ...features.compare import at_panel_size
    name = get_bug(args.bugs[0]).name
    args.bugs = None
    return name, at_panel_size(spec_from_args(args), _panel_size(args, DEFAULT_PANEL))


def _bug(args):
    from ...features.compare import compare_bug
    from ...image.io import check_writable
    name, spec = _bug_spec(args)
    output = args.output or f"compare-{name}.png"
    check_writable(output, (".png",), "output")
    return [(compare_bug(spec, name), output)]


def _contact_sheet(args):
    """The catalog's pages: OUT itself for one page, else OUT-1.png, OUT-2.png, ..."""
    from pathlib import Path

    from ...spec.bugs import BUGS, get_bug
    from ..main import spec_from_args
    from ...features.compare import CATALOG_PANEL, bug_catalog, catalog_pages
    from ...errors import SpecError
    from ...image.io import check_writable
    names = list(BUGS) if args.bugs_sheet.strip() == "all" else \
        [get_bug(n.strip()).name for n in args.bugs_sheet.split(",") if n.strip()]
    if names == []:
        raise SpecError(f"--bugs needs 'all' or bug names; allowed: {', '.join(BUGS)}")
    if args.per_page is None or args.per_page < 0:
        raise SpecError(f"--per-page must be 0 (one sheet) or a positive whole number, got {args.per_page}")
    per_page = args.per_page or len(names)
    spec = spec_from_args(args)
    output = Path(args.output or "bugs.png")
    check_writable(output, (".png",), "output")
    count = len(catalog_pages(names, per_page))
    outputs = [output] if count == 1 else [output.with_name(f"{output.stem}-{i}{output.suffix}")
                                           for i in range(1, count + 1)]
    for path in outputs[1:]:
        check_writable(path, (".png",), "output")
    # Measured where --bug measures: at the size --size/--spec chose, else at the bug figures' size.
    pages = bug_catalog(spec, names, per_page=per_page, panel_size=args.panel_size or CATALOG_PANEL,
                        measure_size=None if (args.size or args.spec) else DEFAULT_PANEL, progress=True)
    return list(zip(pages, outputs))


def _animate_bug(args, start: float) -> int:
    import time

    from ...features.animate import animate_compare, check_animation_output, orbit_specs
    name, spec = _bug_spec(args)
    output = args.output or f"compare-{name}.gif"
    orbit_specs(spec, args.frames, args.orbit)
    check_animation_output(output, args.fps, args.lossless)
    animation = animate_compare(spec, name, args.frames, args.orbit, output=output, fps=args.fps,
                                progress=True, lossless=args.lossless)
    if args.verbose:
        (w, h), n = animation.size, animation.count
        print(f"{output}: {n} frames {w}x{h} at {args.fps:g} fps, orbit {args.orbit}, "
              f"{time.perf_counter() - start:.2f} s")
    return 0
