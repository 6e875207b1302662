"""``sdfpbr stress``: seeded sweeps over the edges (see sdfpbr/devtools/stress/ for the checks)."""
import argparse

FULL_COUNT = 10_000
QUICK_COUNT = 300


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def register(sub) -> None:
    from ..main import SEED
    p = sub.add_parser("stress", help="render thousands of edge-case configurations and check each one",
                       description="Seeded sweeps over roughness, metallic, base colour, silhouettes, exposure, "
                                   "light intensity, camera distance, sphere geometry, grid and image size, "
                                   "half/single-float targets and backends. Exit status 1 if any check fails.")
    p.add_argument("--quick", action="store_true", help=f"the CI subset ({QUICK_COUNT} configurations, small images)")
    p.add_argument("--count", type=_positive, help=f"configurations (default {FULL_COUNT}, --quick {QUICK_COUNT}; "
                   "very small counts are rounded up so that every kind of check runs)")
    p.add_argument("--seed", type=SEED, default=0, help="the sweep is a pure function of the seed (default 0)")
    p.add_argument("--backend", choices=("all", "egl", "osmesa"), default="all", help="backends to sweep (default all)")
    p.add_argument("--failures", metavar="DIR", help="write each failing configuration here as a TOML spec")
    p.add_argument("--json", metavar="PATH", help="also write the summary as JSON")
    p.add_argument("--cache-dir", metavar="DIR", help="keep the sweep's IBL bakes here (default: a temporary "
                   "directory, removed afterwards, so thousands of edge-case bakes stay out of your cache)")
    p.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    p.set_defaults(run=run)


def run(args) -> int:
    import json
    import tempfile
    from pathlib import Path

    from ...cache import ArrayCache

    from ...errors import OutputError
    from ...files import atomic_file
    from ...image.io import check_writable
    from ...devtools.stress.cases import generate_cases
    from ...devtools.stress.runner import make_sessions, run_sweep

    failures_dir = None
    if args.failures:
        failures_dir = Path(args.failures)
        try:
            failures_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"cannot create --failures directory {failures_dir}: {exc.strerror or exc}") from None
        check_writable(failures_dir / "probe.toml", what="--failures directory")
    if args.json:
        check_writable(args.json, (".json",), "--json")
    count = args.count or (QUICK_COUNT if args.quick else FULL_COUNT)
    backends = ("egl", "osmesa") if args.backend == "all" else (args.backend,)
    cases = generate_cases(args.seed, count, quick=args.quick, backends=backends)
    with tempfile.TemporaryDirectory(prefix="sdfpbr-stress-") as tmp:
        sessions, notes = make_sessions(cases, ArrayCache(Path(args.cache_dir or tmp)))
        if not sessions:
            from ...errors import GLUnavailable
            raise GLUnavailable("no backend could start: " + "; ".join(notes))
        report = run_sweep(cases, sessions, notes, seed=args.seed, failures_dir=failures_dir,
                           progress=args.progress)
    print(report.format())
    if failures_dir is not None and report.failures:
        print(f"{len(report.failures)} failing configurations written to {failures_dir}/ as TOML specs")
    if args.json:
        with atomic_file(args.json) as f:
            f.write(json.dumps(report.to_json(), indent=1, default=float).encode())
    return 1 if report.failures else 0
