"""Compose GLSL programs from the modules in shaders/.

The composer resolves ``#include`` recursively (each module once) and evaluates every
``#if``/``#elif``/``#else`` itself, so a feature the spec leaves out is absent from the
composed source, not merely disabled. Every name a conditional tests must be an option the
composer was given, and every option value must be one the caller's OptionSchema allows: a
typo fails in Python, before GLSL sees it. The composer knows no option by itself: the schema
(shading.plan.SCHEMA) is the plan's. ``#line`` directives map compiler messages back to
``module.glsl:line``.
"""
from __future__ import annotations

import functools
import hashlib
import os
import re
import stat
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Mapping

from ..errors import ShaderCompileError

GLSL_VERSION = "#version 450 core"

Value = str | int | bool


@dataclass(frozen=True)
class OptionSchema:
    """The options a program family may set: ``choices`` (option -> allowed lower-case words),
    on/off ``flags`` and ``counts`` (emitted as #define), and ``switches``: flags that are off
    unless set, so conditions may test them without every caller naming them."""
    choices: Mapping[str, tuple[str, ...]]
    flags: tuple[str, ...] = ()
    counts: tuple[str, ...] = ()
    switches: tuple[str, ...] = ()


def shader_dir() -> Path:
    """$SDFPBR_SHADER_DIR if set (tests edit a copy of the modules), else shaders/ beside the
    package in a source tree, else the installed sdfpbr.shaders data."""
    override = os.environ.get("SDFPBR_SHADER_DIR")
    if override:
        return _override_shader_dir(override)
    return _installed_shader_dir()


@functools.lru_cache(maxsize=4)
def _override_shader_dir(text: str) -> Path:
    """$SDFPBR_SHADER_DIR, if it holds sdfpbr's shader modules: one line otherwise, not a
    missing-module traceback from deep in a compose."""
    path = Path(text)
    if not (path / "common.glsl").is_file():
        from ..errors import SpecError
        raise SpecError(f"SDFPBR_SHADER_DIR={text!r} holds no sdfpbr shader modules (common.glsl): "
                        f"point it at a copy of the shaders folder, or unset it")
    return path


@functools.lru_cache(maxsize=1)
def _installed_shader_dir() -> Path:
    """Found once a process: resolving it took 0.2 ms, and a gallery build composes ~1500 times."""
    here = Path(__file__).resolve().parents[2] / "shaders"
    if (here / "common.glsl").is_file():
        return here
    # sdfpbr.shaders is a namespace package (no __init__), whose files() is a MultiplexedPath;
    # going through the regular parent package yields a plain filesystem path.
    return Path(resources.files("sdfpbr").joinpath("shaders"))


def validate_options(options: Mapping[str, Value], schema: OptionSchema) -> dict[str, Value]:
    out: dict[str, Value] = {}
    for name, value in options.items():
        if name in schema.choices:
            if value not in schema.choices[name]:
                raise ValueError(f"shader option {name}={value!r}: allowed {', '.join(schema.choices[name])}")
        elif name in schema.flags or name in schema.switches:
            value = bool(value)
        elif name in schema.counts:
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise ValueError(f"shader option {name} must be a non-negative int, got {value!r}")
        else:
            raise ValueError(f"unknown shader option {name}")
        out[name] = value
    return out


