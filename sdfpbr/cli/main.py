"""The ``sdfpbr`` command: parse, call the API, map errors to one line and an exit status."""
from __future__ import annotations

import argparse
import difflib
import re
import sys
import time

from ..errors import SdfpbrError, SpecError


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line with a suggestion, and exit status 2."""

    def error(self, message: str):
        m = re.search(r"unrecognized arguments: (\S+)", message)
        if m:
            known = [s for a in self._actions for s in a.option_strings]
            for sub in self._subparsers._group_actions if self._subparsers else []:
                for p in getattr(sub, "choices", {}).values():
                    known += [s for a in p._actions for s in a.option_strings]
            close = difflib.get_close_matches(m.group(1).split("=")[0], known, n=1)
            if close:
                message += f" (did you mean {close[0]}?)"
        raise SpecError(f"{self.prog}: {message}")


def add_chart_options(p: argparse.ArgumentParser) -> None:
    """The spec flags every rendering command shares (chart, shader, reference, compare, ...)."""
    p.add_argument("--spec", metavar="FILE.toml", help="a TOML spec; flags given here override it")
    p.add_argument("--rows", type=int)
    p.add_argument("--cols", type=int)
    p.add_argument("--size", metavar="WxH", help="render area in pixels (default 1024x1024)")
    p.add_argument("--roughness", metavar="LO:HI", help="perceptual roughness across the columns (default 0:1)")
    p.add_argument("--metallic", metavar="LO:HI", help="metallic down the rows (default 0:1)")
    p.add_argument("--base-color", metavar="R,G,B", help="linear base colour (default 0.75,0.75,0.75)")
    p.add_argument("--materials", metavar="NAME,...", help="per-row presets: gold, copper, silver, iron, aluminium")
    p.add_argument("--env", metavar="NAME|FILE", help="studio, sky, uniform, black, or an .exr/.npy equirect map")
    p.add_argument("--env-intensity", type=float)
    p.add_argument("--lights", choices=("default", "none"))
    p.add_argument("--no-shadows", dest="shadows", action="store_false", default=None)
    p.add_argument("--no-ao", dest="ao", action="store_false", default=None)
    p.add_argument("--no-ground", dest="ground", action="store_false", default=None)
    p.add_argument("--no-ibl", dest="ibl", action="store_false", default=None)
    p.add_argument("--no-multiscatter", dest="multiscatter", action="store_false", default=None)
    p.add_argument("--no-labels", dest="labels", action="store_false", default=None)
    p.add_argument("--tonemap", help="none, clamp, reinhard, reinhard-extended, aces, aces-hill, neutral")
    p.add_argument("--exposure", type=float, metavar="EV")
    p.add_argument("--spp", type=int, help="samples per pixel")
    p.add_argument("--brdf", help="gltf (default) or schlick-ggx")
    p.add_argument("--camera", help="perspective or orthographic")
    p.add_argument("--intersect", help="auto, analytic or march")
    p.add_argument("--quality", help="draft, default, high, or seed002 (shared seed 002's approach)")
    p.add_argument("--bug", dest="bugs", action="append", metavar="NAME",
                   help="switch on a catalogued PBR mistake (repeatable; `sdfpbr bugs` lists them)")
    p.add_argument("--textures", help="none or procedural (riveted panels: normal, ORM, base colour maps)")
    p.add_argument("--base-color-texture", metavar="PNG", help="sRGB base colour map for the spheres")
    p.add_argument("--orm-texture", metavar="PNG", help="linear occlusion/roughness/metallic map")
    p.add_argument("--normal-texture", metavar="PNG", help="linear tangent-space normal map, OpenGL +Y")
    p.add_argument("--transparent", action="store_true", default=None, help="transparent background")
    p.add_argument("--azimuth", dest="camera_azimuth", type=float, metavar="DEG", help="camera orbit angle around the grid (default 0)")
    p.add_argument("--elevation", dest="camera_elevation", type=float, metavar="DEG", help="camera elevation (default 8)")
    p.add_argument("--title")
    p.add_argument("--backend", help="auto (EGL, then OSMesa), egl or osmesa")
    p.add_argument("--device-index", type=int, help="EGL device by enumeration order")


def spec_from_args(args: argparse.Namespace):
    from ..spec.chart_spec import ChartSpec, load_spec, make_spec, parse_color, parse_range, parse_size
    base = load_spec(args.spec) if args.spec else ChartSpec()
    o = {}
    for name in ("rows", "cols", "env", "env_intensity", "lights", "shadows", "ao", "ground", "ibl",
                 "multiscatter", "labels", "tonemap", "exposure", "spp", "brdf", "camera", "intersect",
                 "quality", "transparent", "title", "backend", "device_index", "camera_azimuth",
                 "camera_elevation", "textures", "base_color_texture", "orm_texture", "normal_texture"):
        value = getattr(args, name)
        if value is not None:
            o[name] = value
    if args.size is not None:   # an explicit empty value is an error, not "unset"
        o["width"], o["height"] = parse_size(args.size)
    if args.roughness is not None:
        o["roughness"] = parse_range(args.roughness, "--roughness")
    if args.metallic is not None:
        o["metallic"] = parse_range(args.metallic, "--metallic")
    if args.base_color is not None:
        o["base_color"] = parse_color(args.base_color)
    if args.bugs:
        o["bugs"] = tuple(base.bugs) + tuple(b for b in args.bugs if b not in base.bugs)
    if args.materials is not None:
        o["row_materials"] = tuple(m.strip() for m in args.materials.split(","))
        o.setdefault("rows", len(o["row_materials"]))
    return make_spec(base, **o)


def cmd_chart(args) -> int:
    if args.frames is not None:
        from ..tools.animate import cmd_chart_animation
        return cmd_chart_animation(args)
    from ..api import chart
    from ..image.io import HDR_SUFFIXES, check_writable
    spec = spec_from_args(args)
    # Check every destination before spending time on the render.
    check_writable(args.output, (".png",), "output")
    if args.hdr:
        check_writable(args.hdr, HDR_SUFFIXES, "--hdr")
    if args.aov:
        check_writable(args.aov, (".npz",), "--aov")
    start = time.perf_counter()
    result = chart(spec, aovs=bool(args.aov))
    result.save(args.output, hdr=args.hdr, aov=args.aov)
    if args.verbose:
        t = result.result.timings
        print(f"{args.output}: {spec.width}x{spec.height}, render {t['render_s']*1e3:.0f} ms, "
              f"setup {t['setup_s']*1e3:.0f} ms, total {time.perf_counter() - start:.2f} s on {result.renderer}")
    return 0


def cmd_shader(args) -> int:
    from ..gpu.render import chart_source, display_source
    spec = spec_from_args(args)
    source = display_source(spec) if args.display else chart_source(spec)
    sys.stdout.write(source.text)
    return 0


def cmd_doctor(args) -> int:
    from ..gpu.gl import INSTALL_HINT, doctor
    reports = doctor(args.device_index or 0)
    for r in reports:
        if r.ok:
            print(f"{r.backend:7s} ok    {r.vendor} | {r.renderer} | {r.version}")
        else:
            print(f"{r.backend:7s} FAIL  {r.error}")
    if not any(r.ok for r in reports):
        print(f"no backend works: {INSTALL_HINT}")
        return 3
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__
    parser = _Parser(prog="sdfpbr", description="Physically based material charts, rendered headless.")
    parser.add_argument("--version", action="version", version=f"sdfpbr {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("chart", help="render a labeled roughness x metallic chart")
    p.add_argument("-o", "--output", default="chart.png", help="PNG path (default chart.png)")
    p.add_argument("--hdr", metavar="PATH", help="also write linear radiance as .npy or .exr")
    p.add_argument("--aov", metavar="PATH.npz", help="also write normal, depth, row, col, roughness, metallic, ndotv")
    p.add_argument("-v", "--verbose", action="store_true")
    p.add_argument("--frames", type=int, metavar="N", help="render an N-frame orbit animation instead (-o .gif, .webp or .mp4)")
    p.add_argument("--orbit", choices=("light", "camera"), default="light", help="what turns in the animation (default light)")
    p.add_argument("--fps", type=float, default=15.0, help="animation frames per second (default 15)")
    add_chart_options(p)
    p.set_defaults(run=cmd_chart)

    p = sub.add_parser("shader", help="print the composed fragment shader for a spec")
    p.add_argument("--display", action="store_true", help="the tone-mapping program instead of the chart program")
    add_chart_options(p)
    p.set_defaults(run=cmd_shader)

    p = sub.add_parser("doctor", help="try each GL backend and report what it gives")
    p.add_argument("--device-index", type=int)
    p.set_defaults(run=cmd_doctor)

    # Further subcommands live one per module in sdfpbr/cli/commands/: each has
    # register(subparsers) that adds its parser and sets run=.
    import importlib
    import pkgutil
    from . import commands
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        importlib.import_module(f"{commands.__name__}.{info.name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return args.run(args)
    except SdfpbrError as exc:
        print(f"sdfpbr: error: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        print("sdfpbr: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
