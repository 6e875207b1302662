"""`sdfpbr bench`: render time, compile time, cold start and error against the reference, per
scene and quality preset."""
from __future__ import annotations

import argparse
import importlib

EPILOG = """\
columns:
  render ms   a frame's draws at full size (the stage's prepasses and the chart program), median
              of --repeats after a warm-up; each frame
              between ctx.finish() calls on the wall clock (a GL timer query where it measures
              execution; llvmpipe's does not). '±' is the median absolute deviation.
  compile ms  link of a never-seen program plus its first draw (llvmpipe JIT-compiles there)
  src kB      composed chart source (features a spec leaves out are not in it)
  cold s      fresh `python -m sdfpbr chart` process, Mesa shader cache off, empty sdfpbr cache
  cold* s     the same with the sdfpbr disk cache filled (IBL bakes, LUTs, prepasses): a second run
  start s     the same with Mesa's shader cache warm too: a user's every later run (median of 3)
  FLIP        mean LDR FLIP of the display image vs the reference, whole frame; FLIPsph over
              sphere pixels
  relRMSE     relative RMSE of linear radiance over sphere pixels, sqrt(mean((t-r)^2/(r^2+0.01)))
  noise       FLIP between two references that differ in their seed: FLIP judges when 3x under it
  bias% ±     the worst sphere's mean luminance over the reference's, minus 1 (in %), and the
              two-seed noise of those means (RMS over the spheres): judged when 3x under it
scenes:
{scenes}
--ablation adds rows 'ablation:<feature>' (one feature off on the default scene; 'code gone'
  when no identifier of the feature is left in the source) and 'absent:<case>' (a feature the
  scene cannot use must compose to the same source and time as leaving it out); these are timed
  in 3 interleaved rounds so load changes on a shared machine hit every variant alike.
--baseline times a Shadertoy-style shader (a .glsl file or a document containing one) the same
  way; it draws its own scene, so it has no error figures.
"""


def _list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def register(subparsers) -> None:
    from ..main import SEED
    from ...spec.presets import STAGES
    from ...devtools.bench.suite import SCENE_NOTES, available_presets   # the suite's own lists
    scenes = "\n".join(f"  {name:10s}  {note}" for name, note in SCENE_NOTES.items())
    p = subparsers.add_parser("bench", help="time and error of each quality preset over a scene suite",
                              description="Benchmark render time, compile time, cold start and error "
                                          "against the reference renderer.",
                              epilog=EPILOG.format(scenes=scenes), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true",
                   help="CI size: 256x256, scenes default,bare, presets draft,default, 3 repeats, "
                        "512-sample references (they judge the bias, not FLIP)")
    p.add_argument("--scenes", type=_list, metavar="A,B", help=f"{', '.join(SCENE_NOTES)} (default: all)")
    p.add_argument("--presets", type=_list, metavar="A,B", help=f"{', '.join(available_presets())} (default: all)")
    p.add_argument("--size", metavar="WxH", help="render size (default 1024x1024)")
    p.add_argument("--repeats", type=int, metavar="N", help="timed draws per row (default 5)")
    p.add_argument("--warmup", type=int, metavar="N", help="untimed draws first (default 1)")
    p.add_argument("--ref-samples", type=int, metavar="N",
                   help="reference samples per pixel (default 256, at most 1048576); going on from the "
                        "cached reference of the same seed with the most samples among "
                        "N k/16 (k < 16), N/32, N/64, ...")
    p.add_argument("--seed", type=SEED, default=0, help="reference seed (default 0)")
    p.add_argument("--no-reference", action="store_true", help="skip the error columns")
    p.add_argument("--no-cold", action="store_true", help="skip the cold-process columns")
    p.add_argument("--ablation", action="store_true", help="add the feature ablation rows")
    p.add_argument("--baseline", metavar="FILE", help="also time a Shadertoy-style shader (.glsl or a document)")
    p.add_argument("--end-to-end", action="store_true",
                   help="instead of the scenes: what a chart costs around its draw (the warm API call, "
                        "starts, a gallery build of --charts, an orbit's and an 8192² chart's peak memory), "
                        "each beside its target")
    p.add_argument("--charts", metavar="DIR", default="charts", help="--end-to-end's gallery (default: ./charts)")
    p.add_argument("--random", type=int, metavar="N",
                   help="instead of the scenes: N random one-cell scenes drawn with --seed (the random-scene "
                        "accuracy suite; default size 128x128, presets draft,default,high, references from "
                        "--ref-samples (default 1024) a seed, four times more while too noisy to judge, up to 4096)")
    p.add_argument("--random-stage", choices=STAGES, default="cells",
                   help="the stage --random's scenes stand on (default cells)")
    p.add_argument("--json", metavar="FILE.json",
                   help="write {machine, settings, rows: [...]} as JSON; rows carry every column and more "
                        "(link_ms, first_draw_ms, hdr_flip_mean, per-sphere flip_cells, ref_rel_noise, ...)")
    p.add_argument("--plot", metavar="FILE.png", help="time-vs-error plot (default: beside --json)")
    p.add_argument("--no-plot", action="store_true", help="no plot even with --json")
    p.add_argument("--heatmaps", metavar="DIR", help="write a FLIP heat map per scene and preset")
    p.add_argument("--backend", help="auto (EGL, then OSMesa), egl or osmesa")
    p.add_argument("--peer", metavar="NAME",
                   help="also render the scenes with an independent path tracer (mitsuba: the 'peer' extra) and "
                        "print the reference's validation against it per region and each preset's time to equal "
                        "error (the peer's samples and seconds to reach the preset's FLIP, and their ratio)")
    p.add_argument("--peer-samples", type=int, metavar="N",
                   help="the peer's samples per pixel for the validation, two seeds (default: --ref-samples); "
                        "its error curve runs 1, 4, 16, ... up to N")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    from pathlib import Path

    from ...devtools.bench.report import format_table, write_json, write_plot
    from ...devtools.bench.run import run_bench
    from ...devtools.bench.suite import BenchConfig
    from ...errors import SpecError
    from ...image.io import check_writable
    from ...spec.chart_spec import parse_size

    overrides = {}
    if args.scenes is not None:
        overrides["scenes"] = tuple(args.scenes)
    if args.presets is not None:
        overrides["presets"] = tuple(args.presets)
    if args.size:
        overrides["width"], overrides["height"] = parse_size(args.size)
    for name in ("repeats", "warmup", "ref_samples", "seed", "baseline", "heatmaps", "backend"):
        value = getattr(args, name)
        if value is not None:
            overrides[name] = value
    overrides.update(reference=not args.no_reference, cold=not args.no_cold, ablation=args.ablation)
    if not args.quiet:
        overrides["log"] = lambda line: print(line, file=sys.stderr, flush=True)
    cfg = BenchConfig.quick(**overrides) if args.quick else BenchConfig(**overrides)

    # Every destination is checked before the (long) run.
    if args.json:
        check_writable(args.json, (".json",), "--json")
    if args.end_to_end:
        return _end_to_end(cfg, Path(args.charts), args.json)
    if args.random is not None:
        return _random(args)
    plot = args.plot
    if plot and args.no_reference:
        raise SpecError("--plot draws time against error, which --no-reference does not measure")
    if plot is None and args.json and not args.no_plot and not args.no_reference:
        plot = str(Path(args.json).with_suffix(".png"))
    if args.no_plot:
        plot = None
    if args.peer is not None or args.peer_samples is not None:
        from ...devtools.bench.peer import check_peer
        if args.peer is None:
            raise SpecError("--peer-samples needs --peer")
        if args.no_reference:
            raise SpecError("--peer validates the reference, which --no-reference skips")
        if args.peer_samples is not None and args.peer_samples < 1:
            raise SpecError(f"--peer-samples must be a whole number >= 1, got {args.peer_samples}")
        check_peer(args.peer)
    if plot:
        check_writable(plot, (".png",), "--plot")
        try:
            importlib.import_module("matplotlib")   # only whether it imports matters
        except ImportError:
            from ...extras import missing_extra
            raise missing_extra("metrics", "--plot", "or --no-plot") from None

    report = run_bench(cfg)
    print(format_table(report))
    if args.peer is not None:
        from ...devtools.bench.peer import format_peer, peer_report
        report["peer"] = peer_report(cfg, report, args.peer_samples, cfg.log)
        print("\n" + format_peer(report["peer"]))
    if args.json:
        write_json(args.json, report)
    if plot:
        write_plot(plot, report)
        if not args.quiet:
            print(f"plot: {plot}", file=sys.stderr)
    return 0


