"""The command line: bad input is one line and exit status 2, and never touches the output."""
import subprocess
import sys

import numpy as np
import pytest

from sdfpbr.cli.main import main
from sdfpbr.shading.plan import compose_program as compose
from sdfpbr.shading.plan import render_plan
from sdfpbr.spec.chart_spec import DEFAULT_LIGHTS, make_spec


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("args, needle", [
    (["chart", "--rowz", "3"], "did you mean '--rows'"),
    (["chart", "--rows", "0"], "rows must be in [1, 64]"),
    (["chart", "--tonemap", "acse"], "did you mean 'aces'"),
    (["chart", "--roughness", "0-1"], "LO:HI"),
    (["chart", "--env", "nowhere.exr"], "does not exist"),
    (["chart", "--size", "big"], "WxH"),
])
def test_bad_input_is_one_line_exit_2_no_file(tmp_path, args, needle):
    out = tmp_path / "chart.png"
    out.write_bytes(b"keep me")
    r = run(*args, "-o", str(out))
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert out.read_bytes() == b"keep me"


def test_values_that_start_with_a_minus_are_values():
    """argparse reads "-1,0,1" or "-2:2" as an option; after a numeric field's option they are
    its value (and a bad one gets the field's own message, not "expected one argument")."""
    from sdfpbr.cli.main import build_parser, spec_from_args
    args = build_parser("chart").parse_args(["chart", "--x-axis", "exposure", "--x-values", "-1,0,1", "--cols", "3",
                                             "--camera-azimuth", "-20.5", "--exposure", "-.5"])
    spec = spec_from_args(args)
    assert (spec.x_values, spec.camera_azimuth, spec.exposure) == ((-1.0, 0.0, 1.0), -20.5, -0.5)
    r = run("chart", "--roughness", "-0.5:1", "-o", "never.png")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "roughness must be in [0, 1]" in r.stderr


