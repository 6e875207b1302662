"""Compose GLSL programs from the modules in shaders/.

The composer resolves ``#include`` recursively (each module once) and evaluates every
``#if``/``#elif``/``#else`` itself, so a feature the spec leaves out is absent from the
composed source, not merely disabled. Every name a conditional tests must be an option the
composer was given, and every option value must be one the OPTIONS table allows: a typo
fails in Python, before GLSL sees it. ``#line`` directives map compiler messages back to
``module.glsl:line``.
"""
from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Mapping

from ..spec.bugs import BUG_DEFINES
from ..errors import ShaderCompileError

GLSL_VERSION = "#version 450 core"

# Every string-valued option and the values it may take.
OPTIONS: dict[str, tuple[str, ...]] = {
    "BRDF_MODEL": ("gltf", "schlick_ggx"),
    "TONEMAP": ("none", "clamp", "reinhard", "reinhard_extended", "aces", "aces_hill", "neutral"),
    "ENV": ("studio", "sky", "uniform", "black", "file"),
    "CAMERA": ("perspective", "orthographic"),
    "NORMAL_METHOD": ("tetrahedron", "central"),
    "COPY_DIRECTION": ("to_cube", "from_cube"),
    "INTERSECT": ("analytic", "march"),
    "AO_METHOD": ("analytic", "sdf"),
    "SCENE_SDF": ("nearest_cell", "all_spheres"),
}
# Options that are on/off switches or counts, emitted as #define for the GLSL code.
FLAGS = ("USE_IBL", "USE_AO", "USE_SHADOWS", "HAS_GROUND", "MULTISCATTER", "TRANSPARENT", "USE_TEXTURES", "HALF_RADIANCE") + BUG_DEFINES
COUNTS = ("NUM_DIR_LIGHTS", "NUM_POINT_LIGHTS", "GRID_ROWS")

Value = str | int | bool


def shader_dir() -> Path:
    """$SDFPBR_SHADER_DIR if set (tests edit a copy of the modules), else shaders/ beside the
    package in a source tree, else the installed sdfpbr.shaders data."""
    override = os.environ.get("SDFPBR_SHADER_DIR")
    if override:
        return Path(override)
    here = Path(__file__).resolve().parents[2] / "shaders"
    if (here / "common.glsl").is_file():
        return here
    # sdfpbr.shaders is a namespace package (no __init__), whose files() is a MultiplexedPath;
    # going through the regular parent package yields a plain filesystem path.
    return Path(resources.files("sdfpbr").joinpath("shaders"))


