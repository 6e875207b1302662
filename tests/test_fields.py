"""The spec field table: one name per field on every surface (flag, TOML key, Python keyword),
aliases, size, numbers, the same refusals everywhere, and the writers' round trips."""
import io
import math
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sdfpbr
from sdfpbr.cli.main import build_parser, main, spec_from_args
from sdfpbr.errors import SpecError
from sdfpbr.spec.checks import BIDI_CONTROLS
from sdfpbr.spec import (BUGS, ENTRY_KEYS, FIELD_NAMES, FIELDS, ChartSpec, Light, field_value, field_value_from_text,
                         load_spec, make_spec, read_entry_document, resolve_field, spec_to_flags, spec_to_toml,
                         spec_from_mapping, split_entry, sweep_defaults, sweep_values_from_text)
from sdfpbr.spec.fields import resolve_relative_files, toml_value
from sdfpbr.spec.material import AXIS_PARAMS
from sdfpbr.spec.presets import DEFAULT_LIGHTS, ENV_PRESETS

CHARTS = sorted((Path(__file__).parent.parent / "charts").glob("*.toml"))

# One non-default value per field: (Python/TOML value, command-line text). A new field needs one.
SAMPLES = {
    "rows": (3, "3"), "cols": (4, "4"), "width": (320, "320"), "height": (240, "240"),
    "size": ((200, 100), "200x100"), "roughness": ((0.25, 0.75), "0.25:0.75"), "metallic": ((0.0, 0.5), "0:0.5"),
    "base_color": ((1.0, 0.5, 0.0), "1,0.5,0"), "materials": (("gold",) * 5, "gold,gold,gold,gold,gold"),
    "env": ("sky", "sky"), "env_intensity": (2.0, "2"), "lights": ((), "none"), "shadows": (False, None),
    "ao": (False, None), "ground": (False, None), "ibl": (False, None), "tonemap": ("neutral", "neutral"),
    "exposure": (-1.5, "-1.5"), "reinhard_white": (2.0, "2"), "spp": (4, "4"),
    "antialias": (False, None), "hdr_precision": ("float16", "float16"),
    "multiscatter": (False, None), "brdf": ("schlick-ggx", "schlick-ggx"),
    "camera": ("orthographic", "orthographic"), "stage": ("shared", "shared"), "cell_borders": (False, None),
    "camera_azimuth": (30.0, "30"), "camera_elevation": (20.0, "20"), "camera_distance_scale": (1.5, "1.5"),
    "intersect": ("march", "march"), "sphere_radius": (0.5, "0.5"), "spacing": (3.0, "3"), "transparent": (True, None),
    "title": ("Hello", "Hello"), "quality": ("draft", "draft"), "backend": ("egl", "egl"), "device_index": (1, "1"),
    "ground_color": ((0.5, 0.5, 0.5), "0.5,0.5,0.5"), "backdrop": ((1.0, 1.0, 1.0), "1,1,1"),
    "ground_roughness": (0.3, "0.3"), "labels": (False, None),
    "bugs": (("clamp-tonemap",), "clamp-tonemap"), "textures": ("procedural", "procedural"),
    "base_color_texture": ("", ""), "orm_texture": ("", ""), "normal_texture": ("", ""),
    "x_axis": ("clearcoat", "clearcoat"), "y_axis": ("ior", "ior"),
    "x_values": ((0.0, 0.5, 1.0, 0.5, 0.0), "0,0.5,1,0.5,0"),
    "y_values": ((0.0, 0.1, 0.2, 0.3, 0.4), "0,0.1,0.2,0.3,0.4"),
    "base_colors": (((1.0, 0.0, 0.0),) * 5, ";".join(["1,0,0"] * 5)), "clearcoat": ((0.5, 0.5), "0.5"),
    "clearcoat_roughness": ((0.2, 0.2), "0.2"), "sheen_roughness": ((0.3, 0.3), "0.3"), "ior": ((1.3, 1.3), "1.3"),
    "specular": ((0.5, 0.5), "0.5"), "emissive_strength": ((2.0, 2.0), "2"),
    "base_color_hue": ((10.0, 200.0), "10:200"),
    "alpha": ((0.5, 0.5), "0.5"), "alpha_mode": ("mask", "mask"), "alpha_cutoff": (0.25, "0.25"),
    "sheen_color": ((1.0, 0.5, 0.5), "1,0.5,0.5"), "specular_color": ((1.0, 0.5, 0.5), "1,0.5,0.5"),
    "emissive": ((1.0, 0.5, 0.5), "1,0.5,0.5"),
    "gltf": (str(Path(__file__).parents[1] / "charts" / "materials.glb"),) * 2,
    "gltf_materials": ((), ""),   # needs gltf: tests/test_gltf.py
}


