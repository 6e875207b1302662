"""``sdfpbr energy``: a white-furnace energy report for every cell of a chart."""


def register(sub) -> None:
    from ..main import add_chart_options
    p = sub.add_parser("energy", help="white-furnace report: each cell against the float64 expectation",
                       description="Renders the spec in a uniform environment of radiance 1 (no lights, ground "
                                   "or AO, one sample per pixel) and compares every sphere pixel with the float64 "
                                   "split-sum expectation at its NdotV. Base colour is white unless --base-color, "
                                   "--materials or the spec file sets one.")
    p.add_argument("--json", metavar="PATH", help="write the table as JSON ('-' for stdout)")
    add_chart_options(p)
    p.set_defaults(run=run)


def run(args) -> int:
    import json

    from ...gpu.session import default_session
    from ..main import spec_from_args
    from ...devtools.energy import (cell_energy, format_table, furnace_is_white, furnace_spec, model_summary,
                                 replaced_settings, to_json)
    from ...files import atomic_file
    from ...image.io import check_writable
    from ...spec.chart_spec import ChartSpec

    spec = spec_from_args(args)
    # White unless the user named a colour (flag, presets, or a spec file that differs from the default).
    white = furnace_is_white(spec, args.base_color is None and not spec.row_materials
                             and spec.base_color == ChartSpec().base_color)
    if args.json and args.json != "-":
        check_writable(args.json, (".json",), "--json")
    replaced = replaced_settings(spec)
    if replaced:
        import sys
        print(f"sdfpbr: note: energy renders a white furnace; it replaces the spec's {', '.join(replaced)}",
              file=sys.stderr)
    spec = furnace_spec(spec, white=white)
    result = default_session(spec.backend, spec.device_index).render(spec)
    cells = cell_energy(result, spec)
    if args.json == "-":
        print(json.dumps(to_json(spec, cells, white), indent=1))
        return 0
    print(format_table(cells))
    print()
    for line in model_summary(cells, white):
        print(line)
    if args.json:
        with atomic_file(args.json) as f:
            f.write(json.dumps(to_json(spec, cells, white), indent=1).encode())
    return 0