def validate_options(options: Mapping[str, Value]) -> dict[str, Value]:
    out: dict[str, Value] = {}
    for name, value in options.items():
        if name in OPTIONS:
            if value not in OPTIONS[name]:
                raise ValueError(f"shader option {name}={value!r}: allowed {', '.join(OPTIONS[name])}")
        elif name in FLAGS:
            value = bool(value)
        elif name in COUNTS:
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

    @property
    def digest(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()

    def locate(self, message: str) -> str:
        """Rewrite compiler locations (Mesa '0:12(5)', NVIDIA '0(12)') as module.glsl:line."""
        def sub(m: re.Match) -> str:
            index, line = int(m.group("file")), m.group("line")
            name = self.modules[index - 1] if 1 <= index <= len(self.modules) else "<composed>"
            return f"{name}:{line}"
        return re.sub(r"(?P<file>\d+)[:(](?P<line>\d+)(?:\(\d+\)|\))", sub, message)


_TOKEN = re.compile(r"\s*(?:(?P<num>\d+(?:\.\d*)?)|(?P<name>[A-Za-z_]\w*)|(?P<op>==|!=|>=|<=|&&|\|\||[()!<>]))")


class _Preprocessor:
    def __init__(self, options: Mapping[str, Value], root: Path):
        self.options = dict(options)
        self.root = root
        self.modules: list[str] = []
        self.out: list[str] = []
        self._next: tuple[int, int] | None = None   # (file index, line) the output continues at

    def condition(self, expr: str, where: str) -> bool:
        python: list[str] = []
        pos = 0
        expr = expr.split("//")[0].strip()
        last_option: str | None = None
        while pos < len(expr):
            m = _TOKEN.match(expr, pos)
            if not m or m.end() == pos:
                raise ValueError(f"{where}: cannot parse condition {expr!r}")
            pos = m.end()
            if m.group("num"):
                python.append(m.group("num"))
            elif m.group("name"):
                name = m.group("name")
                if name in BUG_DEFINES and name not in self.options:
                    python.append("False")   # a bug is off unless a spec names it
                elif name.isupper() or name in self.options:
                    if name not in self.options:
                        raise ValueError(f"{where}: condition uses {name}, which the composer did not define")
                    python.append(repr(self.options[name]))
                    last_option = name
                else:  # a bare lower-case word is a value of the option it is compared with
                    if last_option in OPTIONS and name not in OPTIONS[last_option]:
                        raise ValueError(f"{where}: {last_option} has no value {name!r} "
                                         f"(allowed {', '.join(OPTIONS[last_option])})")
                    python.append(repr(name))
            else:
                op = m.group("op")
                python.append({"&&": " and ", "||": " or ", "!": " not "}.get(op, op))
        return bool(eval("".join(python), {"__builtins__": {}}, {}))  # tokens vetted above

    def include(self, name: str, where: str) -> None:
        if name in self.modules:
            return
        path = self.root / name
        if not path.is_file():
            raise ValueError(f"{where}: no shader module {name}")
        self.modules.append(name)
        index = len(self.modules)
        stack: list[list[bool]] = []   # [active, a branch was taken]
        for lineno, line in enumerate(path.read_text().splitlines(), start=1):
            where_here = f"{name}:{lineno}"
            stripped = line.strip()
            active = all(frame[0] for frame in stack)
            directive = re.match(r"#\s*(if|elif|else|endif|include)\b\s*(.*)", stripped)
            if directive:
                kind, rest = directive.groups()
                if kind == "if":
                    taken = active and self.condition(rest, where_here)
                    stack.append([taken, taken])
                elif kind == "elif":
                    if not stack:
                        raise ValueError(f"{where_here}: #elif without #if")
                    outer = all(frame[0] for frame in stack[:-1])
                    take = outer and not stack[-1][1] and self.condition(rest, where_here)
                    stack[-1] = [take, stack[-1][1] or take]
                elif kind == "else":
                    if not stack:
                        raise ValueError(f"{where_here}: #else without #if")
                    outer = all(frame[0] for frame in stack[:-1])
                    stack[-1] = [outer and not stack[-1][1], True]
                elif kind == "endif":
                    if not stack:
                        raise ValueError(f"{where_here}: #endif without #if")
                    stack.pop()
                elif active:
                    target = re.match(r'"([^"]+)"', rest)
                    if not target:
                        raise ValueError(f"{where_here}: malformed #include {rest!r}")
                    self.include(target.group(1), where_here)
                continue
            if active:
                if self._next != (index, lineno):
                    self.out.append(f"#line {lineno} {index}")
                self.out.append(line)
                self._next = (index, lineno + 1)
        if stack:
            raise ValueError(f"{name}: unterminated #if")


def compose(main: str, options: Mapping[str, Value] | None = None, *, root: Path | None = None) -> ComposedSource:
    """Compose the program whose entry module is ``main`` (e.g. 'chart_main.glsl')."""
    opts = validate_options(options or {})
    pre = _Preprocessor(opts, root or shader_dir())
    pre.include(main, "<compose>")
    header = [GLSL_VERSION, "// composed by sdfpbr from " + main]
    for name, value in sorted(opts.items()):
        if name in OPTIONS:
            header.append(f"// option {name} = {value}")
        else:
            header.append(f"#define {name} {int(value)}")
    text = "\n".join(header + pre.out) + "\n"
    return ComposedSource(text, tuple(pre.modules), tuple(sorted(opts.items())))


def compile_error(source: ComposedSource, exc: Exception) -> ShaderCompileError:
    lines = [line for line in source.locate(str(exc)).splitlines() if "error" in line.lower()]
    first = lines[0].strip() if lines else source.locate(str(exc)).strip().splitlines()[0]
    return ShaderCompileError(f"GLSL compile error: {first}")
