"""``sdfpbr reference``: the path-traced ground truth of a chart, same options as ``chart``.

    sdfpbr reference --samples 256 -o ref.png --hdr ref.npy --aov ref.npz
    sdfpbr reference --target-error 0.01 -o ref.png     until 1 % mean relative standard error
"""
from __future__ import annotations

import argparse


def register(subparsers) -> None:
    from ..main import add_chart_options
    p = subparsers.add_parser(
        "reference", help="path-trace the chart's scene: the ground truth the chart is measured against",
        description="Progressive Monte Carlo path tracing of exactly the chart's scene (same spheres, "
                    "ground, camera, environment, lights and BRDF), with exact visibility, multiple "
                    "importance sampling and a per-pixel standard error. Stops at --samples per pixel "
                    "or at --target-error (mean relative standard error over sphere pixels).",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n", 1)[1])
    p.add_argument("-o", "--output", default="reference.png", help="labeled PNG (default reference.png)")
    p.add_argument("--hdr", metavar="PATH", help="also write linear radiance as .npy or .exr")
    p.add_argument("--aov", metavar="PATH.npz",
                   help="also write the chart's AOVs (normal, depth, row, col, roughness, metallic, ndotv, coverage) "
                        "plus stderr")
    p.add_argument("--samples", type=int, metavar="N",
                   help="samples per pixel (default 64; with --target-error, the most it may take, default 16384)")
    p.add_argument("--target-error", type=float, metavar="E",
                   help="stop once the mean relative standard error over sphere pixels is <= E (e.g. 0.01)")
    p.add_argument("--seed", type=int, default=0, help="random seed; the same seed gives bit-identical output")
    p.add_argument("--bounces", type=int, metavar="B",
                   help="surface interactions per path (default: enough for the light between a white sphere "
                        "and a white floor to converge; 1 = direct light only, no interreflection)")
    p.add_argument("-v", "--verbose", action="store_true", help="print samples, error and timings")
    add_chart_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    import sys
    import time

    from ..main import spec_from_args
    from ...image.io import check_outputs
    from ...features.reference import DEFAULT_MAX_BOUNCES, validate_arguments

    start = time.perf_counter()
    spec = spec_from_args(args)
    bounces = DEFAULT_MAX_BOUNCES if args.bounces is None else args.bounces
    # Everything is checked before the render: a bad argument costs nothing and writes nothing.
    validate_arguments(spec, args.samples, args.target_error, args.seed, bounces)
    check_outputs(spec, args.output, args.hdr, args.aov)

    import json

    from ... import __version__
    from ...gpu.session import default_session
    from ...files import write_group
    from ...image.io import hdr_writer, npz_writer, png_writer
    from ...features.reference import label, render_reference

    session = default_session(spec.backend, spec.device_index)
    result = render_reference(spec, samples=args.samples, target_error=args.target_error, seed=args.seed,
                              max_bounces=bounces, progress=True, session=session)
    metadata = {"Software": f"sdfpbr {__version__}",
                "sdfpbr:spec": json.dumps(spec.to_dict(), sort_keys=True),
                "sdfpbr:reference": json.dumps({"samples": result.samples, "seed": result.seed,
                                                "max_bounces": result.max_bounces,
                                                "mean_relative_stderr": result.error}),
                "sdfpbr:shader-sha256": result.source.digest,
                "sdfpbr:gl-renderer": session.renderer}
    items = [(args.output, png_writer(label(spec, result), metadata))]   # all or none
    if args.hdr:
        items.append((args.hdr, hdr_writer(args.hdr, result.hdr)))
    if args.aov:
        items.append((args.aov, npz_writer({**result.aov, "stderr": result.stderr})))
    write_group(items)
    if result.non_finite:
        print(f"sdfpbr reference: warning: {result.non_finite} non-finite samples were dropped", file=sys.stderr)
    if args.verbose:
        t = result.timings
        print(f"{args.output}: {spec.width}x{spec.height}, {result.samples} spp, {result.max_bounces} bounces, "
              f"mean relative stderr {result.error:.3%} (sphere pixels), render {t['render_s']:.2f} s "
              f"({t['s_per_spp_per_mpx']:.2f} s per spp per Mpx), compile {t['compile_s']:.2f} s, "
              f"total {time.perf_counter() - start:.2f} s on {session.renderer}")
    return 0
