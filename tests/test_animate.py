"""Orbit animations: frames are the still charts of the orbit's specs, files read back with the
frame count and size written, and bad input stops before anything renders."""
import math
import re
import subprocess
import sys
import tracemalloc

import imageio.v3 as iio
import numpy as np
import pytest

from sdfpbr.features import animate as animate_mod
from sdfpbr.features.animate import animate, animate_compare, orbit_specs, write_animation
from sdfpbr.api import chart
from sdfpbr.errors import SpecError
from sdfpbr.spec.chart_spec import Light, make_spec

SMALL = dict(width=64, height=64, quality="draft")


def read_frames(path):
    return np.stack(list(iio.imiter(path, plugin="pillow")))


def test_light_orbit_turns_the_key_light_about_the_vertical():
    spec = make_spec(**SMALL)
    specs = orbit_specs(spec, 8, "light")
    assert specs[0] is spec and len(specs) == 8
    x0, y0, z0 = spec.lights[0].direction
    for i, s in enumerate(specs):
        x, y, z = s.lights[0].direction
        assert y == pytest.approx(y0, abs=1e-12)               # elevation kept
        turned = math.atan2(x, z) - math.atan2(x0, z0)          # heading advanced by i/8 of a turn
        assert math.remainder(turned - 2 * math.pi * i / 8, 2 * math.pi) == pytest.approx(0, abs=1e-9)
        assert s.lights[1:] == spec.lights[1:]                  # the fill light stays
    cams = orbit_specs(make_spec(spec, camera_azimuth=10.0), 4, "camera")
    assert [s.camera_azimuth for s in cams] == [10.0, 100.0, 190.0, 280.0]


def test_orbit_checks():
    spec = make_spec(**SMALL)
    with pytest.raises(SpecError, match="directional"):
        orbit_specs(make_spec(spec, lights=(Light("point", position=(0, 5, 5)),)), 4, "light")
    with pytest.raises(SpecError, match="allowed: light, camera"):
        orbit_specs(spec, 4, "sun")
    with pytest.raises(SpecError, match="frames"):
        orbit_specs(spec, 0, "light")


def test_light_orbit_gif_reads_back_and_frame_0_is_the_chart(tmp_path):
    spec = make_spec(**SMALL)
    out = tmp_path / "orbit.gif"
    anim = animate(spec, 4, "light", output=out, fps=10, progress=False, keep_frames=True)
    n, h, w, _ = anim.frames.shape
    assert n == 4
    np.testing.assert_array_equal(anim.frames[0], chart(spec).image)
    back = iio.imread(out, index=None)
    assert back.shape[:3] == (4, h, w)
    # GIF quantises to 256 colours: close to the frames, not equal.
    assert np.abs(back[0].astype(int) - anim.frames[0][..., :3]).mean() < 4
    # The light turns: each sphere's lit side and shadow move, so a good share of the render's
    # pixels (a tenth, of a labelled canvas) change by far more than quantisation.
    render_px = spec.width * spec.height
    for i in range(1, 4):
        changed = np.abs(anim.frames[i].astype(int) - anim.frames[0]).max(-1) > 16
        assert changed.sum() > 0.1 * render_px
    assert iio.immeta(out, index=0).get("loop") == 0
    assert [p.name for p in tmp_path.iterdir()] == ["orbit.gif"]


@pytest.mark.requires_extra("imageio_ffmpeg")
def test_camera_orbit_webp_is_lossless_and_mp4_has_every_frame(tmp_path):
    spec = make_spec(**SMALL)
    anim = animate(spec, 3, "camera", output=tmp_path / "cam.webp", progress=False, keep_frames=True, lossless=True)
    np.testing.assert_array_equal(read_frames(tmp_path / "cam.webp")[..., :3], anim.frames[..., :3])
    for i in range(1, 3):
        np.testing.assert_array_equal(anim.frames[i], chart(make_spec(spec, camera_azimuth=120.0 * i)).image)
    anim.save(tmp_path / "cam.mp4")
    video = iio.imread(tmp_path / "cam.mp4", index=None, plugin="FFMPEG")
    n, h, w = anim.frames.shape[:3]
    assert video.shape == (3, h + h % 2, w + w % 2, 3)       # H.264 needs even sizes: padded, not scaled


