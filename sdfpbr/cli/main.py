"""The ``sdfpbr`` command: parse, call the API, map errors to one line and an exit status."""
from __future__ import annotations

import argparse
import functools
import re
import sys
import time

from ..errors import OutputError, SdfpbrError, SpecError, did_you_mean


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line with a suggestion, exit status 2, and '_' in an
    option name is the same as '-' (``--base_color`` is ``--base-color``), as in TOML keys.
    It keeps its own record of the arguments it was given (``arguments``, ``subcommands``) so
    that suggestions and generated options never read argparse's internals."""

    def __init__(self, *args, **kwargs):
        self.arguments: list[argparse.Action] = []   # before argparse adds --help through add_argument
        super().__init__(*args, **kwargs)
        self.subcommands: dict[str, "Parser"] = {}
        self.dash_values: set[str] = set()   # options whose value may start with '-' (sweep --values -2,0,2)

    def add_argument(self, *args, **kwargs):
        action = super().add_argument(*args, **kwargs)
        self.arguments.append(action)
        return action

    def add_subparsers(self, **kwargs):
        action = super().add_subparsers(**kwargs)
        self.arguments.append(action)
        add_parser = action.add_parser

        def record(name, **kw):
            parser = add_parser(name, **kw)
            self.subcommands[name] = parser
            return parser
        action.add_parser = record
        return action

    def add_to_group(self, group, *args, **kwargs) -> argparse.Action:
        """add_argument into an argument group (a heading in --help), recorded as the parser's own."""
        action = group.add_argument(*args, **kwargs)
        self.arguments.append(action)
        return action

    def option_strings(self) -> set[str]:
        return {s for a in self.arguments for s in a.option_strings}

    def parse_known_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        cut = args.index("--") if "--" in args else len(args)
        args = [_dashed(a) for a in args[:cut]] + args[cut:]
        # "--values -2,0,2" -> "--values=-2,0,2": argparse reads a value that starts with '-'
        # as an option unless it is a plain negative number (another option stays one).
        joined, i = [], 0
        while i < len(args):
            if (args[i] in self._dash_value_options() and i + 1 < cut
                    and re.match(r"-[\d.]", args[i + 1])):
                joined.append(f"{args[i]}={args[i + 1]}")
                i += 2
            else:
                joined.append(args[i])
                i += 1
        return super().parse_known_args(joined, namespace)

    def _dash_value_options(self) -> set[str]:
        return self.dash_values.union(*(p.dash_values for p in self.subcommands.values()))

    def error(self, message: str):
        m = re.search(r"unrecognized arguments: (\S+)", message)
        if m:
            known = self.option_strings().union(*(p.option_strings() for p in self.subcommands.values()))
            word = m.group(1).split("=")[0]
            message += did_you_mean(word, sorted(known - {word}))   # another command's flag is no suggestion
        m = re.search(r"argument (.+?): invalid choice: '(.*?)' \(choose from", message)
        if m:
            action = next((a for a in self.arguments if m.group(1) in ("/".join(a.option_strings), a.metavar, a.dest)),
                          None)
            choices = list(getattr(action, "choices", None) or [])
            if m.group(1) == "command":
                message = (f"unknown command {m.group(2)!r}{did_you_mean(m.group(2), choices)}; "
                           f"commands: {', '.join(choices)}")
            else:
                message += did_you_mean(m.group(2), choices)
        # main() prints "sdfpbr: error: "; a subcommand's messages name the subcommand.
        sub = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        raise SpecError(f"{sub}: {message}" if sub else message)


