"""``sdfpbr sweep FIELD``: the same chart across the values of one spec field, as one sheet.

    sdfpbr sweep tonemap                          every tone mapper
    sdfpbr sweep exposure --values -2,0,2         exposures in EV
    sdfpbr sweep env --values studio,sky,uniform  environments
    sdfpbr sweep roughness --values 0:0.5,0.5:1   any spec field
"""
from __future__ import annotations

import argparse

DEFAULT_PANEL = 384   # without --size/--spec/--panel-size: a sheet of 384 px panels, not 1024


def register(subparsers) -> None:
    from ..main import add_chart_options
    p = subparsers.add_parser(
        "sweep", help="the same chart across tone mappers, exposures, environments, ... as one sheet",
        description="Render the chart once per value of one spec field and lay the renders out as "
                    "one labeled sheet. Chart flags set everything else.",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n", 1)[1])
    from ...spec.fields import SWEEP_FIELDS
    p.add_argument("field", help="tonemap, exposure, env, or any other spec field (e.g. brdf, quality)")
    p.add_argument("--values", metavar="V,...", help=f"values to show (default for {', '.join(SWEEP_FIELDS)}: "
                                                     f"all / -2..2 EV / 0..90 degrees)")
    p.add_argument("--columns", type=int, metavar="N", help="panels per row (default: at most four)")
    p.add_argument("--panel-size", type=int, metavar="PX",
                   help=f"render each panel with this longer edge "
                        f"(default {DEFAULT_PANEL} unless --size/--spec give one)")
    p.add_argument("-o", "--output", help="PNG path (default sweep-FIELD.png)")
    p.add_argument("-v", "--verbose", action="store_true")
    add_chart_options(p)
    p.dash_values.add("--values")   # `--values -2,0,2` is a value, not an option
    p.set_defaults(run=run)


def run(args) -> int:
    import time

    from ..main import spec_from_args
    from ...features.compare import at_panel_size, sweep
    from ...image.io import check_writable
    from ...spec.chart_spec import make_spec
    from ...spec.fields import resolve_field, sweep_defaults, sweep_values_from_text

    start = time.perf_counter()
    field = resolve_field(args.field).name   # an alias sweeps its field, under the field's name
    values = sweep_values_from_text(field, args.values) if args.values is not None else list(sweep_defaults(field))
    panel_size = args.panel_size
    if panel_size is None and not (args.size or args.spec):
        panel_size = DEFAULT_PANEL
    base = at_panel_size(spec_from_args(args), panel_size)
    for v in values:                      # every value is a valid spec before anything renders
        make_spec(base, **{field: v})
    output = args.output or f"sweep-{field}.png"
    check_writable(output, (".png",), "output")
    sheet = sweep(base, field, values, columns=args.columns, progress=True)
    sheet.save(output)
    if args.verbose:
        h, w = sheet.image.shape[:2]
        print(f"{output}: {w}x{h}, {len(sheet.panels)} panels ({', '.join(p.label for p in sheet.panels)}), "
              f"{time.perf_counter() - start:.2f} s on {sheet.renderer}")
    return 0