@dataclass(frozen=True)
class ComposedSource:
    text: str
    modules: tuple[str, ...]      # files in inclusion order
    options: tuple[tuple[str, Value], ...]

    @functools.cached_property
    def digest(self) -> str:
        """sha256 of the text, hashed once (a program is looked up by it at every render)."""
        return hashlib.sha256(self.text.encode()).hexdigest()

    def locate(self, message: str) -> str:
        """Rewrite the location that starts each line of a driver's compile log as
        ``module.glsl:line``. The drivers' formats (the first number is the source-string
        index that ``#line LINE INDEX`` set, so module ``modules[INDEX - 1]``; 0 is the header):
          Mesa (llvmpipe, radeonsi, iris)  ``1:12(5): error: `x' undeclared``
          NVIDIA                           ``1(12) : error C1503: undefined variable "x"``
          AMD, Intel (Windows), Apple      ``ERROR: 1:12: 'x' : undeclared identifier``
        Only a location at the start of a line (after AMD's ``ERROR:``) is rewritten, so
        numbers in the message text (``vec4(1)``) are left alone.

        Mesa keeps the index for syntax errors but reports 0 for semantic ones (an undeclared
        name, a type mismatch), with the module's own line and column. Such a location is
        resolved against the text: the modules that have that line, narrowed to those whose
        line has the quoted name at that column (or is that long); the header, whose lines are
        source 0 for every driver, counts as one more candidate."""
        where: dict[tuple[int, int], str] = {}   # (source index, line) -> the text of that line
        index, line_no = 0, 1
        for text_line in self.text.split("\n"):
            directive = re.match(r"#line\s+(\d+)\s+(\d+)\s*$", text_line.strip())
            if directive:
                line_no, index = int(directive.group(1)), int(directive.group(2))
                continue
            where[(index, line_no)] = text_line
            line_no += 1

        def name_of(i: int) -> str:
            return self.modules[i - 1] if 1 <= i <= len(self.modules) else "<composed>"

        def resolve(line: int, col: int | None, rest: str) -> str:
            candidates = [i for i in range(len(self.modules) + 1) if (i, line) in where]
            quoted = re.search(r"[`'\"]([A-Za-z_]\w*)['\"]", rest)
            for keep in (
                lambda i: col is not None and quoted is not None
                and where[(i, line)][col - 1:].startswith(quoted.group(1)),
                lambda i: quoted is not None and re.search(rf"\b{quoted.group(1)}\b", where[(i, line)]),
                lambda i: col is None or len(where[(i, line)]) >= col,
            ):
                narrowed = [i for i in candidates if keep(i)]
                if narrowed:
                    candidates = narrowed
                    break
            if not candidates:
                return f"<composed>:{line}"
            return " or ".join(f"{name_of(i)}:{line}" for i in candidates)

        def sub(m: re.Match) -> str:
            i = int(m.group("file"))
            line = int(m.group("line") or m.group("nv_line"))
            col = int(m.group("col")) if m.group("col") else None
            if i == 0 and self.modules:
                place = resolve(line, col, message[m.end():].split("\n", 1)[0])
            else:
                place = f"{name_of(i)}:{line}"
            return m.group("prefix") + place
        return re.sub(r"^(?P<prefix>[ \t]*(?:(?:ERROR|WARNING):[ \t]*)?)(?P<file>\d+)"
                      r"(?::(?P<line>\d+)(?:\((?P<col>\d+)\))?|\((?P<nv_line>\d+)\))",
                      sub, message, flags=re.M)


_TOKEN = re.compile(r"\s*(?:(?P<num>\d+(?:\.\d*)?)|(?P<name>[A-Za-z_]\w*)|(?P<op>==|!=|>=|<=|&&|\|\||[()!<>]))")
_DIRECTIVE = re.compile(r"\s*#\s*(if|elif|else|endif|include)\b\s*(.*)")


@dataclass(frozen=True)
class _Module:
    """A module's text split once into directives and runs of plain lines:
    (line number, directive kind or None, its argument or the run's lines), and for each run
    the upper-case names its code uses (an option may be named there, not only tested).
    ``jump`` and ``end`` are its conditionals' structure, found once: for an #if, #elif or
    #else, the index of the next branch of its chain and of the chain's #endif, so a compose
    steps over a branch not taken instead of walking it line by line. ``read`` is every name
    its conditions read (None where one does not parse: it is reported when evaluated), and
    ``plans`` what a compose does in it (runs to emit, modules to include) by those names'
    values: the same module under the same values is not walked twice."""
    items: tuple[tuple[int, str | None, object], ...]
    names: dict[int, frozenset[str]]      # index of a run in items -> its upper-case names
    jump: dict[int, int]
    end: dict[int, int]
    read: tuple[str, ...] | None
    plans: dict = field(default_factory=dict, compare=False)


_UPPER_NAME = re.compile(r"\b[A-Z_][A-Z0-9_]*\b")


# Parsed modules by path, with the (mtime, size) they were read at: every compose walks the
# same few dozen files, and splitting them line by line was most of a compose's time.
_parsed: dict[str, tuple[tuple[int, int], _Module]] = {}