def chart_args(*argv):
    return build_parser().parse_args(["chart", *argv])


def cli_spec(*argv):
    return spec_from_args(chart_args(*argv))


def toml_spec(tmp_path, text):
    path = tmp_path / "spec.toml"
    path.write_text(text)
    return load_spec(path)


def flag_for(name, text, value):
    flag = "--" + name.replace("_", "-")
    if text is None:   # a boolean: --X or --no-X
        return [flag if value else "--no-" + flag[2:]]
    return [f"{flag}={text}"]


def test_every_field_has_a_sample():
    assert set(SAMPLES) == set(FIELD_NAMES)


@pytest.mark.parametrize("name", FIELD_NAMES)
def test_every_field_has_one_name_on_every_surface(tmp_path, name):
    value, text = SAMPLES[name]
    from_python = make_spec(**{name: value})
    from_cli = cli_spec(*flag_for(name, text, value))
    from_toml = toml_spec(tmp_path, f"{name} = {toml_value(value)}\n")
    assert from_python == from_cli == from_toml
    assert field_value(from_python, name) == resolve_field(name).check(value)
    if "texture" not in name and name != "gltf_materials":
        assert from_python != ChartSpec(), f"the sample for {name} is the default"


@pytest.mark.parametrize("alias, name, value, text", [
    ("row_materials", "materials", ("gold", "copper"), "gold,copper"),
    ("azimuth", "camera_azimuth", 45.0, "45"),
    ("elevation", "camera_elevation", -10.0, "-10"),
    ("bug", "bugs", ("no-cosine",), "no-cosine"),
])
def test_aliases_work_everywhere(tmp_path, alias, name, value, text):
    expected = make_spec(**{name: value})
    assert make_spec(**{alias: value}) == expected
    assert cli_spec(f"--{alias.replace('_', '-')}={text}") == expected
    assert toml_spec(tmp_path, f"{alias} = {toml_value(value)}\n") == expected
    with pytest.raises(SpecError, match="both set"):
        make_spec(**{alias: value, name: value})


def test_dash_and_underscore_are_the_same_everywhere(tmp_path):
    expected = make_spec(base_color=(1.0, 0.0, 0.0), camera_azimuth=10.0)
    assert make_spec(**{"base-color": (1, 0, 0), "camera-azimuth": 10}) == expected
    assert cli_spec("--base_color", "1,0,0", "--camera_azimuth=10") == expected
    assert cli_spec("--base-color", "1,0,0", "--camera-azimuth", "10") == expected
    assert toml_spec(tmp_path, 'base-color = [1, 0, 0]\ncamera_azimuth = 10\n') == expected
    assert toml_spec(tmp_path, '[[lights]]\nangular-radius-deg = 3.0\n').lights[0].angular_radius_deg == 3.0


def test_size_sets_width_and_height_on_every_surface(tmp_path):
    expected = make_spec(width=256, height=128)
    assert make_spec(size="256x128") == make_spec(size=(256, 128)) == make_spec(size=np.array([256, 128])) == expected
    assert cli_spec("--size", "256x128") == cli_spec("--width", "256", "--height", "128") == expected
    assert toml_spec(tmp_path, 'size = "256x128"\n') == toml_spec(tmp_path, "size = [256, 128]\n") == expected
    with pytest.raises(SpecError, match="both set width"):
        make_spec(size="64x64", width=32)