def test_compare_animation_shows_the_pair_side_by_side(tmp_path):
    spec = make_spec(**SMALL)
    anim = animate_compare(spec, "double-gamma", 3, "light", output=tmp_path / "pair.webp", progress=False,
                           keep_frames=True)
    assert read_frames(tmp_path / "pair.webp").shape[0] == 3
    assert [s.bugs for s in anim.specs[:2]] == [(), ("double-gamma",)]
    # Frame 0 holds both renders of orbit step 0, unresampled, correct on the left.
    correct, buggy = (chart(make_spec(s, labels=False)).image[..., :3] for s in anim.specs[:2])
    (xc, yc), (xb, yb) = where(anim.frames[0][..., :3], correct), where(anim.frames[0][..., :3], buggy)
    assert yc == yb and xc + correct.shape[1] < xb
    # Later frames in the same places: the stills of their step, but for the turned probe's
    # resampling (test_an_orbits_other_frames_differ_by_resampling_only).
    h, w = correct.shape[:2]
    for x, s in ((xc, anim.specs[4]), (xb, anim.specs[5])):
        still = chart(make_spec(s, labels=False)).image[..., :3].astype(int)
        assert np.abs(anim.frames[2][yc:yc + h, x:x + w, :3].astype(int) - still).max() <= 8


def where(image, patch):
    """(x, y) of an exact copy of ``patch`` inside ``image``."""
    h, w = patch.shape[:2]
    ys, xs = np.nonzero((image[:image.shape[0] - h + 1, :image.shape[1] - w + 1] == patch[0, 0]).all(-1))
    for y, x in zip(ys, xs):
        if np.array_equal(image[y:y + h, x:x + w], patch):
            return x, y
    raise AssertionError("patch not found")


def test_a_failed_write_leaves_the_old_file(tmp_path):
    """Interrupted after two frames are in: the old file stays, no temporary is left."""
    out = tmp_path / "a.gif"
    out.write_bytes(b"keep me")

    def frames():
        yield np.zeros((8, 8, 4), np.uint8) + 255
        yield np.zeros((8, 8, 4), np.uint8) + 255
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_animation(out, frames(), 10)
    assert out.read_bytes() == b"keep me" and [p.name for p in tmp_path.iterdir()] == ["a.gif"]


@pytest.mark.parametrize("suffix", [".gif", ".webp"])
def test_streamed_files_hold_every_frame_with_its_timing(tmp_path, suffix):
    """Frames written one at a time read back in order, with the delay and endless loop asked
    for, transparent WebP frames with their alpha."""
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (5, 12, 20, 4), dtype=np.uint8)
    frames[..., 3] = 255 if suffix == ".gif" else frames[..., 3]
    out = tmp_path / f"s{suffix}"
    write_animation(out, frames, 20, lossless=True)
    back = read_frames(out)
    assert back.shape[:3] == (5, 12, 20)
    if suffix == ".webp":
        np.testing.assert_array_equal(back, frames)          # lossless, alpha and colour under it kept
    else:
        for got, want in zip(back, frames):                   # 256 colours, dithered: close on average
            assert np.abs(got[..., :3].astype(int) - want[..., :3]).mean() < 40
    from PIL import Image
    with Image.open(out) as im:
        durations = []
        for i in range(im.n_frames):
            im.seek(i)
            im.load()   # WebP frames carry their duration once decoded
            durations.append(im.info.get("duration"))
        assert im.info.get("loop") == 0 and durations == [50] * 5


def test_animation_memory_is_flat_in_the_frame_count(tmp_path):
    """Peak Python memory (numpy included) of a 10-frame and a 30-frame orbit within two
    frames' bytes of each other. Both counts pass the session's KEPT_BAKES (8) kept per-frame
    bakes, so neither can hold more of them than the other (a 2-frame orbit against a 10-frame
    one read 1.3 MB apart after some orders of the suite's earlier tests: that comparison is
    not made)."""
    from sdfpbr.gpu.ibl import KEPT_BAKES
    spec = make_spec(**SMALL)
    animate(spec, 10, "light", output=tmp_path / "warm.webp", progress=False)     # compile and bake first
    peaks = []
    assert 10 > KEPT_BAKES
    for n in (10, 30):
        tracemalloc.start()
        try:
            anim = animate(spec, n, "light", output=tmp_path / f"a{n}.webp", progress=False)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert anim.frames is None and anim.count == n
        assert read_frames(tmp_path / f"a{n}.webp").shape[0] == n
    frame_bytes = anim.size[0] * anim.size[1] * 4
    assert peaks[1] < peaks[0] + 2 * frame_bytes, f"peak grew from {peaks[0]} to {peaks[1]} bytes"