# Inside modules_fixed() each module file is stat'ed once, at its first use, and taken as
# unchanged after: a gallery build composes ~2 400 programs, and stat'ing each program's
# modules every time (0.16 ms a program) was 0.4 s of its critical path. A build wants one
# version of every module throughout anyway (its image keys were made from them). Outside the
# block an edited module is noticed at the next compose, as before.
class _Fixed:
    def __init__(self):
        self.stamps: dict[str, tuple[int, int] | None] = {}   # module path -> its stamp in the block
        self.checked: set[tuple] = set()                       # composed sources valid in the block


_fixed: _Fixed | None = None


@contextmanager
def modules_fixed():
    """A block in which the shader modules are taken as unchanged (see above); nests."""
    global _fixed
    outer = _fixed
    if outer is None:
        _fixed = _Fixed()
    try:
        yield
    finally:
        if outer is None:
            _fixed = None


def _stamp(path: str) -> tuple[int, int] | None:
    """(mtime, size) of the module file at ``path``; None if there is no such file."""
    fixed = _fixed
    if fixed is not None and path in fixed.stamps:
        return fixed.stamps[path]
    try:
        st = os.stat(path)
        stamp = (st.st_mtime_ns, st.st_size) if stat.S_ISREG(st.st_mode) else None
    except OSError:
        stamp = None
    if fixed is not None:
        fixed.stamps[path] = stamp
    return stamp


def _module(path: str, name: str) -> _Module | None:
    """The parsed module at ``path`` (``name`` in messages); None if there is no such file."""
    stamp = _stamp(path)
    if stamp is None:
        return None
    hit = _parsed.get(path)
    if hit is not None and hit[0] == stamp:
        return hit[1]
    items: list[tuple[int, str | None, object]] = []
    run: list[str] = []
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    for lineno, line in enumerate(lines, start=1):
        directive = _DIRECTIVE.match(line)
        if directive:
            if run:
                items.append((lineno - len(run), None, tuple(run)))
                run = []
            items.append((lineno, directive.group(1), directive.group(2).strip()))
        else:
            run.append(line)
    if run:
        items.append((lineno - len(run) + 1, None, tuple(run)))
    names = {i: frozenset(_UPPER_NAME.findall("\n".join(rest))) for i, (_, kind, rest) in enumerate(items)
             if kind is None}
    module = _Module(tuple(items), names, *_structure(items, name), _condition_names(items, name))
    _parsed[path] = (stamp, module)
    return module


def _condition_names(items: list, name: str) -> tuple[str, ...] | None:
    read: dict[str, None] = {}
    try:
        for lineno, kind, rest in items:
            if kind in ("if", "elif"):
                read.update((v, None) for k, v in _tokens(rest, f"{name}:{lineno}") if k == "name")
    except ValueError:
        return None
    return tuple(read)


def _structure(items: list, name: str) -> tuple[dict[int, int], dict[int, int]]:
    """(jump, end) of a module's conditionals (see _Module); a malformed chain is an error
    wherever it stands, taken or not."""
    jump: dict[int, int] = {}
    end: dict[int, int] = {}
    chains: list[list[int]] = []   # the open chains: indices of their #if, #elif, #else
    for i, (lineno, kind, _) in enumerate(items):
        if kind == "if":
            chains.append([i])
        elif kind in ("elif", "else", "endif"):
            if not chains:
                raise ValueError(f"{name}:{lineno}: #{kind} without #if")
            chain = chains[-1]
            if kind != "endif" and items[chain[-1]][1] == "else":
                raise ValueError(f"{name}:{lineno}: #{kind} after #else")
            chain.append(i)
            if kind == "endif":
                chains.pop()
                for a, b in zip(chain, chain[1:]):
                    jump[a] = b
                for a in chain[:-1]:
                    end[a] = i
    if chains:
        raise ValueError(f"{name}: unterminated #if")
    return jump, end


_tokens_of: dict[str, tuple[tuple[str, str], ...]] = {}
_names_of: dict[str, tuple[str, ...]] = {}   # a condition -> the names it reads, in order
_conditions: dict[tuple, tuple[bool, tuple[str, ...], OptionSchema]] = {}   # see condition()
_ABSENT = object()
_paths: dict[tuple, str] = {}   # (root, module name) -> its path


