"""Bad input, fuzzed (hypothesis): every invalid CLI argument or TOML spec gets one line on
stderr and exit status 2 -- never a traceback, never an output file created or overwritten.
main() runs in-process; invalid inputs are rejected before any rendering."""
import io
import json
import math
import tomllib
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sdfpbr.cli.main import build_parser, main
from sdfpbr.errors import SpecError
from sdfpbr.spec.fields import FIELD_NAMES, FIELDS
from sdfpbr.spec.chart_spec import (BACKENDS, BRDF_MODELS, CAMERAS, ENV_PRESETS, INTERSECT_METHODS, MATERIAL_PRESETS,
                         QUALITY_PRESETS, SPEC_KEYS, TONEMAPPERS, load_spec)

# Seeded: derandomize draws every example from the test's own source, so CI runs the same
# examples each time (a failure reproduces; no example database is kept).
FUZZ = settings(max_examples=150, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
KEEP = b"pre-existing output, must survive"
PRINTABLE = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=12)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "keep.png").write_bytes(KEEP)
    return d


def snapshot(d: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir()) if p.is_file()}


def run(argv) -> tuple[int, str, str]:
    """main() in-process; any exception escaping it would be a traceback for the user."""
    err, out = io.StringIO(), io.StringIO()
    with redirect_stderr(err), redirect_stdout(out):
        status = main([str(a) for a in argv])
    return status, err.getvalue(), out.getvalue()


def assert_rejected(argv, workdir):
    before = snapshot(workdir)
    status, err, _ = run(list(argv) + ["-o", workdir / "keep.png"])
    lines = err.strip().splitlines()
    assert status == 2, (argv, status, err)
    assert len(lines) == 1 and lines[0].startswith("sdfpbr: error: "), (argv, err)
    assert "Traceback" not in err
    assert snapshot(workdir) == before, argv


# ---- CLI arguments ------------------------------------------------------------------------------

def _not(parse):
    def reject(text):
        try:
            parse(text)
        except (ValueError, OverflowError):
            return True
        return False
    return reject


def _float_outside(lo, hi):
    return st.one_of(st.floats(allow_nan=True, allow_infinity=True).filter(lambda x: not (lo <= x <= hi)).map(repr),
                     PRINTABLE.filter(_not(float)))


def _whole_within(lo, hi):
    """Whether a text is a whole number in [lo, hi] as the spec reads it: any finite number
    with an integral value ("2", "2.", "2e0"), not only what int() takes."""
    def accepted(text):
        try:
            v = float(text)
        except (ValueError, OverflowError):
            return False
        return math.isfinite(v) and v == int(v) and lo <= v <= hi
    return accepted


def _int_outside(lo, hi):
    return st.one_of(st.integers().filter(lambda x: not (lo <= x <= hi)).map(str),
                     PRINTABLE.filter(lambda t: not _whole_within(lo, hi)(t)))


def _word_outside(allowed):
    return PRINTABLE.filter(lambda t: t not in allowed)


def _unit_number(text):
    try:
        return 0 <= float(text) <= 1
    except ValueError:
        return False


def _valid_unit_interval():
    return st.floats(0, 1).map(repr)


OPTION_NAMES = sorted({s for a in build_parser()._subparsers._group_actions[0].choices["chart"]._actions
                       for s in a.option_strings})