def test_materials_set_the_rows_unless_rows_are_given():
    assert make_spec(materials=["gold", "copper"]).rows == 2
    # Measured metals are metals unless metallic is given (issue 10: gold was a cream plastic).
    assert make_spec(materials=["gold"]).metallic == (1.0, 1.0)
    assert make_spec(materials=["gold"], metallic=(0.0, 1.0)).metallic == (0.0, 1.0)
    assert cli_spec("--materials", "gold,iron").metallic == (1.0, 1.0)
    assert cli_spec("--materials", "gold", "--metallic", "0:1").metallic == (0.0, 1.0)
    assert make_spec(row_materials="gold,iron,silver").materials == ("gold", "iron", "silver")
    with pytest.raises(SpecError, match="one per row"):
        make_spec(rows=3, materials=["gold"])


def test_numpy_numbers_are_numbers():
    spec = make_spec(width=np.int64(64), height=np.int32(48), rows=np.uint8(3), exposure=np.float32(0.5),
                     base_color=np.array([1.0, 0.5, 0.25]), shadows=np.bool_(False))
    assert (spec.width, spec.height, spec.rows, spec.exposure) == (64, 48, 3, 0.5)
    assert type(spec.width) is int and type(spec.exposure) is float and spec.shadows is False


def _message(fn):
    try:
        fn()
    except SpecError as exc:
        return str(exc)
    raise AssertionError("accepted")


def _cli_message(*argv):
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        status = main(["shader", *argv])
    assert status == 2 and len(err.getvalue().strip().splitlines()) == 1, err.getvalue()
    return err.getvalue().strip()


@pytest.mark.parametrize("name, value, toml, cli, needle", [
    ("width", 64.7, "64.7", "64.7", "width must be a whole number"),
    ("size", [64.7, 48.2], "[64.7, 48.2]", "64.7x48.2", "width must be a whole number"),
    ("rows", 2.5, "2.5", "2.5", "rows must be a whole number"),
    ("rows", True, "true", "true", "rows must be a number"),
    ("size", [True, 48], "[true, 48]", "truex48", "width must be a number"),
    ("exposure", [[1.0]], "[[1.0]]", "[[1.0]]", "exposure must be a number"),
    ("rows", [[1, 2]] * 40, "[" + ", ".join(["[1, 2]"] * 40) + "]", "[[1]]", "rows must be a number"),
    ("exposure", math.inf, "inf", "inf", "exposure must be a finite number"),
    ("spp", 0, "0", "0", "spp must be in [1, 1024]"),
])
def test_refusals_are_the_same_on_every_surface(tmp_path, name, value, toml, cli, needle):
    python = _message(lambda: make_spec(**{name: value}))
    path = tmp_path / "bad.toml"
    path.write_text(f"{name} = {toml}\n")
    from_toml = _message(lambda: load_spec(path))
    from_cli = _cli_message(f"--{name}={cli}")
    for msg in (python, from_toml, from_cli):
        assert needle in msg, msg
        assert len(msg.replace(str(path), "")) < 120, msg     # a bad value is quoted short
    assert python.split(", got")[0] == from_toml.split(": ", 1)[1].split(", got")[0]


def test_unknown_names_suggest_the_closest_everywhere(tmp_path):
    with pytest.raises(SpecError, match="unknown option 'siez'.*did you mean 'size'"):
        sdfpbr.make_spec(siez="64x64")
    with pytest.raises(SpecError, match="did you mean 'materials'"):
        resolve_field("materils")
    assert "did you mean 'caption'" in _message(lambda: toml_spec(tmp_path, 'captoin = "x"\n'))