def whole_number(lo: int, hi: int):
    """An argparse type: an integer in [lo, hi] (a usage error, one line, otherwise)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [{lo}, {hi}], got {value}")
        return value
    return parse


SEED = whole_number(0, 2**32 - 1)   # numpy's seeds are non-negative 32-bit words


def _dashed(arg: str) -> str:
    if not arg.startswith("--"):
        return arg
    name, eq, value = arg.partition("=")
    return name.replace("_", "-") + eq + value


def add_animation_options(p: Parser, frames_help: str) -> None:
    """--frames, --orbit, --fps and --lossless, for every command that animates."""
    from ..spec.presets import DEFAULT_FPS, ORBITS, WEBP_QUALITY
    p.add_argument("--frames", type=int, metavar="N", help=frames_help)
    p.add_argument("--orbit", choices=ORBITS, default=ORBITS[0],
                   help=f"what turns in the animation (default {ORBITS[0]})")
    p.add_argument("--fps", type=float, default=DEFAULT_FPS,
                   help=f"animation frames per second (default {DEFAULT_FPS:g})")
    p.add_argument("--lossless", action="store_true",
                   help="WebP animation frames stored exactly "
                        f"(about 4x larger than the default quality {WEBP_QUALITY})")


def check_still_options(args) -> None:
    """A command that draws a still image (no --frames) was given no animation-only flag."""
    if args.lossless and args.frames is None:
        raise SpecError("--lossless applies to animations: give --frames N and -o NAME.webp")


def add_chart_options(p: Parser) -> None:
    """The spec flags every rendering command shares (chart, shader, reference, compare, ...):
    one per field of the spec table, named as the field, plus its aliases. A flag the command
    already defines for itself (compare's --bugs and --labels) is left to the command."""
    from ..spec.fields import FIELDS, HELP_GROUPS
    p.add_argument("--spec", metavar="FILE.toml", help="a TOML spec; flags given here override it")
    taken = p.option_strings()
    used_dests = {a.dest for a in p.arguments}
    dests = {}
    headings = {title: p.add_argument_group(f"chart: {title}") for title, _ in HELP_GROUPS}
    groups = {name: headings[title] for title, names in HELP_GROUPS for name in names}
    by_name = {f.name: f for f in FIELDS}
    for f in (by_name[name] for _, names in HELP_GROUPS for name in names):
        add = functools.partial(p.add_to_group, groups[f.name])
        dest = f.name if f.name not in used_dests else f"spec_{f.name}"
        if f.kind == "bool":
            on = [o for o in f.option_strings if o not in taken]
            off = [o for o in ("--no-" + o[2:] for o in f.option_strings) if o not in taken]
            for opts, value in ((on, True), (off, False)):
                if opts:   # the help goes on the flag that changes the default, saying what it does
                    add(*opts, dest=dest, action="store_const", const=value, default=None,
                                   help=f"{'turn on' if value else 'turn off'}: {f.help} "
                                        f"({'on' if f.default else 'off'} by default)"
                                   if value != f.default else argparse.SUPPRESS)
        else:
            opts = [o for o in f.option_strings if o not in taken]
            if not opts:
                continue
            default = "" if f.default in (None, "", ()) or f.kind == "lights" else f" (default {f.to_text(f.default)})"
            add(*opts, dest=dest, metavar=f.metavar, default=None,
                           action="append" if f.kind == "bugs" else "store",
                           help=f.help + default + ("; repeatable" if f.kind == "bugs" else ""))
            if f.numeric:   # `--x-values -1,0,1`, `--exposure -2`: values, not options
                p.dash_values.update(opts)
        dests[f.name] = dest
    p.set_defaults(spec_dests=dests)


def spec_from_args(args: argparse.Namespace):
    """The spec the chart flags describe: --spec (or the defaults) with each given flag on top;
    --bug adds to the spec file's bugs rather than replacing them."""
    from ..spec.chart_spec import ChartSpec, load_spec, make_spec
    from ..spec.fields import field_value_from_text, resolve_field
    base = load_spec(args.spec) if args.spec else ChartSpec()
    o = {}
    for name, dest in getattr(args, "spec_dests", {}).items():
        value = getattr(args, dest, None)
        if value is None:   # not given (an explicit empty value is given, and checked)
            continue
        if resolve_field(name).kind == "bugs":
            added = tuple(b for v in value for b in field_value_from_text(name, v))
            o[name] = tuple(base.bugs) + tuple(b for b in dict.fromkeys(added) if b not in base.bugs)
        elif isinstance(value, bool):
            o[name] = value
        else:
            o[name] = field_value_from_text(name, value)
    return make_spec(base, **o)


def cmd_chart(args) -> int:
    check_still_options(args)
    if args.frames is not None:
        from ..features.animate import cmd_chart_animation
        return cmd_chart_animation(spec_from_args(args), args)
    from ..api import chart
    from ..image.io import check_outputs
    spec = spec_from_args(args)
    check_outputs(spec, args.output, args.hdr, args.aov)   # before spending time on the render
    if spec.gltf:   # say what of the asset the chart leaves out, so no image is silently partial
        from ..spec.gltf import gltf_materials
        for what in gltf_materials(spec.gltf, spec.gltf_materials).ignored:
            print(f"sdfpbr: note: {what} is not charted", file=sys.stderr)
    start = time.perf_counter()
    from ..gpu.render import check_memory
    from ..gpu.session import default_session
    from ..progress import Ticker
    # A refusal is one line, before any progress line: the memory is checked before the GL
    # context is made and again after (a driver may reserve much address space), then timed.
    check_memory(spec, bool(args.aov), bool(args.hdr))
    session = default_session(spec.backend, spec.device_index)
    check_memory(spec, bool(args.aov), bool(args.hdr))
    with Ticker(f"sdfpbr chart {spec.width}x{spec.height}"):   # silent unless it takes a while
        result = chart(spec, hdr=bool(args.hdr), aovs=bool(args.aov), session=session)
        result.save(args.output, hdr=args.hdr, aov=args.aov)
    if args.verbose:
        t = result.result.timings
        print(f"{args.output}: {spec.width}x{spec.height}, render {t['render_s']*1e3:.0f} ms, "
              f"setup {t['setup_s']*1e3:.0f} ms, total {time.perf_counter() - start:.2f} s on {result.renderer}")
    return 0


def cmd_shader(args) -> int:
    from ..shading.plan import render_plan
    programs = render_plan(spec_from_args(args)).frame_programs()
    if args.display and args.program not in ("chart", "display"):   # chart: --program's default
        raise SpecError(f"--display is --program display; give one of them, not --program {args.program} too")
    name = "display" if args.display else args.program
    if name not in programs:
        raise SpecError(f"this chart runs no {name} program; it runs: {', '.join(programs)}")
    sys.stdout.write(programs[name].text)
    return 0


def cmd_doctor(args) -> int:
    from ..gpu.gl import INSTALL_HINT, doctor
    from ..gpu.session import chart_shader_for
    reports = doctor(args.device_index or 0)
    for r in reports:
        if r.ok:   # and which program draws the chart there (session.chart_shader_for)
            print(f"{r.backend:7s} ok    {r.vendor} | {r.renderer} | {r.version} | chart: "
                  f"{chart_shader_for(r.renderer)} shader")
        else:
            print(f"{r.backend:7s} FAIL  {r.error}")
    if not any(r.ok for r in reports):
        print(f"no backend works: {INSTALL_HINT}")
        return 3
    return 0


BUILTIN_COMMANDS = ("chart", "shader", "doctor")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The whole parser, or with ``command`` (a command's name) that command's parser alone:
    six commands add the chart's ~90 options each, and the modules behind them import what
    they run (~45 ms of a cold `sdfpbr chart`). An unknown name builds them all, so the error
    lists every choice."""
    import importlib
    import pkgutil

    from .. import __version__
    from . import commands
    parser = Parser(prog="sdfpbr", description="Physically based material charts, rendered headless.")
    parser.add_argument("--version", action="version", version=f"sdfpbr {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    modules = sorted(info.name for info in pkgutil.iter_modules(commands.__path__))
    if command in BUILTIN_COMMANDS or command in modules:
        wanted = {command}
    else:
        wanted = {*BUILTIN_COMMANDS, *modules}

    if "chart" in wanted:
        add_chart_command(sub)
    if "shader" in wanted:
        add_shader_command(sub)
    if "doctor" in wanted:
        p = sub.add_parser("doctor", help="try each GL backend and report what it gives")
        p.add_argument("--device-index", type=int)
        p.set_defaults(run=cmd_doctor)

    # Further subcommands live one per module in sdfpbr/cli/commands/, named as the command:
    # each has register(subparsers) that adds its parser and sets run=.
    for name in modules:
        if name in wanted:
            importlib.import_module(f"{commands.__name__}.{name}").register(sub)
    return parser


CHART_EXAMPLES = """examples:
  sdfpbr chart -o chart.png                                    the default 5x5 chart
  sdfpbr chart --y-axis clearcoat --base-color 0.6,0.05,0.05 -o coat.png
  sdfpbr chart --materials gold,copper,silver,iron -o metals.png
  sdfpbr chart --env sky.hdr --lights none --size 768x768 -o sky.png
  sdfpbr chart --bugs unsquared-roughness -o bug.png           a PBR mistake switched on
  sdfpbr chart --gltf charts/materials.glb -o m.png            a glTF asset's materials
  sdfpbr chart --spec charts/default.toml --title "My chart" -o mine.png"""


def add_chart_command(sub) -> None:
    p = sub.add_parser("chart", help="render a labeled roughness x metallic chart",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=CHART_EXAMPLES)
    p.add_argument("-o", "--output", default="chart.png", help="PNG path (default chart.png)")
    p.add_argument("--hdr", metavar="PATH", help="also write linear radiance as .npy or .exr")
    p.add_argument("--aov", metavar="PATH.npz",
                   help="also write normal, depth, row, col, roughness, metallic, ndotv, coverage")
    p.add_argument("-v", "--verbose", action="store_true", help="print the image's size, render and set-up times")
    add_animation_options(p, "render an N-frame orbit animation instead (-o .gif, .webp or .mp4)")
    add_chart_options(p)
    p.set_defaults(run=cmd_chart)


def add_shader_command(sub) -> None:
    p = sub.add_parser("shader", help="print the composed source of a program a chart runs")
    p.add_argument("--program", default="chart", metavar="NAME",
                   help="chart (default) or another program a frame of the chart runs, e.g. display, "
                        "chart-edges or a cells-stage prepass (sphere-prepass holds the sphere's shading when the "
                        "chart has one); a name the chart does not run is answered with those it does")
    p.add_argument("--display", action="store_true", help="the tone-mapping program (--program display)")
    add_chart_options(p)
    p.set_defaults(run=cmd_shader)


def main(argv: list[str] | None = None) -> int:
    stdout = sys.stdout
    sys.stdout = _StandardOutput(stdout)
    try:
        _interrupts_unwind()
        argv = sys.argv[1:] if argv is None else list(argv)
        args = build_parser(argv[0] if argv else None).parse_args(argv)
        status = args.run(args)
        sys.stdout.flush()   # a full stdout fails here, where it is reported
        return status
    except SdfpbrError as exc:
        print(f"sdfpbr: error: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        return _interrupted()
    except MemoryError:   # what check_memory could not foresee (another process took it first)
        print("sdfpbr: error: out of memory: render a smaller chart", file=sys.stderr)
        return 2
    except BrokenPipeError:   # stdout closed early (`sdfpbr cache -v | head`): stop quietly
        _drop_stdout()
        return 1
    except Exception:
        if not _interrupts:
            raise
        return _interrupted()   # a library turned the interrupt into an error of its own
    finally:
        sys.stdout = stdout


def _interrupted() -> int:
    print("sdfpbr: interrupted", file=sys.stderr)
    # A -j build's process pool, torn down by the interrupt, can race CPython 3.11's exit hook
    # (concurrent.futures' _python_exit wakes a manager thread whose pipe just closed: EBADF,
    # printed as "Exception ignored in: <module 'threading'>" after this line). Nothing is
    # left to report once interrupted.
    sys.unraisablehook = lambda unraisable: None
    return 130


_interrupts: list[int] = []   # the Ctrl-Cs main() was sent


def _interrupt(signum, frame) -> None:
    _interrupts.append(signum)
    raise KeyboardInterrupt


def _interrupts_unwind() -> None:
    """Ctrl-C raises KeyboardInterrupt from here on (the entry module exits at once until
    now), so that what is half done is cleaned up on the way out and said in one line. It is
    also recorded: a library may turn the KeyboardInterrupt into an error of its own (numpy's
    import into an ImportError), which is then an interrupt all the same."""
    import signal
    import threading
    if threading.current_thread() is threading.main_thread() and \
            signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _interrupt) or _is_quiet():
        signal.signal(signal.SIGINT, _interrupt)


def _is_quiet() -> bool:
    import signal
    from .entry import is_quiet
    return is_quiet(signal.getsignal(signal.SIGINT))


class _StandardOutput:
    """sys.stdout while a command runs: a write or flush that fails (a full disk, a file size
    limit) is an OutputError, said in one line as any output file's is, and the rest of what
    was buffered is dropped (no second failure at exit). A closed pipe stays a BrokenPipeError;
    everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream

    def _reported(self, call, *args):
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            _drop_stdout()
            raise OutputError(f"cannot write standard output: {exc.strerror or exc}") from None

    def write(self, text: str) -> int:
        return self._reported(self._stream.write, text)

    def flush(self) -> None:
        self._reported(self._stream.flush)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _drop_stdout() -> None:
    """Point stdout at /dev/null, so that nothing buffered fails again at exit."""
    import os
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.__stdout__.fileno())
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    sys.exit(main())