INVALID_FLAGS = st.one_of(
    st.tuples(st.sampled_from(["--rows", "--cols"]), _int_outside(1, 64)),
    st.tuples(st.just("--spp"), _int_outside(1, 1024)),
    st.tuples(st.just("--device-index"), _int_outside(0, 64)),
    st.tuples(st.just("--exposure"), _float_outside(-40, 40)),
    st.tuples(st.just("--env-intensity"), _float_outside(0, 1e6)),
    st.tuples(st.just("--azimuth"), _float_outside(-3600, 3600)),
    st.tuples(st.just("--elevation"), _float_outside(-89, 89)),
    st.tuples(st.just("--tonemap"), _word_outside(TONEMAPPERS)),
    st.tuples(st.just("--brdf"), _word_outside(BRDF_MODELS)),
    st.tuples(st.just("--camera"), _word_outside(CAMERAS)),
    st.tuples(st.just("--intersect"), _word_outside(INTERSECT_METHODS)),
    st.tuples(st.just("--quality"), _word_outside(tuple(QUALITY_PRESETS))),
    st.tuples(st.just("--backend"), _word_outside(BACKENDS)),
    st.tuples(st.just("--lights"), _word_outside(("default", "none"))),
    st.tuples(st.just("--materials"), st.lists(PRINTABLE.filter(lambda t: t.strip() not in MATERIAL_PRESETS
                                                                          and "," not in t),
                                               min_size=1, max_size=3).map(",".join).filter(bool)),
    st.tuples(st.just("--env"), PRINTABLE.filter(lambda t: t not in ENV_PRESETS and t)),
    st.tuples(st.sampled_from(["--roughness", "--metallic"]),
              st.one_of(st.tuples(_float_outside(0, 1), _valid_unit_interval()).map(":".join),
                        st.tuples(_valid_unit_interval(), _float_outside(0, 1)).map(":".join),
                        _float_outside(0, 1),  # one number is a range of one value: only out of bounds is wrong
                        PRINTABLE.filter(lambda t: t.count(":") != 1 and not _unit_number(t)))),
    st.tuples(st.just("--base-color"),
              st.one_of(st.tuples(_float_outside(0, 1), _valid_unit_interval(), _valid_unit_interval()).map(",".join),
                        PRINTABLE.filter(lambda t: t.count(",") != 2))),
    st.tuples(st.just("--size"),
              st.one_of(st.tuples(_int_outside(1, 65536), st.integers(1, 64).map(str)).map("x".join),
                        st.tuples(st.integers(1, 64).map(str), _int_outside(1, 65536)).map("x".join),
                        PRINTABLE.filter(lambda t: t.lower().count("x") != 1))),
    # Every number and choice field of the table, outside what its check allows.
    st.sampled_from([f for f in FIELDS if f.kind in ("int", "float", "choice")]).flatmap(
        lambda f: st.tuples(st.just(f.option_strings[-1]),
                            _word_outside(f.choices) if f.kind == "choice" else
                            (_int_outside if f.kind == "int" else _float_outside)(*f.bounds))),
    # An option nobody defined (argparse would take an unambiguous prefix of a real one).
    st.from_regex(r"--[a-z][a-z\-]{0,10}", fullmatch=True)
      .filter(lambda o: not any(known.startswith(o) for known in OPTION_NAMES)).map(lambda o: (o, "1")),
)
VALID_FLAGS = st.lists(st.sampled_from([("--rows", "2"), ("--cols", "3"), ("--tonemap", "aces"), ("--no-ao", None),
                                        ("--exposure", "-1.5"), ("--quality", "draft")]), max_size=3, unique=True)


def _argv(valid, invalid):
    argv = ["chart"]
    for flag, value in valid:
        argv += [flag] + ([value] if value is not None else [])
    flag, value = invalid
    return argv + [flag, value] if not str(value).startswith("-") else argv + [f"{flag}={value}"]


@FUZZ
@given(valid=VALID_FLAGS, invalid=INVALID_FLAGS)
@example(valid=[], invalid=("--rows", "inf"))
@example(valid=[], invalid=("--size", "0x8"))
@example(valid=[], invalid=("--exposure", "nan"))
@example(valid=[], invalid=("--roughness", "1.5"))
def test_invalid_cli_arguments_are_one_line_exit_2(workdir, valid, invalid):
    assert_rejected(_argv(valid, invalid), workdir)


@pytest.mark.parametrize("name, needle", [("out.jpg", "must end in .png"), ("out.PNGX", "must end in .png"),
                                          ("out", "must end in .png"), ("missing/out.png", "does not exist"),
                                          ("adir.png", "is a directory")])
def test_bad_output_paths_are_refused(workdir, name, needle):
    (workdir / "adir.png").mkdir(exist_ok=True)
    before = snapshot(workdir)
    status, err, _ = run(["chart", "--size", "8x8", "-o", workdir / name])
    assert status == 2 and needle in err and len(err.strip().splitlines()) == 1
    assert snapshot(workdir) == before


# ---- TOML specs ---------------------------------------------------------------------------------