def test_the_issues_python_commands(cache_dir):
    a = sdfpbr.chart(size="64x64")
    b = sdfpbr.chart(size="64x64", row_materials=["gold"])
    c = sdfpbr.chart(width=64, height=64, materials=["gold"])
    assert a.spec.width == b.spec.width == c.spec.width == 64 and b.spec == c.spec and b.spec.rows == 1
    assert a.image.ndim == 3 and np.array_equal(b.image, c.image)


@pytest.mark.parametrize("path", CHARTS, ids=lambda p: p.name)
def test_every_chart_file_loads_as_a_spec(path):
    """(The files a chart names, e.g. gltf-materials.toml's asset, are found beside it.) A
    [compare] or [sweep] entry is no chart spec: load_spec refuses it, naming `sdfpbr build`."""
    spec_mapping, entry = read_entry_document(path)
    assert set(entry) <= set(ENTRY_KEYS) and not set(spec_mapping) & set(ENTRY_KEYS)
    section = next((k for k in ("compare", "sweep") if k in entry), None)
    if section:
        with pytest.raises(SpecError, match=rf"\[{section}\] gallery entry, not a chart spec: `sdfpbr build "):
            load_spec(path)
        return
    assert load_spec(path) == spec_from_mapping(resolve_relative_files(spec_mapping, path.parent))


def test_a_docs_entry_renders_with_chart_spec(tmp_path, cache_dir):
    out = tmp_path / "m.png"
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--spec", str(CHARTS[0].parent / "materials.toml"),
                        "--size", "96x96", "--quality", "draft", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_entry_documents_split_into_spec_and_entry():
    spec, entry = split_entry({"caption": "c", "sweep": {"field": "env"}, "spec": {"size": "64x64"}})
    assert spec == {"size": "64x64"} and set(entry) == {"caption", "sweep", "spec"}
    spec, entry = split_entry({"caption": "c", "rows": 3})
    assert spec == {"rows": 3} and entry == {"caption": "c"}
    with pytest.raises(SpecError, match="not both"):
        split_entry({"sweep": {}, "compare": {}})
    with pytest.raises(SpecError, match="unknown top-level key 'rows'.*go in \\[spec\\]"):
        split_entry({"sweep": {}, "rows": 3})
    with pytest.raises(SpecError, match="belongs to"):
        split_entry({"spec": {"rows": 3}})


def test_sweep_values_from_text():
    assert sweep_values_from_text("exposure", "-2,0,2.5") == [-2.0, 0.0, 2.5]
    assert sweep_values_from_text("multiscatter", "on,off") == [True, False]
    assert sweep_values_from_text("roughness", "0:0.5;0.5:1") == [(0.0, 0.5), (0.5, 1.0)]
    assert sweep_values_from_text("base-color", "1,0,0;0,1,0") == [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    assert sweep_values_from_text("row_materials", "gold+copper,iron+silver") == [("gold", "copper"),
                                                                                  ("iron", "silver")]
    assert sweep_values_from_text("lights", "default,none") == ["default", "none"]
    assert field_value_from_text("size", "64x32") == (64, 32)
    assert field_value_from_text("materials", "gold+copper") == ("gold", "copper")
    with pytest.raises(SpecError, match="must be numbers"):
        sweep_values_from_text("exposure", "1,x")
    assert sweep_defaults("azimuth") == sweep_defaults("camera_azimuth")
    with pytest.raises(SpecError, match="needs values"):
        sweep_defaults("rows")


def test_nonsense_command_is_one_line_with_a_suggestion():
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "nonsense"], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]
    assert r.stderr.startswith("sdfpbr: error: unknown command 'nonsense'; commands: chart, ")
    assert "sdfpbr: error: sdfpbr" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chrat"], capture_output=True, text=True)
    assert r.returncode == 2 and "did you mean 'chart'" in r.stderr


# ---- round trips of the writers -------------------------------------------------------------------

# Any text the spec takes (checks.text refuses bidi and control characters but tab and breaks).
TEXT = st.text(st.one_of(st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters=BIDI_CONTROLS),
                         st.sampled_from("\t\n\r")), max_size=12)


