"""The shader composer's memo: outside a build an edited module is noticed at the next compose;
inside ``modules_fixed`` (a build, a catalog) every program reads the version of each module
the block first saw, as the build's image keys did."""
import os
import shutil

import pytest

from sdfpbr.shading.compose import OptionSchema, modules_fixed, shader_dir
from sdfpbr.shading.compose import compose as compose_source
from sdfpbr.shading.plan import chart_options, display_options
from sdfpbr.shading.plan import compose_program as compose
from sdfpbr.spec.chart_spec import make_spec


def _edit(path, marker):
    path.write_text(path.read_text() + f"\n// {marker}\n")
    st = path.stat()
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))   # a new stamp, however coarse the clock


def test_an_edited_module_is_noticed_outside_a_fixed_block_and_not_inside(tmp_path):
    root = tmp_path / "shaders"
    shutil.copytree(shader_dir(), root)
    options, shown = chart_options(make_spec()), display_options(make_spec())
    brdf, display = root / "brdf.glsl", root / "display_main.glsl"
    first = compose("chart_main.glsl", options, root=root)
    _edit(brdf, "edit one")
    second = compose("chart_main.glsl", options, root=root)
    assert "edit one" not in first.text and "edit one" in second.text     # noticed: no block

    with modules_fixed():
        inside = compose("chart_main.glsl", options, root=root)
        assert inside.text == second.text
        _edit(brdf, "edit two")
        assert compose("chart_main.glsl", options, root=root).text == second.text   # the block's version
        with modules_fixed():                                                        # nested: the same block
            assert compose("chart_main.glsl", options, root=root).text == second.text
        unseen = compose("display_main.glsl", shown, root=root)   # a module first read in the block: as it is now
        _edit(display, "edit three")
        assert compose("display_main.glsl", shown, root=root).text == unseen.text
    assert "edit two" in compose("chart_main.glsl", options, root=root).text     # after the block: noticed
    assert "edit three" in compose("display_main.glsl", shown, root=root).text


def _tree(root, modules: dict):
    root.mkdir(exist_ok=True)
    for name, text in modules.items():
        (root / name).write_text(text)
    return root


_SCHEMA = OptionSchema(choices={"MODE": ("a", "b", "c")}, flags=("X", "Y"), counts=("N",), switches=("S",))


def _body(source) -> list[str]:
    """The composed lines without the header and #line directives."""
    return [line for line in source.text.splitlines()[2:] if not line.startswith(("#line", "#define", "// option"))]


def test_conditionals_take_one_branch_per_chain_and_skip_the_rest(tmp_path):
    """Chains of #if/#elif/#else, nested, in both taken and untaken branches: the lines kept
    are those of C's preprocessor for the same defines (written out here by hand)."""
    root = _tree(tmp_path / "s", {
        "main.glsl": "\n".join([
            "top",
            "#if X",
            "x1",
            "#if MODE == a",
            "xa",
            "#elif MODE == b && N > 2",
            "xb",
            "#else",
            "xelse",
            "#endif",
            "x2",
            "#elif Y",
            "y",
            "#if N > 100",
            "#if UNDEFINED_IN_A_SKIPPED_BRANCH",
            "never",
            "#endif",
            "#endif",
            "#else",
            "neither",
            '#include "missing_but_skipped.glsl"',
            "#endif",
            "#if S || !Y",
            "s_or_not_y",
            "#endif",
            '#include "part.glsl"',
            "bottom",
        ]),
        "part.glsl": "#if N >= 3\nmany\n#elif N\nsome\n#else\nnone\n#endif\n",
    })

    def lines(**options):
        return _body(compose_source("main.glsl", {"X": False, "Y": False, "MODE": "a", "N": 0, **options},
                                    _SCHEMA, root=root))
    assert lines(X=True) == ["top", "x1", "xa", "x2", "s_or_not_y", "none", "bottom"]
    assert lines(X=True, MODE="b", N=3) == ["top", "x1", "xb", "x2", "s_or_not_y", "many", "bottom"]
    assert lines(X=True, MODE="b", N=2) == ["top", "x1", "xelse", "x2", "s_or_not_y", "some", "bottom"]
    assert lines(X=True, Y=True, MODE="c", N=1) == ["top", "x1", "xelse", "x2", "some", "bottom"]
    assert lines(Y=True) == ["top", "y", "none", "bottom"]
    assert lines(Y=True, S=True) == ["top", "y", "s_or_not_y", "none", "bottom"]
    with pytest.raises(ValueError, match="no shader module missing_but_skipped.glsl"):
        lines()   # the #else branch is taken: its include is read


def test_conditionals_report_what_is_wrong_taken_or_not(tmp_path):
    cases = {
        "#if X\na\n#elif Y\nb\n#else\nc\n#elif X\nd\n#endif\n": r"main.glsl:7: #elif after #else",
        "a\n#elif X\nb\n#endif\n": r"main.glsl:2: #elif without #if",
        "#if X\na\n#endif\n#endif\n": r"main.glsl:4: #endif without #if",
        "#if Y\n#if X\na\n#endif\n": r"main.glsl: unterminated #if",
        "#if X\nb\n#endif\n#if MODE == d\nc\n#endif\n": r"main.glsl:4: MODE has no value 'd'",
        "#if X && Z\nb\n#endif\n": r"main.glsl:1: condition uses Z, which the composer did not define",
        "#if X\n#include <part.glsl>\n#endif\n": r"main.glsl:2: malformed #include",
    }
    for i, (text, message) in enumerate(cases.items()):
        root = _tree(tmp_path / f"s{i}", {"main.glsl": text})
        with pytest.raises(ValueError, match=message):
            compose_source("main.glsl", {"X": True, "Y": False, "MODE": "a"}, _SCHEMA, root=root)


def test_a_remembered_condition_is_one_of_the_same_options(tmp_path):
    """Conditions are remembered by the values they read: the same text under other options
    is evaluated again, and the header names the options each program's conditions read."""
    root = _tree(tmp_path / "s", {"main.glsl": "#if X && MODE == b\nxb\n#elif Y\ny\n#endif\nend\n"})
    for x in (False, True):
        for mode in ("a", "b"):
            for y in (False, True):
                source = compose_source("main.glsl", {"X": x, "Y": y, "MODE": mode}, _SCHEMA, root=root)
                expected_first = ["xb"] if (x and mode == "b") else (["y"] if y else [])
                assert _body(source) == expected_first + ["end"]
                header = source.text.splitlines()[:6]
                assert ("#define X 1" in header or "#define X 0" in header)
                assert ("#define Y" in source.text) == (not x or mode != "b")   # Y read only when the first fails