def _end_to_end(cfg, charts, json_path) -> int:
    from ...gpu.session import default_session
    from ...devtools.bench.end_to_end import end_to_end_figures, format_figures
    from ...devtools.bench.report import write_json
    from ...devtools.bench.run import machine_info
    from ...devtools.bench.suite import check_config
    check_config(cfg)   # the size and the backend, before anything is measured
    session = default_session(cfg.backend, 0)
    figures = end_to_end_figures(session, cfg, charts)
    print(format_figures(figures))
    if json_path:
        write_json(json_path, {"machine": machine_info(session), "end_to_end": [f.row() for f in figures]})
    return 0


def _random(args) -> int:
    import sys

    from ...devtools.bench.random_suite import RandomConfig, format_random, run_random
    from ...devtools.bench.report import write_json
    from ...devtools.bench.suite import available_presets, pick_choices
    from ...errors import SpecError
    from ...image.io import check_writable
    from ...spec.chart_spec import make_spec, parse_size

    if isinstance(args.random, bool) or args.random < 1:
        raise SpecError(f"--random must be a whole number >= 1, got {args.random}")
    cfg = RandomConfig(count=args.random, seed=args.seed, stage=args.random_stage)
    if args.presets is not None:
        cfg.presets = pick_choices(args.presets, available_presets(), "preset")
    if args.size:
        cfg.size = parse_size(args.size)
    if args.ref_samples is not None:
        if args.ref_samples < 1:
            raise SpecError(f"--ref-samples must be a whole number >= 1, got {args.ref_samples}")
        cfg.ref_samples = args.ref_samples
        cfg.max_ref_samples = max(cfg.max_ref_samples, args.ref_samples)
    if args.backend:
        cfg.backend = args.backend
    cfg.heatmaps = args.heatmaps
    make_spec(width=cfg.size[0], height=cfg.size[1], backend=cfg.backend)   # the size, checked now
    if not args.quiet:
        cfg.log = lambda line: print(line, file=sys.stderr, flush=True)
    if args.json:
        check_writable(args.json, (".json",), "--json")
        cfg.on_scene = lambda partial: write_json(args.json, partial)   # a long run's figures so far
    report = run_random(cfg)
    print(format_random(report))
    if args.json:
        write_json(args.json, report)
    return 0