def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v)))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{toml_value(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def toml_doc(mapping: dict) -> str:
    return "".join(f"{toml_value(k)} = {toml_value(v)}\n" for k, v in mapping.items())


SCALARS = st.one_of(st.booleans(), st.integers(-2 ** 63, 2 ** 63 - 1), st.floats(allow_nan=True, allow_infinity=True),
                    PRINTABLE)
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                        st.dictionaries(PRINTABLE, inner, max_size=3)), max_leaves=8)
# Values a known key might plausibly get: valid ones, near misses and junk.
PLAUSIBLE = {
    "rows": st.integers(-2, 70), "cols": st.integers(-2, 70), "width": st.integers(-2, 70000),
    "height": st.integers(-2, 70000), "spp": st.integers(-1, 2000), "exposure": st.floats(-50, 50),
    "roughness": st.one_of(st.lists(st.floats(-0.5, 1.5), min_size=2, max_size=2), st.just("0:1"), PRINTABLE),
    "metallic": st.one_of(st.lists(st.floats(-0.5, 1.5), min_size=2, max_size=2), st.just("0.2:0.8")),
    "base_color": st.lists(st.floats(-0.5, 1.5), min_size=2, max_size=4),
    "ground_color": st.lists(st.floats(-1.5, 1.5), min_size=3, max_size=3),
    "tonemap": st.sampled_from(TONEMAPPERS + ("acse", "ACES", "")),
    "env": st.sampled_from(ENV_PRESETS + ("studi0", "nowhere.exr", "x.npy", "")),
    "lights": st.one_of(st.sampled_from(["default", "none", "all"]), st.lists(st.fixed_dictionaries(
        {}, optional={"kind": st.sampled_from(["directional", "point", "spot"]),
                      "direction": st.lists(st.floats(-1e300, 1e300), min_size=3, max_size=3),
                      "position": st.lists(st.floats(allow_nan=True), min_size=2, max_size=4),
                      "intensity": st.floats(-1, 1e13), "color": st.lists(st.floats(-1, 2), min_size=3, max_size=3),
                      "angular_radius_deg": st.floats(-1, 90), "range": st.floats(-1, 1e13),
                      "radius": st.floats()}), max_size=3)),
    "camera_distance_scale": st.floats(0, 2000), "hdr_precision": st.sampled_from(["float32", "float16", "half", ""]),
    "size": st.one_of(st.just("64x32"), PRINTABLE, st.lists(st.integers(-1, 99), min_size=1, max_size=3)),
}
KEYS = st.sampled_from(sorted(set(SPEC_KEYS) | set(FIELD_NAMES) | {"camera-azimuth", "azimuth", "base-color"}))


@st.composite
def spec_documents(draw):
    doc = {}
    for key in draw(st.lists(st.one_of(KEYS, PRINTABLE.filter(bool)), min_size=1, max_size=5, unique=True)):
        name = key.replace("-", "_")
        name = {"azimuth": "camera_azimuth", "row_materials": "materials"}.get(name, name)
        doc[key] = draw(st.one_of(PLAUSIBLE[name], VALUES) if name in PLAUSIBLE else VALUES)
    # Keep renders small when a document happens to be valid.
    doc.setdefault("width", 8)
    doc.setdefault("height", 8)
    return doc


@FUZZ
@given(doc=spec_documents())
@example(doc={"rows": math.inf})
@example(doc={"width": math.nan})
@example(doc={"lights": [{"direction": [1e200, 0.0, 0.0]}]})
@example(doc={"ground_color": [-1.0, 0.0, 0.0]})
def test_toml_specs_are_valid_or_one_line_exit_2(workdir, tmp_path_factory, doc):
    text = toml_doc(doc)
    assert tomllib.loads(text) is not None   # the document itself is well-formed TOML
    path = tmp_path_factory.mktemp("spec") / "spec.toml"
    path.write_text(text)
    try:
        load_spec(path)
    except SpecError:
        assert_rejected(["chart", "--spec", path], workdir)
        return
    # Valid: the composed shader (no GPU work) and the spec's own round trip must succeed.
    status, err, out = run(["shader", "--spec", path])
    assert status == 0 and out.startswith("#version"), err