def _tokens(expr: str, where: str) -> tuple[tuple[str, str], ...]:
    """A condition's tokens as (kind, text), kind num / name / op; parsed once per text."""
    tokens = _tokens_of.get(expr)
    if tokens is None:
        out = []
        text, pos = expr.split("//")[0].strip(), 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if not m or m.end() == pos:
                raise ValueError(f"{where}: cannot parse condition {expr.split('//')[0].strip()!r}")
            pos = m.end()
            out.append(next((kind, value) for kind, value in m.groupdict().items() if value is not None))
        tokens = _tokens_of[expr] = tuple(out)
    return tokens


class _Preprocessor:
    def __init__(self, options: Mapping[str, Value], schema: OptionSchema, root: Path):
        self.options = dict(options)
        self.schema = schema
        self.root = root
        self.modules: list[str] = []
        self.included: set[str] = set()    # self.modules, to look up
        self.out: list[str] = []
        self.consulted: set[str] = set()   # the options a condition read
        self.named: set[str] = set()       # the upper-case names in the code composed
        self._next: tuple[int, int] | None = None   # (file index, line) the output continues at

    def condition(self, expr: str, where: str) -> bool:
        """The value of an #if/#elif condition; remembered by its text, the schema and the values
        (or absence) of the names it reads, which decide it and the checks it passes."""
        names = _names_of.get(expr)
        if names is None:
            names = _names_of[expr] = tuple(dict.fromkeys(v for k, v in _tokens(expr, where) if k == "name"))
        options = self.options
        key = (expr, id(self.schema), tuple(options.get(n, _ABSENT) for n in names))
        hit = _conditions.get(key)
        if hit is None or hit[2] is not self.schema:
            consulted: set[str] = set()
            hit = _conditions[key] = (self._evaluate(expr, where, consulted), tuple(consulted), self.schema)
        self.consulted.update(hit[1])
        return hit[0]

    def _evaluate(self, expr: str, where: str, consulted: set[str]) -> bool:
        python: list[str] = []
        last_option: str | None = None
        for kind, value in _tokens(expr, where):
            if kind == "num":
                python.append(value)
            elif kind == "name":
                name = value
                if name in self.schema.switches and name not in self.options:
                    python.append("False")   # a switch is off unless the caller sets it
                elif name.isupper() or name in self.options:
                    if name not in self.options:
                        raise ValueError(f"{where}: condition uses {name}, which the composer did not define")
                    python.append(repr(self.options[name]))
                    consulted.add(name)
                    last_option = name
                else:  # a bare lower-case word is a value of the option it is compared with
                    allowed = self.schema.choices.get(last_option)
                    if allowed is not None and name not in allowed:
                        raise ValueError(f"{where}: {last_option} has no value {name!r} "
                                         f"(allowed {', '.join(allowed)})")
                    python.append(repr(name))
            else:
                python.append({"&&": " and ", "||": " or ", "!": " not "}.get(value, value))
        return bool(eval("".join(python), {"__builtins__": {}}, {}))  # tokens vetted above

    def include(self, name: str, where: str) -> None:
        if name in self.included:
            return
        path = _paths.get((self.root, name))
        if path is None:
            path = _paths[(self.root, name)] = os.path.join(self.root, name)
        module = _module(path, name)
        if module is None:
            raise ValueError(f"{where}: no shader module {name}")
        self.modules.append(name)
        self.included.add(name)
        index = len(self.modules)
        items = module.items
        actions, named = self._plan(module, name)
        self.named |= named
        out = self.out
        for action in actions:
            if isinstance(action, int):   # a run of plain lines
                lineno, _, rest = items[action]
                if self._next != (index, lineno):
                    out.append(f"#line {lineno} {index}")
                out.extend(rest)
                self._next = (index, lineno + len(rest))
            else:
                self.include(action[1], f"{name}:{action[0]}")

    def _plan(self, module: _Module, name: str) -> tuple[tuple, frozenset[str]]:
        """What composing ``module`` does under these options: run indices and (line, module)
        includes, in order, and the upper-case names of those runs; the options its
        conditions read are added to ``consulted``."""
        key = None
        if module.read is not None:
            options = self.options
            key = (id(self.schema), tuple(options.get(n, _ABSENT) for n in module.read))
            hit = module.plans.get(key)
            if hit is not None and hit[3] is self.schema:
                self.consulted.update(hit[2])
                return hit[0], hit[1]
        outer, self.consulted = self.consulted, set()
        try:
            actions = self._walk(module, name)
            consulted = self.consulted
        finally:
            self.consulted = outer | self.consulted
        named = frozenset().union(*(module.names[a] for a in actions if isinstance(a, int)))
        if key is not None:
            module.plans[key] = (actions, named, tuple(consulted), self.schema)
        return actions, named

    def _walk(self, module: _Module, name: str) -> tuple:
        items, jump, end = module.items, module.jump, module.end
        actions: list = []
        i, count = 0, len(items)
        while i < count:
            lineno, kind, rest = items[i]
            if kind is None:
                actions.append(i)
                i += 1
            elif kind == "if":   # the chain's first branch whose condition holds, else none
                while True:
                    lineno, kind, rest = items[i]
                    if kind == "endif" or kind == "else" or self.condition(rest, f"{name}:{lineno}"):
                        i += 1
                        break
                    i = jump[i]
            elif kind == "endif":
                i += 1
            elif kind == "include":
                target = re.match(r'"([^"]+)"', rest)
                if not target:
                    raise ValueError(f"{name}:{lineno}: malformed #include {rest!r}")
                actions.append((lineno, target.group(1)))
                i += 1
            else:   # an #elif or #else met in a branch that was taken: that branch has ended
                i = end[i] + 1
        return tuple(actions)