def test_bad_toml_key_and_malformed_toml(tmp_path):
    bad_key = tmp_path / "a.toml"
    bad_key.write_text('roughnes = "0:1"\n')
    r = run("chart", "--spec", str(bad_key), "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2 and "did you mean 'roughness'" in r.stderr
    broken = tmp_path / "b.toml"
    broken.write_text("rows = = 3\n")
    r = run("chart", "--spec", str(broken), "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2 and "malformed TOML" in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_unwritable_output_is_refused_before_rendering(tmp_path):
    r = run("chart", "-o", str(tmp_path / "missing" / "x.png"))
    assert r.returncode == 2 and "does not exist" in r.stderr


def test_furnace_chart_with_hdr_and_aov_from_the_cli(tmp_path):
    """The issue's furnace check, end to end: white metals read 1 with compensation."""
    png, hdr, aov = tmp_path / "f.png", tmp_path / "f.npy", tmp_path / "f.npz"
    r = run("chart", "--env", "uniform", "--lights", "none", "--no-shadows", "--no-ao", "--no-ground",
            "--base-color", "1,1,1", "--size", "200x200", "-o", str(png), "--hdr", str(hdr), "--aov", str(aov))
    assert r.returncode == 0, r.stderr
    radiance, a = np.load(hdr), np.load(aov)
    assert radiance.shape == (200, 200, 3) and radiance.dtype == np.float32
    metal = (a["metallic"] == 1.0) & (a["ndotv"] > 0.15)
    np.testing.assert_allclose(radiance[metal], 1.0, atol=1e-5)   # (A + B) / E from one texel fetch
    assert set(a.files) == {"normal", "depth", "row", "col", "roughness", "metallic", "ndotv", "coverage"}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def subcommands(parser) -> dict:
    return parser._subparsers._group_actions[0].choices


def test_a_command_builds_its_own_parser_alone_and_the_same_one():
    """`sdfpbr chart` builds the chart's parser only (the other commands' options and modules
    are start-up time); each command's parser is the same built alone or with the rest, and a
    name that is no command builds them all, so its error lists every choice."""
    from sdfpbr.cli.main import build_parser
    everything = subcommands(build_parser())
    assert {"chart", "shader", "doctor", "bench", "build", "compare", "reference"} <= set(everything)
    for name, full in everything.items():
        alone = subcommands(build_parser(name))
        assert list(alone) == [name]
        assert ([a.option_strings for a in alone[name]._actions] == [a.option_strings for a in full._actions])
        assert alone[name].format_help() == full.format_help()
    assert set(subcommands(build_parser("chrat"))) == set(everything)
    r = run("chrat")
    assert r.returncode == 2 and "chart" in r.stderr and "reference" in r.stderr


def test_shader_command_from_another_directory(tmp_path):
    r = run("shader", "--no-ground", "--no-ao", "--lights", "none", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.startswith("#version 450")


def test_shader_command_prints_each_program_of_the_frame(capsys):
    """The default chart's sphere is shaded by the sphere prepass's program: `--program` shows it;
    a program the chart does not run is one line naming those it does, exit 2."""
    assert main(["shader", "--program", "sphere-prepass"]) == 0
    assert "// composed by sdfpbr from stage_sphere_main.glsl" in capsys.readouterr().out
    assert main(["shader", "--display"]) == 0
    assert "// composed by sdfpbr from display_main.glsl" in capsys.readouterr().out
    assert main(["shader", "--program", "sphere-prepass", "--spp", "4"]) == 2   # stratified rays: no prepass
    err = capsys.readouterr().err
    runs = "floor-prepass, bounce-cache, bounce-prepass, gather-prepass, chart"
    assert err.count("\n") == 1 and f"runs no sphere-prepass program; it runs: {runs}" in err


def test_features_left_out_are_absent_from_the_source():
    point = {"kind": "point", "position": [3.0, 2.0, 3.0], "intensity": 10.0}
    full = render_plan(make_spec(lights=[*DEFAULT_LIGHTS, point])).chart.text
    bare = render_plan(make_spec(ground=False, ao=False, lights="none")).chart.text
    # (the lights' loops shade each light with shaded_light_angle(s, ground, ...); the helpers
    # themselves may stay, unused)
    for needle in ("soft_shadow", "ambient_occlusion", "sdf_ground", "u_dir_light", "u_point_light",
                   "shaded_light_angle(s, ground,"):
        assert needle in full and needle not in bare, needle
    # One ray a pixel, the edge not anti-aliased: no loop over further samples (llvmpipe would
    # run its body once although it runs no turn), nor the sphere's shading (the sphere prepass).
    one = render_plan(make_spec(antialias=False)).chart.text
    several = render_plan(make_spec(antialias=False, spp=4)).chart.text
    assert "sample_offset(s)" in several and "sample_offset(s)" not in one
    call = "return shade_sphere(p, n_geo, v, cell, pixel_size)"   # sphere_radiance's, in chart_main.glsl
    assert call in several and call not in one


def test_composer_refuses_unknown_options_and_maps_errors(tmp_path, session):
    with pytest.raises(ValueError, match="allowed"):
        compose("display_main.glsl", {"TONEMAP": "filmic"})
    with pytest.raises(ValueError, match="unknown shader option"):
        compose("display_main.glsl", {"TONEMAPPER": "aces"})
    (tmp_path / "broken.glsl").write_text("void f() {\n  float x = ;\n}\n")
    (tmp_path / "main.glsl").write_text('#include "broken.glsl"\nvoid main() {}\n')
    from sdfpbr.errors import ShaderCompileError
    with session.ctx, pytest.raises(ShaderCompileError, match=r"broken\.glsl:2"):
        session.programs.fragment(compose("main.glsl", root=tmp_path))


@pytest.mark.requires_backend("egl", "osmesa")
def test_doctor_reports_both_backends():
    r = run("doctor")
    assert r.returncode == 0
    assert "egl     ok" in r.stdout and "osmesa  ok" in r.stdout
    assert "chart: fragment shader" in r.stdout or "chart: compute shader" in r.stdout


def test_chart_help_is_grouped_by_concern_with_every_option_once():
    """`chart --help` was 196 lines in one flat group: the options now sit under headings
    (fields.HELP_GROUPS), each field in exactly one, with examples at the end."""
    from sdfpbr.spec.fields import FIELDS, HELP_GROUPS
    grouped = [name for _, names in HELP_GROUPS for name in names]
    assert sorted(grouped) == sorted(f.name for f in FIELDS) and len(grouped) == len(set(grouped))
    text = _chart_help()
    for title, names in HELP_GROUPS:
        assert f"chart: {title}:" in text
    assert text.rstrip().splitlines()[-1].lstrip().startswith("sdfpbr chart") and "examples:" in text


def _chart_help() -> str:
    import contextlib
    import io
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main(["chart", "--help"])
    return out.getvalue()
