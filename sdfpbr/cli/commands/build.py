"""``sdfpbr build CHARTS -o OUT``: render a gallery of chart entries through the image cache."""
from __future__ import annotations

import argparse


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "build", help="render every entry of a chart directory (gallery, manifest, index.html), cached",
        description="Render every *.toml entry in CHARTS to OUT/<name>.png through a content-addressed "
                    "cache; write OUT/manifest.json and OUT/index.html. A rebuild renders only what changed.")
    p.add_argument("charts", metavar="CHARTS", help="directory of chart, [compare] and [sweep] entries")
    p.add_argument("--shard", metavar="I/N", type=_shard,
                   help="render only shard I of N (every N-th entry from the I-th) with a partial manifest, "
                        "for a CI matrix; join the shards with --merge")
    p.add_argument("--merge", metavar="DIR", nargs="+",
                   help="render nothing: join these shard directories into OUT (manifest.json, index.html)")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="output directory (created)")
    p.add_argument("-j", "--jobs", type=int, default=1, metavar="N",
                   help="render in N processes (0: one per CPU; default 1)")
    p.add_argument("--force", action="store_true", help="render every image, ignoring cached ones")
    p.add_argument("-v", "--verbose", action="store_true", help="keys and timings")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(run=run)


def _shard(text: str) -> tuple[int, int]:
    i, slash, n = text.partition("/")
    try:
        shard = (int(i), int(n)) if slash else None
    except ValueError:
        shard = None
    if shard is None or not 1 <= shard[0] <= shard[1]:
        raise argparse.ArgumentTypeError(f"must be I/N with 1 <= I <= N (e.g. 2/4), got {text!r}")
    return shard


def run(args: argparse.Namespace) -> int:
    import functools
    import sys

    from ...errors import SpecError
    from ...features.gallery.build import build, merge
    log = None if args.quiet else functools.partial(print, file=sys.stderr, flush=True)
    if args.merge:
        if args.shard or args.force or args.jobs != 1:
            raise SpecError("--merge renders nothing: leave out --shard, --force and -j")
        manifest = merge(args.charts, args.merge, args.output, log=log)
        print(f"{args.output}: {len(manifest['images'])} images merged from {len(args.merge)} shards")
        return 0
    manifest = build(args.charts, args.output, jobs=args.jobs, force=args.force, log=log, verbose=args.verbose,
                     shard=args.shard)
    n = len(manifest["images"])
    print(f"{args.output}: {n} images ({manifest['rendered']} rendered, {manifest['cached']} cached) "
          f"in {manifest['elapsed_s']:.1f} s")
    if args.verbose:
        print(f"  GL: {', '.join(manifest['gl_renderers'])}")
    return 0