@FUZZ
@given(data=st.one_of(st.binary(max_size=200), st.text(max_size=200).map(str.encode)))
@example(data=b"\xff\xfe rows = 3")
@example(data=b"rows = = 3")
def test_arbitrary_spec_files_never_crash(workdir, tmp_path_factory, data):
    path = tmp_path_factory.mktemp("raw") / "spec.toml"
    path.write_bytes(data)
    try:
        load_spec(path)
    except SpecError:
        assert_rejected(["chart", "--spec", path], workdir)


NUMBERS = st.floats(-2.0, 2.0) | st.sampled_from([0.0, 1.0, 1e-300, 1e300])
SHADED = st.fixed_dictionaries({}, optional={
    "base_color": st.lists(NUMBERS, min_size=3, max_size=3),
    "ground_color": st.lists(NUMBERS, min_size=3, max_size=3),
    "ground_roughness": NUMBERS, "exposure": st.floats(-40, 40), "env_intensity": NUMBERS,
    "roughness": st.lists(NUMBERS, min_size=2, max_size=2), "metallic": st.lists(NUMBERS, min_size=2, max_size=2),
    "lights": st.lists(st.fixed_dictionaries({"kind": st.sampled_from(["directional", "point"])}, optional={
        "color": st.lists(NUMBERS, min_size=3, max_size=3), "intensity": st.floats(-1, 1e12),
        "direction": st.lists(NUMBERS, min_size=3, max_size=3), "position": st.lists(NUMBERS, min_size=3, max_size=3),
        "angular_radius_deg": st.floats(-1, 46)}), max_size=2),
})


RENDER_FUZZ = settings(FUZZ, max_examples=80)
OVERHEAD_SUN = {"kind": "directional", "direction": [0.0, 1.0, 0.0], "intensity": 1.0}


@RENDER_FUZZ
@given(doc=SHADED)
@example(doc={"ground_color": [-1.0, 0.0, 0.0]})
def test_every_spec_the_validator_accepts_renders_finite_non_negative(session, tmp_path_factory, doc):
    """The other half of validation: what passes it must render, finite and not all black
    where something lit is in view: a white sun overhead is added to the fuzzed lights, so a
    floor or spheres with any colour must give some light back. Environment black and no IBL
    keep each example to one small render (no environment bake)."""
    doc = {**doc, "env": "black", "ibl": False, "width": 12, "height": 10, "rows": 2, "cols": 2, "quality": "draft",
           "lights": [*doc.get("lights", []), OVERHEAD_SUN]}
    path = tmp_path_factory.mktemp("valid") / "spec.toml"
    path.write_text(toml_doc(doc))
    try:
        spec = load_spec(path)
    except SpecError:
        return
    res = session.render(spec)
    assert np.isfinite(res.hdr).all() and res.hdr.min() >= 0, doc
    if max(*spec.base_color, *spec.ground_color) > 1e-3:   # something under the sun reflects it
        assert res.hdr.max() > 0, doc


# ---- standalone textures ----------------------------------------------------------------------

IMAGE_MODES = ["1", "L", "LA", "P", "RGB", "RGBA", "I;16", "I", "F"]


@st.composite
def texture_files(draw):
    """Bytes of a texture file: a PNG (or TIFF, for the 32-bit modes PNG cannot hold) of any
    mode and size, or such a file cut short, or bytes that are no image."""
    from PIL import Image
    kind = draw(st.sampled_from(["image", "cut", "noise"]))
    if kind == "noise":
        return draw(st.binary(max_size=300))
    mode = draw(st.sampled_from(IMAGE_MODES))
    w, h = draw(st.integers(1, 40)), draw(st.integers(1, 40))
    seed = draw(st.integers(0, 2 ** 16))
    pixels = np.random.default_rng(seed).integers(0, 256, (h, w, 4), dtype=np.uint8)
    image = Image.fromarray(pixels, "RGBA").convert(mode if mode not in ("I;16", "I", "F") else "L")
    if mode in ("I;16", "I", "F"):
        image = image.convert(mode)
    buf = io.BytesIO()
    image.save(buf, format="TIFF" if mode in ("I", "F") else "PNG")
    data = buf.getvalue()
    return data[: draw(st.integers(0, len(data) - 1))] if kind == "cut" else data