def _value(field, rows):
    if field.kind == "int":
        lo, hi = field.bounds
        return st.integers(lo, min(hi, 4096))
    if field.kind == "float":
        lo, hi = field.bounds
        return st.floats(lo, hi, allow_nan=False, allow_infinity=False)
    if field.kind == "bool":
        return st.booleans()
    if field.kind == "choice":
        return st.sampled_from(field.choices)
    if field.kind == "range":   # off an axis a range holds one value (specs() below)
        lo, hi = field.bounds
        return st.tuples(st.floats(lo, hi), st.floats(lo, hi))
    if field.kind == "color":
        return st.tuples(st.floats(0, 1), st.floats(0, 1), st.floats(0, 1))
    if field.kind == "names" and not field.choices:   # glTF material names need a glTF file
        return st.just(())
    if field.kind == "names":
        return st.one_of(st.just(()), st.lists(st.sampled_from(field.choices), min_size=rows, max_size=rows))
    if field.kind == "bugs":
        return st.lists(st.sampled_from(field.choices), unique=True, max_size=3).map(tuple)
    if field.kind == "env":
        return st.sampled_from(ENV_PRESETS)
    if field.kind == "text":
        return TEXT
    if field.kind == "lights":
        light = st.builds(Light, kind=st.sampled_from(["directional", "point"]),
                          direction=st.tuples(st.floats(0.1, 1), st.floats(-1, 1), st.floats(-1, 1)),
                          intensity=st.floats(0, 100), range=st.floats(0.5, 100))
        return st.one_of(st.just(DEFAULT_LIGHTS), st.just(()), st.lists(light, max_size=2).map(tuple))
    return st.just(field.default)   # texture paths: "" (a file would have to exist)


@st.composite
def specs(draw):
    rows = draw(st.integers(1, 6))
    axes = draw(st.lists(st.sampled_from(AXIS_PARAMS), min_size=2, max_size=2, unique=True))
    values = {"rows": rows, "x_axis": axes[0], "y_axis": axes[1]}
    for field in FIELDS:
        if field.name not in ("rows", "size", "x_axis", "y_axis") and draw(st.booleans()):
            values[field.name] = draw(_value(field, rows))
            if field.kind == "range" and field.name not in axes:
                values[field.name] = values[field.name][0]   # one value off an axis
    if "exposure" in axes:
        values["stage"] = "cells"   # the only stage an exposure axis is drawn on
    default = ChartSpec()
    if values.get("stage", default.stage) == "cells":   # a pixel per cell at least
        values["width"] = max(values.get("width", default.width), values.get("cols", default.cols))
        values["height"] = max(values.get("height", default.height), rows)
    return make_spec(**values)


ROUND_TRIP = settings(max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])


@ROUND_TRIP
@given(spec=specs())
def test_spec_to_toml_round_trips(tmp_path_factory, spec):
    path = tmp_path_factory.mktemp("toml") / "spec.toml"
    path.write_text(spec_to_toml(spec, comments=["written by a test"]), encoding="utf-8")
    assert load_spec(path) == spec


@ROUND_TRIP
@given(spec=specs(), base=st.one_of(st.none(), specs()))
def test_spec_to_flags_round_trips(tmp_path_factory, spec, base):
    """Flags on top of the defaults, or of a --spec file: only default/none lights have a flag,
    and flags add bugs to the base's."""
    ref = base or ChartSpec()
    if spec.lights != ref.lights and spec.lights not in (DEFAULT_LIGHTS, ()):
        with pytest.raises(SpecError, match="spec_to_toml"):
            spec_to_flags(spec, base)
        spec = make_spec(spec, lights=ref.lights)
    bugs = ref.bugs + tuple(b for b in spec.bugs if b not in ref.bugs)
    if bugs != spec.bugs:
        with pytest.raises(SpecError, match="only add bugs"):
            spec_to_flags(spec, base)
        spec = make_spec(spec, bugs=bugs)
    argv = spec_to_flags(spec, base)
    if base is not None:
        path = tmp_path_factory.mktemp("base") / "base.toml"
        path.write_text(spec_to_toml(base), encoding="utf-8")
        argv = ["--spec", str(path), *argv]
    assert cli_spec(*argv) == spec, argv


