"""Compile errors name module.glsl:line whatever driver wrote the log: Mesa (llvmpipe here),
NVIDIA and AMD, for composed programs (ComposedSource.locate / compile_error) and for the
Shadertoy baseline (tools.baseline.build_program). The logs below are literal lines in each
driver's format, so this runs without those drivers; the last tests compile for real on the
driver at hand."""
import pytest

from sdfpbr.errors import ShaderCompileError
from sdfpbr.shading.compose import ComposedSource, compile_error
from sdfpbr.devtools.baseline import build_program, load_shadertoy

# What compose() emits for main.glsl including broken.glsl including util.glsl: a header in
# source string 0, then each module's lines under `#line LINE INDEX` (INDEX = position in
# inclusion order, from 1).
COMPOSED = ComposedSource(
    text="\n".join([
        "#version 450 core",                      # header, source 0
        "// composed by sdfpbr from main.glsl",
        "#line 3 3",                               # util.glsl (included first by broken.glsl)
        "float helper(float v) {",                 # util.glsl:3
        "    return v * 2.0;",                     # util.glsl:4
        "}",                                       # util.glsl:5
        "#line 2 2",                               # broken.glsl
        "void f() {",                              # broken.glsl:2
        "    float x = helper(1.0) + missing;",   # broken.glsl:3, `missing' at column 29
        "}",                                       # broken.glsl:4
        "#line 2 1",                               # main.glsl
        "out vec4 color;",                         # main.glsl:2
        "void main() { color = vec4(helper(0.5)); }",   # main.glsl:3
    ]) + "\n",
    modules=("main.glsl", "broken.glsl", "util.glsl"),
    options=(),
)
HEAD = "GLSL Compiler failed\n\nfragment_shader\n===============\n"   # moderngl's preamble

DRIVER_LOGS = {
    # Mesa: INDEX:LINE(COLUMN); keeps the index for syntax errors ...
    "mesa-syntax": "2:3(38): error: syntax error, unexpected ';', expecting '('\n",
    # ... and reports index 0 for semantic ones (found on llvmpipe 24.x; resolved by the text).
    "mesa-semantic": "0:3(29): error: `missing' undeclared\n"
                     "0:3(15): error: operands to arithmetic operators must be numeric\n",
    # NVIDIA: INDEX(LINE), a warning first.
    "nvidia": '3(4) : warning C7022: unrecognized profile specifier "x"\n'
              '2(3) : error C1503: undefined variable "missing"\n',
    "nvidia-index-0": '0(3) : error C1503: undefined variable "missing"\n',
    # AMD (and Intel on Windows, Apple): ERROR: INDEX:LINE:, then a count line that also says ERROR.
    "amd": "ERROR: 2:3: 'missing' : undeclared identifier \nERROR: 1 compilation errors.  No code generated.\n\n",
}


@pytest.mark.parametrize("driver", sorted(DRIVER_LOGS))
def test_composed_error_names_module_and_line(driver):
    err = compile_error(COMPOSED, Exception(HEAD + DRIVER_LOGS[driver]))
    assert isinstance(err, ShaderCompileError)
    text = str(err)
    assert text.startswith("GLSL compile error: ") and "\n" not in text
    assert "broken.glsl:3" in text, text
    assert "<composed>" not in text and "util.glsl" not in text
    assert "error" in text.lower() and "compilation errors" not in text and "warning" not in text


def test_locate_rewrites_every_driver_format_and_nothing_else():
    log = ("2:3(38): error: `vec4(1)' wrong\n"        # Mesa
           "1(2) : error C1038: declaration of \"color\" conflicts\n"   # NVIDIA
           "ERROR: 3:4: 'v' : x\n"                     # AMD
           "WARNING: 1:3: '' : y\n"                    # AMD warning
           "  0:1(1): error: header\n"                 # index 0 on a header line
           "link error: 12(3) is not a location here\n")
    assert COMPOSED.locate(log).splitlines() == [
        "broken.glsl:3: error: `vec4(1)' wrong",
        "main.glsl:2 : error C1038: declaration of \"color\" conflicts",
        "ERROR: util.glsl:4: 'v' : x",
        "WARNING: main.glsl:3: '' : y",
        "  <composed>:1: error: header",
        "link error: 12(3) is not a location here",
    ]