def test_mp4_without_ffmpeg_is_refused_before_rendering(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)     # as if the extra were not installed
    from sdfpbr.extras import install_command
    with pytest.raises(SpecError, match=re.escape(install_command("video"))):   # a command for this install
        animate_mod.check_animation_output(tmp_path / "a.mp4")


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("args, needle", [
    (["chart", "--frames", "3", "-o", "{dir}/a.png"], "give -o NAME.gif"),
    (["chart", "--frames", "3", "-o", "{dir}/a.avi"], "must end in .gif or .webp or .mp4"),
    (["chart", "--frames", "0", "-o", "{dir}/a.gif"], "frames must be"),
    (["chart", "--frames", "3", "--orbit", "sun", "-o", "{dir}/a.gif"], "invalid choice"),
    (["chart", "--frames", "3", "--fps", "0", "-o", "{dir}/a.gif"], "fps must be"),
    (["chart", "--frames", "3", "--hdr", "{dir}/a.npy", "-o", "{dir}/a.gif"], "--hdr and --aov"),
    (["chart", "--frames", "3", "--lights", "none", "-o", "{dir}/a.gif"], "directional"),
    (["compare", "--bug", "nope", "--frames", "3", "-o", "{dir}/a.gif"], "allowed: unsquared-roughness"),
    (["compare", "--bug", "double-gamma", "--frames", "3", "-o", "{dir}/a.png"], "must end in .gif"),
])
def test_animation_bad_input_is_one_line_exit_2_no_file(tmp_path, args, needle):
    r = run(*[a.format(dir=tmp_path) for a in args])
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert not list(tmp_path.iterdir())


def test_animation_commands(tmp_path):
    """Both commands report their frames on stderr though it is no terminal (a pipe here): long
    work is never silent in a CI log."""
    r = run("chart", "--frames", "3", "--orbit", "camera", "--size", "48x48", "--quality", "draft",
            "-o", str(tmp_path / "c.webp"), "-v")
    assert r.returncode == 0, r.stderr
    assert "3 frames" in r.stdout and read_frames(tmp_path / "c.webp").shape[0] == 3
    assert "orbit camera: 3/3 frames" in r.stderr
    r = run("compare", "--bug", "clamp-tonemap", "--frames", "2", "--size", "48x48", "--quality", "draft",
            "-o", str(tmp_path / "p.gif"))
    assert r.returncode == 0, r.stderr
    assert iio.imread(tmp_path / "p.gif", index=None).shape[0] == 2
    assert "clamp-tonemap orbit light: 2/2 frames" in r.stderr


def test_frames_after_the_first_leave_no_bakes_in_the_disk_cache(monkeypatch, tmp_path):
    """A light orbit re-bakes the cells stage's probe every frame; only frame 0's bakes (those a
    still chart of the same spec reads) reach the disk cache. The process's session reads and
    writes a cache of this test's own here: the xdist workers share the run's, and another
    test's entries would land in it meanwhile."""
    from sdfpbr.cache import ArrayCache
    from sdfpbr.gpu.session import default_session
    monkeypatch.setattr(default_session(), "cache", ArrayCache(tmp_path / "cache"))
    spec = make_spec(**SMALL, lights=(Light("directional", direction=(0.3, 0.7, 0.2)),))
    chart(spec)                                                   # frame 0's bakes, as a still chart
    root = default_session().cache.root
    before = sorted(p.name for p in root.rglob("*.npz"))
    assert before                                                 # the still chart's bakes are there
    anim = animate(spec, 4, "light", progress=False)
    assert anim.count == 4
    assert sorted(p.name for p in root.rglob("*.npz")) == before


