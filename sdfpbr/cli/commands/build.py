"""``sdfpbr build CHARTS -o OUT``: render a gallery of chart entries through the image cache."""
from __future__ import annotations

import argparse


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "build", help="render every entry of a chart directory (gallery, manifest, index.html), cached",
        description="Render every *.toml entry in CHARTS to OUT/<name>.png through a content-addressed "
                    "cache; write OUT/manifest.json and OUT/index.html. A rebuild renders only what changed.")
    p.add_argument("charts", metavar="CHARTS", help="directory of chart, [compare] and [sweep] entries")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output directory (created)")
    p.add_argument("-j", "--jobs", type=int, default=1, metavar="N",
                   help="render in N processes (0: one per CPU; default 1)")
    p.add_argument("--force", action="store_true", help="render every image, ignoring cached ones")
    p.add_argument("-v", "--verbose", action="store_true", help="keys and timings")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import functools
    import sys

    from ...tools.gallery.build import build
    log = None if args.quiet else functools.partial(print, file=sys.stderr, flush=True)
    manifest = build(args.charts, args.output, jobs=args.jobs, force=args.force, log=log, verbose=args.verbose)
    n = len(manifest["images"])
    print(f"{args.output}: {n} images ({manifest['rendered']} rendered, {manifest['cached']} cached) "
          f"in {manifest['elapsed_s']:.1f} s")
    if args.verbose:
        print(f"  GL: {', '.join(manifest['gl_renderers'])}")
    return 0
