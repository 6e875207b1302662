"""The shader composer's memo: outside a build an edited module is noticed at the next compose;
inside ``modules_fixed`` (a build, a catalog) every program reads the version of each module
the block first saw, as the build's image keys did."""
import os
import shutil

from sdfpbr.shading.compose import modules_fixed, shader_dir
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
