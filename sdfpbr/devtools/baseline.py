"""A Shadertoy-style fragment shader as a timing baseline for ``sdfpbr bench --baseline``.

Input is a ``.glsl`` file or a text/markdown document that contains one (a tutorial, a blog
post). The shader may use Shadertoy's ``void mainImage(out vec4, in vec2)`` entry point or an
old-style ``void main()`` writing ``gl_FragColor``; it is wrapped into a ``#version 330 core``
program with Shadertoy's uniforms (``iResolution``, ``iTime``, ``iTimeDelta``, ``iFrame``,
``iMouse``, ``iDate``) declared unless the shader declares them itself.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import ShaderCompileError, SpecError
from ..inputs import read_input
from ..shading.compose import ComposedSource, compile_error

# Shadertoy's uniforms and their types; a shader that declares one itself keeps its own type.
SHADERTOY_UNIFORMS = {
    "iResolution": "vec3", "iTime": "float", "iTimeDelta": "float", "iFrame": "int",
    "iMouse": "vec4", "iDate": "vec4", "iFrameRate": "float",
}
# Where the code of an unfenced document starts: the first line that can only be GLSL.
_START = re.compile(r"^[ \t]*(#version\b|precision\s+\w+\s+float\s*;|uniform\s+\w+\s+\w+|#define\s+\w+"
                    r"|void\s+mainImage\s*\()", re.M)
_ENTRY = re.compile(r"\bvoid\s+(mainImage|main)\s*\(")
_FENCE = re.compile(r"^[ \t]*(```|~~~)[^\n]*\n(.*?)^[ \t]*\1[ \t]*$", re.M | re.S)
_WORD = re.compile(r"^[A-Za-z][a-z']*[,.:;!?]?$")

VERTEX_SHADER = """#version 330 core
// One triangle that covers the viewport; no vertex buffers.
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""


@dataclass(frozen=True)
class ShadertoySource:
    code: str          # the GLSL as extracted from the input
    text: str          # the wrapped, compilable fragment shader
    entry: str         # "mainImage" or "main"
    origin: str        # file name, for messages and the bench table
    start_line: int    # 1-based line of the input where the code starts

    @property
    def name(self) -> str:
        return Path(self.origin).name


def _skip_comment(code: str, i: int) -> int:
    """If code[i] opens a comment, return the index after it; else i."""
    if code.startswith("//", i):
        j = code.find("\n", i)
        return len(code) if j < 0 else j
    if code.startswith("/*", i):
        j = code.find("*/", i + 2)
        return len(code) if j < 0 else j + 2
    return i


def _function_end(code: str, entry_at: int) -> int | None:
    """Index just past the closing brace of the function whose signature starts at entry_at."""
    i = code.find("{", entry_at)
    if i < 0:
        return None
    depth = 0
    while i < len(code):
        j = _skip_comment(code, i)
        if j != i:
            i = j
            continue
        c = code[i]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return i + 1
        i += 1
    return None


def _is_prose(line: str) -> bool:
    """A sentence of English between code lines (unfenced documents): mostly plain words, no
    statement punctuation. Comments and preprocessor lines are code."""
    s = line.strip()
    if not s or s.startswith(("//", "/*", "*", "#")) or s[-1] in ";{}(),=+-*/&|<>?":
        return False
    words = s.split()
    plain = sum(1 for w in words if _WORD.match(w))
    return len(words) >= 6 and plain >= 0.7 * len(words)


def _line_of(text: str, index: int) -> int:
    return text.count("\n", 0, index) + 1