def test_index_0_is_resolved_by_the_quoted_name_and_column():
    # Line 3 exists in broken.glsl, util.glsl and main.glsl: the name at the column decides.
    assert COMPOSED.locate("0:3(29): error: `missing' undeclared") == "broken.glsl:3: error: `missing' undeclared"
    assert COMPOSED.locate("0:3(28): error: `helper' bad") == "main.glsl:3: error: `helper' bad"
    # Without a name: the lines long enough for the column.
    assert COMPOSED.locate("0:3(30): error: type mismatch") == "main.glsl:3 or broken.glsl:3: error: type mismatch"


# ---- the Shadertoy baseline ----------------------------------------------------------------------

class _FailingContext:
    """Stands in for a moderngl context whose driver rejects the shader with ``log``."""
    def __init__(self, log: str):
        self.log = log

    def program(self, **shaders):
        raise Exception(HEAD + self.log)


@pytest.fixture
def post(tmp_path):
    """A blog post whose fenced shader starts at line 6; `oops` is on line 7 of the post."""
    path = tmp_path / "post.md"
    path.write_text("# Shader of the week\n\nTry this one:\n\n```glsl\n"
                    "void mainImage(out vec4 c, in vec2 p) {\n"          # post.md:6
                    "    c = vec4(oops);\n"                                # post.md:7, `oops' at column 14
                    "}\n```\n")
    return load_shadertoy(path)


@pytest.mark.parametrize("log", [
    "1:7(14): error: syntax error, unexpected IDENTIFIER\n",                          # Mesa, syntax
    "0:7(14): error: `oops' undeclared\n0:7(9): error: cannot construct `vec4'\n",   # Mesa, semantic
    '1(7) : error C1503: undefined variable "oops"\n',                              # NVIDIA
    '0(7) : error C1503: undefined variable "oops"\n',                              # NVIDIA, no index
    "ERROR: 1:7: 'oops' : undeclared identifier \nERROR: 1 compilation errors.  No code generated.\n",  # AMD
], ids=["mesa-syntax", "mesa-semantic", "nvidia", "nvidia-index-0", "amd"])
def test_baseline_error_names_the_input_file_line(post, log):
    with pytest.raises(ShaderCompileError) as info:
        build_program(_FailingContext(log), post)
    text = str(info.value)
    assert text.startswith("baseline shader: post.md:7") or "ERROR: post.md:7" in text, text
    assert "\n" not in text and "compilation errors" not in text


def test_baseline_wrapper_error_is_not_blamed_on_the_input(post):
    # The call of mainImage is the wrapper's last line (source 0, its own line number).
    wrapper_line = post.text.splitlines().index(
        "void main() { mainImage(_sdfpbr_frag_color, gl_FragCoord.xy); }") + 1
    log = f"0:{wrapper_line}(15): error: no matching function for call to `mainImage(vec4, vec2)'\n"
    with pytest.raises(ShaderCompileError, match=rf"<sdfpbr wrapper>:{wrapper_line}: error: no matching"):
        build_program(_FailingContext(log), post)


# ---- for real, on the driver at hand --------------------------------------------------------------

@pytest.mark.parametrize("body, line", [
    ("    float x = ;\n", 3),                        # a syntax error
    ("    float x = missing_name;\n", 3),            # a semantic one (Mesa drops the index)
    ("    float x = 1.0;\n    float y = vec2(x);\n", 4),   # a semantic one without a quoted name
])
def test_real_compile_errors_name_the_nested_module(ctx, session, tmp_path, body, line):
    from sdfpbr.shading.plan import compose_program
    (tmp_path / "util.glsl").write_text("// util\nfloat helper() {\n    return 1.0;\n}\n")
    (tmp_path / "broken.glsl").write_text('#include "util.glsl"\nvoid f() {\n' + body + "}\n")
    (tmp_path / "main.glsl").write_text('#include "broken.glsl"\nout vec4 c;\nvoid main() { c = vec4(helper()); }\n')
    with pytest.raises(ShaderCompileError, match=rf"^GLSL compile error: (ERROR: )?broken\.glsl:{line}\b"):
        session.programs.fragment(compose_program("main.glsl", root=tmp_path))


@pytest.mark.parametrize("code, line", [
    ("void mainImage(out vec4 c, in vec2 p) {\n  c = vec4(undefined_name);\n}\n", 2),
    ("void mainImage(out vec4 c, in vec2 p) {\n  c = vec4(1.0)\n}\n", 3),
])
def test_real_baseline_errors_name_the_file_line(ctx, tmp_path, code, line):
    path = tmp_path / "shader.glsl"
    path.write_text(code)
    with pytest.raises(ShaderCompileError, match=rf"^baseline shader: (ERROR: )?shader\.glsl:{line}\b"):
        build_program(ctx, load_shadertoy(path))