@pytest.mark.parametrize("rows, materials, metallic", [
    (1, ("gold",), (0.0, 0.0)),                         # metallic 0 would read back as 1
    (3, ("gold", "silver", "iron"), (0.25, 0.25)),
    (2, ("gold", "copper") * 5, (1.0, 1.0)),             # one per cell: 10 would read back as 10 rows
])
def test_materials_flags_read_back_with_the_specs_rows_and_metallic(tmp_path, rows, materials, metallic):
    """`--materials` alone reads back as one metal row per material (attr_values); a spec whose
    rows or metallic say otherwise writes them too. Found by the round-trip property test: a
    one-row base and a gold row at metallic 0 read back at metallic 1."""
    base = ChartSpec(rows=rows)
    spec = make_spec(base, row_materials=materials, metallic=metallic, rows=rows)
    path = tmp_path / "base.toml"
    path.write_text(spec_to_toml(base), encoding="utf-8")
    for argv in (spec_to_flags(spec, base), ["--spec", str(path), *spec_to_flags(spec, base)]):
        assert cli_spec(*argv) == spec, argv


def test_spec_to_flags_skips_the_defaults_and_bugs_are_added():
    assert spec_to_flags(ChartSpec()) == []
    assert spec_to_flags(make_spec(bugs=["no-cosine"])) == ["--bugs=no-cosine"]
    base = make_spec(bugs=["no-cosine"])
    with pytest.raises(SpecError, match="only add bugs"):
        spec_to_flags(ChartSpec(), base)


def test_bugs_need_no_import_of_the_spec_module():
    """bugs.py is data the spec module imports; it must not import the spec module back."""
    import ast
    import sdfpbr.spec.bugs as bugs
    imported = [n.module for n in ast.walk(ast.parse(Path(bugs.__file__).read_text()))
                if isinstance(n, ast.ImportFrom)]
    assert not any(m and ("chart_spec" in m or "fields" in m) for m in imported)
    spec = BUGS["orm-srgb"].apply(ChartSpec())
    assert spec.bugs == ("orm-srgb",) and spec.textures == "procedural"
    assert BUGS["orm-srgb"].correct(ChartSpec()).bugs == ()


def test_a_size_nobody_chose_follows_the_grid_and_a_chosen_one_stays(tmp_path):
    """Square cells with 1024 px on the grid's longer side, unless a size is given; the TOML and
    flag forms read back to the same size either way."""
    from sdfpbr.spec.chart_spec import grid_size
    from sdfpbr.spec.fields import spec_to_flags
    from sdfpbr.cli.main import build_parser, spec_from_args
    assert (make_spec(rows=1).width, make_spec(rows=1).height) == (1024, 205)
    assert (make_spec(rows=6, cols=3).width, make_spec(rows=6, cols=3).height) == (512, 1024)
    assert grid_size(5, 5) == (1024, 1024) and (make_spec().width, make_spec().height) == (1024, 1024)
    chosen = make_spec(rows=1, size="1024x1024")
    assert (chosen.width, chosen.height) == (1024, 1024)
    assert (make_spec(chosen, cols=3).width, make_spec(chosen, cols=3).height) == (1024, 1024)   # stays chosen
    assert make_spec(make_spec(rows=1), cols=3).height == 341                                   # follows again
    path = tmp_path / "strip.toml"
    path.write_text("rows = 1\ncols = 4\n")
    assert (load_spec(path).width, load_spec(path).height) == (1024, 256)
    for spec in (chosen, make_spec(rows=1), make_spec(rows=2, cols=7, width=300)):
        args = build_parser().parse_args(["chart", *spec_to_flags(spec)])
        assert spec_from_args(args) == spec, spec_to_flags(spec)


