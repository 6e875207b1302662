"""``sdfpbr cache``: where the on-disk cache is, what it holds by kind, its cap; clear it.

Only sdfpbr's own entries are listed, counted and cleared (sdfpbr.cache: the marker in the
root and sdfpbr's naming); any other file in the folder is left alone."""


def register(sub) -> None:
    p = sub.add_parser("cache", help="list the on-disk cache (bakes, references, built images) or clear it",
                       description="Lists the cache directory ($SDFPBR_CACHE_DIR, else $XDG_CACHE_HOME/sdfpbr) "
                                   "by kind of entry, with its size cap ($SDFPBR_CACHE_MAX: least recently used "
                                   "entries go first). --clear deletes its entries (all, or one --kind); "
                                   "files sdfpbr did not write there are never listed, counted or deleted.")
    p.add_argument("--clear", action="store_true", help="delete the entries (everything unless --kind)")
    p.add_argument("--kind", metavar="KIND", help="only this kind of entry (a subdirectory: ibl, dfg, build, ...)")
    p.add_argument("-v", "--verbose", action="store_true", help="list every entry, least recently used first")
    p.set_defaults(run=run)


def _size(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"


def run(args) -> int:
    import os
    import time
    from pathlib import Path

    from ...cache import MARKER, cache_entries, cache_max, claim, clear, default_cache_dir, kinds as cache_kinds, owned
    from ...errors import SpecError

    root = default_cache_dir()
    if root.exists() and not root.is_dir():
        raise SpecError(f"the cache directory {root} is a file, not a directory: point $SDFPBR_CACHE_DIR "
                        f"at a directory (or unset it)")
    limit = cache_max()
    if root.is_dir() and not owned(root) and not os.environ.get("SDFPBR_CACHE_DIR"):
        try:   # the default location is sdfpbr's by its name: an older version's cache is adopted
            claim(root)
        except OSError:
            pass
    unmarked = root.is_dir() and not owned(root)
    note = (f" (no {MARKER} marker: sdfpbr has not written here, so nothing in it is counted or removed)"
            if unmarked else "")
    kinds = cache_kinds(root) if root.is_dir() else []
    if args.kind is not None and args.kind not in kinds:
        raise SpecError(f"--kind {args.kind!r} is not in the cache; kinds: {', '.join(kinds) or 'none (empty cache)'}")
    if args.clear:
        files, size = clear(root, args.kind) if root.is_dir() else (0, 0)
        print(f"{root / args.kind if args.kind else root}: removed {files} entries, {_size(size)}{note}")
        return 0
    entries = cache_entries(root) if root.is_dir() else []
    print(f"{root}: {len(entries)} entries, {_size(sum(e[1] for e in entries))} "
          f"(cap {_size(limit) if limit is not None else 'none'}, $SDFPBR_CACHE_MAX){note}")
    for kind in kinds if args.kind is None else [args.kind]:
        mine = [e for e in entries if Path(e[0]).relative_to(root).parts[0] == kind]
        print(f"  {kind:16s} {len(mine):6d} entries  {_size(sum(e[1] for e in mine)):>10s}")
        if args.verbose:
            for path, size, used in sorted(mine, key=lambda e: e[2]):
                stamp = time.strftime("%Y-%m-%d %H:%M", time.localtime(used))
                print(f"    {stamp}  {_size(size):>10s}  {path.name}")
    return 0