@settings(FUZZ, max_examples=40)
@given(data=texture_files(), which=st.sampled_from(["--base-color-texture", "--orm-texture", "--normal-texture"]))
def test_standalone_textures_render_or_are_one_line(workdir, tmp_path_factory, data, which):
    """A texture file from the command line, of any mode, size or damage: it renders (exit 0,
    an image written) or it is refused with one line and exit 2, the output untouched."""
    path = tmp_path_factory.mktemp("texture") / "t.png"
    path.write_bytes(data)
    d = tmp_path_factory.mktemp("out")
    out, hdr = d / "c.png", d / "c.npy"
    status, err, _ = run(["chart", "--size", "16x16", "--rows", "1", "--cols", "1", "--quality", "draft",
                          "--no-ground", which, path, "-o", out, "--hdr", hdr])
    assert "Traceback" not in err
    if status == 0:   # a lit sphere of any map reflects something (its specular, if nothing else)
        radiance = np.load(hdr)
        assert out.exists() and np.isfinite(radiance).all() and radiance.min() >= 0 and radiance.max() > 0
    else:
        assert status == 2 and len(err.strip().splitlines()) == 1, (status, err)
        assert not out.exists() and not hdr.exists()


ENV_VALUES = st.sampled_from([0.0, 1e-30, 0.5, 1.0, 7.0, 1e29, 3.4e38, -1.0, np.nan, np.inf])


@settings(FUZZ, max_examples=30)
@example(shape=[8, 16, 3], dtype="f4", values=[0.5, 7.0], seed=1)     # lit: it must render, not black
@example(shape=[4, 8, 4], dtype="u1", values=[1.0, 0.0], seed=2)
@example(shape=[6, 12, 3], dtype="f2", values=[1e-30, 0.0], seed=3)   # dark, not black: renders
@given(shape=st.lists(st.integers(0, 12), min_size=1, max_size=4),
       dtype=st.sampled_from(["f4", "f8", "f2", "u1", "i4", "c8", "U3", "?"]),
       values=st.lists(ENV_VALUES, min_size=1, max_size=4), seed=st.integers(0, 2 ** 16))
def test_environment_files_render_or_are_one_line(workdir, tmp_path_factory, shape, dtype, values, seed):
    """An environment .npy of any shape, type and values (NaN, Inf, negative, huge), lighting
    the chart alone: it renders, finite and not all black when its radiance is, or it is one
    line and exit 2 with nothing written."""
    d = tmp_path_factory.mktemp("env")
    array = np.random.default_rng(seed).choice(np.array(values), size=tuple(shape))
    with np.errstate(all="ignore"):
        array = array.astype(dtype) if dtype != "U3" else array.astype(str)
    np.save(d / "env.npy", array)
    out, hdr = d / "c.png", d / "c.npy"
    status, err, _ = run(["chart", "--size", "16x16", "--rows", "1", "--cols", "1", "--quality", "draft",
                          "--lights", "none", "--env", d / "env.npy", "-o", out, "--hdr", hdr])
    assert "Traceback" not in err
    if status != 0:
        assert status == 2 and len(err.strip().splitlines()) == 1, (status, err)
        assert not out.exists() and not hdr.exists()
        return
    radiance = np.load(hdr)
    assert np.isfinite(radiance).all() and radiance.min() >= 0
    if np.asarray(array, np.float64).max() > 1e-3:   # a lit environment lights the chart
        assert radiance.max() > 0


@pytest.mark.parametrize("content", [b"not an array", b"", np.zeros((4, 4)), np.zeros((8, 16, 3)) - 1.0,
                                     np.full((8, 16, 3), np.nan), np.array([object()], dtype=object)])
def test_broken_environment_files_are_one_line_exit_2(workdir, tmp_path, content):
    """The env file is read at render time: still one line, exit 2, output untouched. (A text
    file named .npy used to escape as a numpy ValueError traceback.)"""
    path = tmp_path / "env.npy"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        np.save(path, content, allow_pickle=True)
    assert_rejected(["chart", "--size", "8x8", "--env", path], workdir)