# Composed sources by (entry, options, schema, root), each with the (path, mtime, size) of the
# modules it read: a chart composes the same few programs every render (~20 ms on this path
# otherwise), and an edited module (tests edit copies) is noticed by its stat.
_composed: dict[tuple, tuple[ComposedSource, tuple, OptionSchema]] = {}


def _stamps(root: Path, modules: tuple[str, ...]) -> tuple:
    stamps, root = [], str(root)
    for name in modules:
        stamp = _stamp(os.path.join(root, name))
        if stamp is None:
            return ()
        stamps.append(stamp)
    return tuple(stamps)


def compose(main: str, options: Mapping[str, Value] | None, schema: OptionSchema, *,
            root: Path | None = None) -> ComposedSource:
    """Compose the program whose entry module is ``main`` (e.g. 'chart_main.glsl'), with
    ``options`` checked against ``schema`` (the plan's: shading.plan.SCHEMA)."""
    opts = validate_options(options or {}, schema)
    root = root or shader_dir()
    key = (main, tuple(sorted(opts.items())), id(schema), str(root))
    hit = _composed.get(key)
    fixed = _fixed
    if hit is not None and hit[2] is schema and hit[1]:
        if fixed is not None and key in fixed.checked:
            return hit[0]
        if _stamps(root, hit[0].modules) == hit[1]:
            if fixed is not None:
                fixed.checked.add(key)
            return hit[0]
    source = _compose(main, opts, schema, root)
    _composed[key] = (source, _stamps(root, source.modules), schema)
    if fixed is not None:
        fixed.checked.add(key)
    return source


def _compose(main: str, opts: dict[str, Value], schema: OptionSchema, root: Path) -> ComposedSource:
    pre = _Preprocessor(opts, schema, root)
    pre.include(main, "<compose>")
    header = [GLSL_VERSION, "// composed by sdfpbr from " + main]
    # Only the options this program's text depends on: those its conditions read and those its
    # code names. Programs that differ in options they never read (a normal-map bug, to the
    # stage probe, which shades no map) are then the same text: one compile, one cache key,
    # one IBL bake between them.
    for name, value in sorted(opts.items()):
        if name not in pre.consulted and name not in pre.named:
            continue
        if name in schema.choices:
            header.append(f"// option {name} = {value}")
        else:
            header.append(f"#define {name} {int(value)}")
    text = "\n".join(header + pre.out) + "\n"
    return ComposedSource(text, tuple(pre.modules), tuple(sorted(opts.items())))


def compile_error(source: ComposedSource, exc: Exception, what: str = "GLSL compile error") -> ShaderCompileError:
    """One line: the first line of the driver's log that reports an error (Mesa 'error:',
    NVIDIA 'error C1503:', AMD 'ERROR:'), its location as module.glsl:line."""
    located = source.locate(str(exc)).strip().splitlines() or ["unknown error"]
    errors = [line.strip() for line in located if "error" in line.lower()]
    return ShaderCompileError(f"{what}: {errors[0] if errors else located[0].strip()}")