def test_turned_sh_is_the_irradiance_of_the_turned_light():
    """Independent of the shader: ibl.glsl's SH9 polynomial evaluated at R^T n equals the turned
    coefficients' polynomial at n, for random coefficients and turns about every axis."""
    from sdfpbr.gpu.ibl import turned_sh

    def irradiance(u, n):
        x, y, z = n
        return (u[0] + u[1] * y + u[2] * z + u[3] * x + u[4] * x * y + u[5] * y * z
                + u[6] * (3 * z * z - 1) + u[7] * x * z + u[8] * (x * x - y * y))
    rng = np.random.default_rng(4)
    for _ in range(5):
        u = rng.normal(size=(9, 3))
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        R = q * np.sign(np.linalg.det(q))                      # a rotation
        n = rng.normal(size=(3, 50))
        n /= np.linalg.norm(n, axis=0)
        turned = turned_sh(u, R)
        for channel in range(3):
            np.testing.assert_allclose(irradiance(turned[:, channel], n), irradiance(u[:, channel], R.T @ n),
                                       atol=1e-12)


def test_the_turn_is_the_orbits_own():
    from sdfpbr.gpu.ibl import turn_about_vertical
    spec = make_spec(**SMALL, lights=(Light("directional", direction=(0.3, 0.7, 0.2)),))
    d0 = np.array(spec.lights[0].direction)
    for frame in orbit_specs(spec, 5, "light")[1:]:
        d1 = np.array(frame.lights[0].direction)
        np.testing.assert_allclose(turn_about_vertical(d0, d1) @ d0, d1, atol=1e-12)
    assert turn_about_vertical(d0, (0.3, 0.6, 0.2)) is None                  # another height
    assert turn_about_vertical((0.0, 1.0, 0.0), (0.0, 1.0, 0.0)) is None     # straight overhead


@pytest.fixture(scope="module")
def orbit_pair(session):
    """Eight frames of a light orbit on the cells stage, each baked on its own and composed
    from the first frame's bakes (Session.turning_light)."""
    spec = make_spec(width=160, height=160, rows=2, cols=2, metallic=(0, 1), roughness=(0, 0.5), labels=False)
    specs = orbit_specs(spec, 8, "light")
    direct = [session.render(s, aovs=False) for s in specs]
    with session.turning_light(0):
        turned = [session.render(s, aovs=False) for s in specs]
    return direct, turned


def test_an_orbits_quarter_turns_are_its_bakes(orbit_pair):
    """At a quarter turn every texel centre of the probe turns onto a texel centre, so the
    composed probe is the probe baked for that frame up to how the prefilter's samples lie in
    each texel's frame (the same estimator, another pattern): the mirror sphere, which shows the
    probe itself, within 1e-4 of the brightest pixel. Frame 0 is the bake itself."""
    direct, turned = orbit_pair
    np.testing.assert_array_equal(turned[0].hdr, direct[0].hdr)
    for i in (2, 4, 6):
        peak = direct[i].hdr.max()
        assert np.abs(turned[i].hdr - direct[i].hdr).max() < 1e-4 * peak, i
        assert not np.array_equal(direct[i].hdr, direct[0].hdr)    # the light did move


def test_an_orbits_other_frames_differ_by_resampling_only(orbit_pair):
    """Between quarter turns a level is read between its texels (bilinear, at its own size):
    the probe is blurred by at most half a texel, which the chart's 8-bit image shows as a few
    levels at most on the mirror sphere's reflection of its shadow edge."""
    from sdfpbr.image import metrics
    direct, turned = orbit_pair
    for i in (1, 3, 5, 7):
        assert np.abs(turned[i].image.astype(int) - direct[i].image.astype(int)).max() <= 8, i
        assert metrics.flip_ldr(turned[i].image, direct[i].image)[0] < 0.005, i


def test_an_animation_keeps_no_prepasses(monkeypatch, tmp_path):
    """Prepasses save a still chart's start; an animation (its compile spread over its frames)
    writes none, not even its first frame's (its bakes: the test above)."""
    from sdfpbr.cache import ArrayCache
    from sdfpbr.gpu.prepasses import PREPASS_KIND
    from sdfpbr.gpu.session import default_session
    session = default_session()
    monkeypatch.setattr(session, "cache", ArrayCache(tmp_path))   # where prepasses would go
    spec = make_spec(**SMALL, lights=(Light("directional", direction=(0.2, 0.7, 0.3)),))
    assert animate(spec, 3, "light", progress=False).count == 3
    assert not list(tmp_path.rglob(f"{PREPASS_KIND}/*.npz"))
    chart(spec)                                                   # the same first frame, as a still
    assert list((tmp_path / PREPASS_KIND).glob("*.npz"))