def extract_glsl(text: str, origin: str = "<text>") -> tuple[str, str, int]:
    """(code, entry point, first line) of the shader in ``text``: the fenced block that holds an
    entry point, or else the span from the first line that can only be GLSL to the end of the
    entry function. Raises SpecError when there is none."""
    for m in _FENCE.finditer(text):
        block = m.group(2)
        e = _ENTRY.search(block)
        if e and _function_end(block, e.start()) is not None:
            return block, e.group(1), _line_of(text, m.start(2))
    # No fenced block with an entry point: the code is inline in the text.
    starts = [m.start() for m in _START.finditer(text)]
    for e in _ENTRY.finditer(text):
        end = _function_end(text, e.start())
        if end is None:
            continue
        before = [s for s in starts if s <= e.start()]
        start = before[0] if before else text.rfind("\n", 0, e.start()) + 1
        lines = text[start:end].splitlines()
        code = "\n".join(line for line in lines if not _is_prose(line)) + "\n"
        return code, e.group(1), _line_of(text, start)
    raise SpecError(f"{origin}: no GLSL shader found (need `void mainImage(out vec4, in vec2)` "
                    f"or `void main()` with its body)")


def wrap_shadertoy(code: str, entry: str, start_line: int = 1) -> str:
    """A #version 330 core fragment shader around Shadertoy-style ``code``.

    The code is source string 1 and starts at ``start_line`` (``#line start_line 1``), so a
    driver reports its errors at the input file's own lines; the wrapper around it is source
    string 0 at its own line numbers (build_program maps both)."""
    # Drop the shader's own #version (ours comes first); keep its precision and uniforms.
    body = re.sub(r"^[ \t]*#version[^\n]*\n?", "", code, flags=re.M)
    declared = set(re.findall(r"\buniform\s+\w+\s+(\w+)", body))
    lines = ["#version 330 core"]
    lines += [f"uniform {t} {n};" for n, t in SHADERTOY_UNIFORMS.items() if n not in declared]
    lines += [
        "out vec4 _sdfpbr_frag_color;",
        "#define gl_FragColor _sdfpbr_frag_color",
        "#define texture2D texture",
        "#define textureCube texture",
        f"#line {start_line} 1",
    ]
    lines += body.rstrip("\n").split("\n")
    if entry == "mainImage":
        lines.append(f"#line {len(lines) + 2} 0")   # the next line is physical line len + 2
        lines.append("void main() { mainImage(_sdfpbr_frag_color, gl_FragCoord.xy); }")
    return "\n".join(lines) + "\n"


def load_shadertoy(path: str | Path) -> ShadertoySource:
    p = Path(path)
    if p.is_dir():
        raise SpecError(f"--baseline {p} is a directory; give a .glsl file or a document with GLSL")
    text = read_input(p, "--baseline file", "spec").decode("utf-8", errors="replace")   # a regular file, bounded
    code, entry, start = extract_glsl(text, str(p))
    return ShadertoySource(code, wrap_shadertoy(code, entry, start), entry, str(p), start)


def build_program(ctx, source: ShadertoySource):
    """Compile and link; a compile error is one line naming the input file and its line, in
    the log format of any driver (see ComposedSource.locate): the code is source string 1
    and keeps the input's line numbers; the wrapper's own lines are '<sdfpbr wrapper>:N'."""
    try:
        return ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=source.text)
    except Exception as exc:   # moderngl raises a bare Error carrying the driver log
        message = str(compile_error(ComposedSource(source.text, (source.name,), ()), exc, "baseline shader"))
        raise ShaderCompileError(message.replace("<composed>", "<sdfpbr wrapper>")) from None


def shadertoy_uniforms(width: int, height: int, time_s: float = 0.0, frame: int = 0) -> dict:
    return {"iResolution": (float(width), float(height), 1.0), "iTime": float(time_s), "iTimeDelta": 1.0 / 60.0,
            "iFrame": int(frame), "iMouse": (0.0, 0.0, 0.0, 0.0), "iDate": (2024.0, 0.0, 1.0, 0.0),
            "iFrameRate": 60.0}


def set_shadertoy_uniforms(program, width: int, height: int, time_s: float = 0.0, frame: int = 0) -> None:
    """Set the uniforms the program uses, in the width the shader declared (vec2 or vec3 ...)."""
    for name, value in shadertoy_uniforms(width, height, time_s, frame).items():
        if name not in program:
            continue
        member = program[name]
        if isinstance(value, tuple):
            dim = getattr(member, "dimension", len(value))
            member.value = value[0] if dim == 1 else tuple(value[:dim])
        else:
            member.value = value
