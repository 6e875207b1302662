"""Determinism: one spec gives byte-identical PNGs across renders, across processes, and from
an empty cache (the IBL bake and DFG LUT recomputed from scratch); seeded things (the stress
sweep, the reference path tracer) are functions of their seed."""
import os
import subprocess
import sys

import numpy as np

from sdfpbr.api import chart
from sdfpbr.spec.chart_spec import Light, make_spec
from sdfpbr.devtools.stress.cases import generate_cases
from sdfpbr.spec.fields import spec_to_toml

# Supersampled (a lattice of 3 points a pixel), both light kinds, IBL, AO, shadows, a tone map with a knee.
SPEC = make_spec(width=96, height=72, rows=2, cols=3, spp=3, quality="draft", tonemap="neutral",
                 lights=(Light("directional", direction=(-0.5, 0.7, 0.5), intensity=3.0, angular_radius_deg=2.5),
                         Light("point", position=(4.0, 2.0, 6.0), intensity=20.0)))


def cli_png(tmp_path, name, env=None):
    spec_file = tmp_path / "spec.toml"
    spec_file.write_text(spec_to_toml(SPEC))
    out = tmp_path / name
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--spec", str(spec_file), "-o", str(out)],
                       capture_output=True, text=True, env={**os.environ, **(env or {})})
    assert r.returncode == 0, r.stderr
    return out.read_bytes()


def test_same_spec_same_png_bytes_in_one_process(tmp_path):
    a, b = chart(SPEC), chart(SPEC)
    a.save(tmp_path / "a.png")
    b.save(tmp_path / "b.png")
    assert np.array_equal(a.hdr, b.hdr)
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_same_spec_same_png_bytes_across_processes(tmp_path):
    first, second = cli_png(tmp_path, "1.png"), cli_png(tmp_path, "2.png")
    assert first == second
    here = chart(SPEC)
    here.save(tmp_path / "here.png")
    assert (tmp_path / "here.png").read_bytes() == first


def test_an_empty_cache_bakes_the_same_pixels(tmp_path):
    """Two processes, each with its own empty cache: every LUT and IBL level is recomputed on
    the GPU, and the PNGs still match byte for byte."""
    a = cli_png(tmp_path, "a.png", {"SDFPBR_CACHE_DIR": str(tmp_path / "cache-a")})
    b = cli_png(tmp_path, "b.png", {"SDFPBR_CACHE_DIR": str(tmp_path / "cache-b")})
    assert a == b
    assert any((tmp_path / "cache-a" / "ibl").iterdir())


def test_stress_configurations_are_a_function_of_the_seed():
    assert [c.spec for c in generate_cases(21, 300)] == [c.spec for c in generate_cases(21, 300)]
    assert [c.spec for c in generate_cases(21, 300)] != [c.spec for c in generate_cases(22, 300)]


def test_reference_is_reproducible_from_its_seed(session):
    from sdfpbr.features.reference import render_reference
    spec = make_spec(width=32, height=24, rows=1, cols=2, quality="draft")
    a = render_reference(spec, samples=4, seed=7, session=session)
    b = render_reference(spec, samples=4, seed=7, session=session)
    c = render_reference(spec, samples=4, seed=8, session=session)
    assert np.array_equal(a.hdr, b.hdr) and np.array_equal(a.image, b.image)
    assert not np.array_equal(a.hdr, c.hdr)