def test_a_spec_rebuilt_with_no_changes_is_the_same_spec():
    """An axis parameter held at its default single value stays there when nothing moves the
    axes (a --spec file read back with no flags): only a parameter put on or taken off an axis
    follows it."""
    base = make_spec(rows=1, x_axis="metallic", y_axis="clearcoat", clearcoat=(0.0, 0.0))
    assert make_spec(base) == base and make_spec(base, cols=3).clearcoat == (0.0, 0.0)
    assert make_spec(base, y_axis="ior").ior == (1.0, 2.5)


def test_a_spec_files_relative_files_are_found_beside_it(tmp_path, monkeypatch):
    """A spec file in another directory names its glTF asset beside it; the same name from the
    working directory, where no such file is, would not load."""
    import shutil
    glb = Path(__file__).parents[1] / "charts" / "materials.glb"
    pytest.importorskip("pygltflib", reason="the gltf extra (pygltflib) is not installed")
    (tmp_path / "sub").mkdir()
    shutil.copy(glb, tmp_path / "sub" / "m.glb")
    (tmp_path / "sub" / "spec.toml").write_text('gltf = "m.glb"\n')
    monkeypatch.chdir(tmp_path)
    assert load_spec("sub/spec.toml").gltf == str(Path("sub") / "m.glb")
    with pytest.raises(SpecError, match="m.glb"):
        make_spec(gltf="m.glb")


def test_huge_lists_are_refused_before_they_are_read_and_quoted_short():
    """Issue 12: a million lights were read (53 s, 950 MB) before the refusal; a million-value
    roughness gave a 5 MB error line. The count is checked first, and a bad value is quoted
    as a short excerpt."""
    with pytest.raises(SpecError, match="at most 16 lights, got 1000000"):
        make_spec(lights=[{"kind": "directional", "direction": "bad"}] * 10**6)
    with pytest.raises(SpecError) as refused:
        make_spec(roughness=[0.5] * 10**6)
    assert len(str(refused.value)) < 200, len(str(refused.value))


def test_base_colours_per_row_per_cell_and_the_hue_axis_reach_each_cell():
    """`base_colors` with one colour per row fills each row with it, one per cell fills the
    cells row by row; the `base_color_hue` axis turns the base colour's hue across the columns
    (0 to 300 degrees by default), keeping its saturation and value. A list that is neither is
    refused with one line naming both counts."""
    import colorsys
    rows = make_spec(rows=2, cols=3, base_colors=[(1, 0, 0), (0, 0, 1)]).cell_materials()
    assert [[m.base_color for m in row] for row in rows] == [[(1.0, 0.0, 0.0)] * 3, [(0.0, 0.0, 1.0)] * 3]
    six = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0, 1, 1), (1, 0, 1)]
    cells = make_spec(rows=2, cols=3, base_colors=six).cell_materials()
    assert [m.base_color for row in cells for m in row] == [tuple(map(float, c)) for c in six]
    hues = make_spec(rows=1, cols=4, x_axis="base_color_hue", base_color=(0.8, 0.2, 0.2)).cell_materials()[0]
    for m, hue in zip(hues, (0.0, 100.0, 200.0, 300.0)):
        h, s, v = colorsys.rgb_to_hsv(*m.base_color)
        assert (h * 360.0 - hue + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-6)
        assert (s, v) == pytest.approx((0.75, 0.8))
    with pytest.raises(SpecError, match="lists 4 entries for 2 rows x 3 columns"):
        make_spec(rows=2, cols=3, base_colors=six[:4]).cell_materials()


def test_a_spec_file_saved_with_a_byte_order_mark_reads(tmp_path):
    """Windows editors start UTF-8 files with a BOM, which TOML's parser calls an invalid
    statement at line 1, column 1."""
    from sdfpbr.spec.chart_spec import load_spec
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbfrows = 2\n")
    assert load_spec(path).rows == 2
