"""Helpers the test modules share (they import from here, never from each other).

Plain functions and constants; the GL fixtures live in conftest.py. pygltflib (the 'test'
extra) is imported inside the glTF helpers, so a module that does not write glTF runs without it."""
import io
import os
import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np

from sdfpbr.oracle import lobes, shading_model
from sdfpbr.shading.camera import frame_grid, ground_height, sphere_centers
from sdfpbr.shading.plan import chart_frame

# tests/data holds the script that writes the shipped glTF asset (textured_glb builds on it).
sys.path.insert(0, str(Path(__file__).parent / "data"))

# ---- program rounding ----------------------------------------------------------------------

# The correct and the buggy chart are two different programs. In the cells a bug leaves alone
# they evaluate the same formulas, but a driver may compile the two differently (fma
# contraction, reassociation, another common subexpression), and each rounding that moves is
# worth at most 2^-24 of its value: llvmpipe happens to agree bit for bit, an NVIDIA H100
# differed by 1.2e-7. Allowed: 256 such roundings of the pixel's radiance (2^-16 = 1.5e-5
# relative; a shading path is well under 256 float32 operations deep), three orders of
# magnitude below the smallest real change asserted (0.01).
PROGRAM_RTOL = 256 * 2.0 ** -24


def rounding_bound(f, args):
    """Per case and channel, the float32 evaluation's error bound for f(*args) (each arg (N,) or
    (N, k) float64; f returns (N, 3)): the forward bound of a computation test_bugs.PROGRAM_RTOL
    deep (256 roundings) -- that many ulps of the result, plus that many of every input passed
    through the condition sum_j |df/dx_j| |x_j| (forward differences in float64, a relative
    step of 1e-6). It takes each step as backward stable; one that is not, such as exp of an
    argument near 20 (the sheen's visibility), turns one rounding into ~20 ulps, inside the 256.
    Sharp highlights get the wide bound their slope asks for; smooth shading a tight one."""
    want = f(*args)
    condition = np.zeros_like(want)
    for i, arg in enumerate(args):
        arg = np.asarray(arg, np.float64)
        columns = arg.reshape(len(arg), -1)
        for c in range(columns.shape[1]):
            x = columns[:, c]
            step = 1e-6 * np.maximum(np.abs(x), 1e-3)
            shifted = columns.copy()
            shifted[:, c] = x + step
            moved = f(*(shifted.reshape(arg.shape) if k == i else a for k, a in enumerate(args)))
            condition += np.abs(moved - want) / step[:, None] * np.abs(x)[:, None]
    return PROGRAM_RTOL * (condition + np.abs(want))


# ---- the DFG table and the split-sum furnace -------------------------------------------------

def dfg_read(table, n_dot_v, perceptual_roughness, rounding=(None, None), channels=3):
    """(A, B, C) -- or the first ``channels`` of (A, B, C, E_s) -- read bilinearly from a
    (size, size, 4) table at dfg.glsl's mapping (0 and 1 on the first and last texel centres);
    ``rounding``: per axis, None or how the filter's fraction is held in 8 bits (np.floor,
    np.ceil)."""
    size = table.shape[0]
    x, y = n_dot_v * (size - 1), perceptual_roughness * (size - 1)
    i = np.minimum(np.floor(x).astype(int), size - 2)
    j = np.minimum(np.floor(y).astype(int), size - 2)
    fx, fy = ((f if q is None else q(f * 256) / 256)[:, None] for f, q in zip((x - i, y - j), rounding))
    near, far = (1 - fx) * table[j, i] + fx * table[j, i + 1], (1 - fx) * table[j + 1, i] + fx * table[j + 1, i + 1]
    return ((1 - fy) * near + fy * far)[:, :channels].T


# How a GPU may hold a bilinear filter's fractions: exact, or in 8 bits, rounded down or up per axis.
FILTER_ROUNDINGS = [(None, None)] + [(qx, qy) for qx in (np.floor, np.ceil) for qy in (np.floor, np.ceil)]


def dfg_read_error(table, n_dot_v, perceptual_roughness, exact, channel):
    """|a channel of a DFG table read as dfg.glsl reads it - its float64 value ``exact``|, the
    worst over FILTER_ROUNDINGS; channel 0-3 (A, B, C, E_s) or "E" for A + B."""
    reads = [dfg_read(table, n_dot_v, perceptual_roughness, q, channels=4) for q in FILTER_ROUNDINGS]
    return np.max([np.abs((t[0] + t[1] if channel == "E" else t[channel]) - exact) for t in reads], 0)


def chart_dfg_table(session, spec):
    """The DFG table a chart of ``spec`` reads, as the GPU baked it: (size, size, 4) float64."""
    from sdfpbr.shading.plan import render_plan
    with session.ctx:
        texture = session.ibl.dfg(render_plan(spec))
        size = texture.size[0]
        return np.frombuffer(texture.read(), np.float32).reshape(size, size, 4).astype(np.float64)


class FurnaceBudget:
    """A furnace pixel is the split-sum model (REFERENCE.md §2-3) read through the chart's DFG
    table. Through that table (its texels as the GPU baked them, read here in float64) the pixel
    is exact but for the filter's fractions -- GPUs may hold them in 8 bits: the bound takes the
    worse of rounding them down and up -- and float32 (1e-5). Against the float64 model it is
    off by the table's interpolation (the same read of a float64 table) and by its texels' own
    error, as the material passes it on: the pixel's change with each of A, B and C moved by
    that error (to first order; a white metal's (A + B) comp is 1 whatever the table, a
    dielectric's C + (0.04 A + B) comp moves by about |dC| + |dB| + 0.04 |dA|). White by default."""

    def __init__(self, session, spec, res, mask, base_color=(1.0, 1.0, 1.0)):
        from sdfpbr.spec.material import MIN_PERCEPTUAL_ROUGHNESS
        table = chart_dfg_table(session, spec)
        size = table.shape[0]
        self.got = res.hdr[mask].astype(float)
        mu = res.aov["ndotv"][mask].astype(float)
        r = np.maximum(res.aov["roughness"][mask].astype(float), MIN_PERCEPTUAL_ROUGHNESS)
        metallic = res.aov["metallic"][mask].astype(float)

        base = np.asarray(base_color, float)

        def expected(t, rounding=(None, None)):
            return shading_model.furnace_from_dfg(*dfg_read(t, mu, r, rounding), base, metallic, spec.multiscatter)

        terms = dfg_read(table, mu, r)
        self.through_table = shading_model.furnace_from_dfg(*terms, base, metallic, spec.multiscatter)
        rounded = [expected(table, q) for q in FILTER_ROUNDINGS[1:]]
        self.filter = np.max([np.abs(e - self.through_table) for e in rounded], 0) + 1e-5 * (1 + self.through_table)
        # The float64 table on the rows these roughnesses read.
        rows = np.unique(np.minimum(np.floor(r * (size - 1)).astype(int), size - 2)[:, None] + [0, 1])
        grid = np.arange(size) / (size - 1)
        exact = table.copy()
        exact[rows, :, :3] = np.stack(shading_model.dfg_integrate(np.maximum(grid[None, :], shading_model.MIN_N_DOT_V),
                                                           grid[rows][:, None]), -1)
        self.texel_error = np.abs(table[rows, :, :3] - exact[rows, :, :3]).max()
        self.model = shading_model.furnace_expected(mu, base, metallic, r, multiscatter=spec.multiscatter)
        self.interpolation = np.abs(expected(exact) - self.model)
        moved = [shading_model.furnace_from_dfg(*(t + self.texel_error * (k == i) for k, t in enumerate(terms)), base,
                                         metallic, spec.multiscatter) for i in range(3)]
        self.spread = np.sum([np.abs(m - self.through_table) for m in moved], 0)

    def check(self):
        assert (np.abs(self.got - self.through_table) <= self.filter).all(), np.abs(self.got - self.through_table).max()
        spread = self.spread
        assert (np.abs(self.got - self.model) <= self.interpolation + spread + self.filter).all()


# ---- the path-traced reference ---------------------------------------------------------------

# The reference tests' furnace: a lone white sphere under the uniform environment, traced on the
# shared stage's grid camera, which primary_hits re-traces in float64.
REFERENCE_FURNACE = {"env": "uniform", "lights": "none", "ground": False, "rows": 1, "cols": 1,
                     "base_color": (1.0, 1.0, 1.0), "width": 40, "height": 40, "stage": "shared"}
SUB = 6   # subsamples per pixel edge for the expected values
# What a pixel carries besides noise where it reads no table: float32 sums (~1e-5), held to 1e-4.
BIAS = 1e-4


def luminance(rgb):
    return np.asarray(rgb, float) @ np.array([0.2126, 0.7152, 0.0722])


def mean_and_se(lum, lum_se, mask):
    """The mean of a reference's pixel values over ``mask`` and its standard error (the pixels'
    estimates are independent: their variances add)."""
    return lum[mask].mean(), np.sqrt((np.asarray(lum_se, np.float64)[mask] ** 2).sum()) / mask.sum()


def primary_hits(spec, sub=SUB):
    """Per pixel and subsample, the sphere hit by the camera ray: (hit, row, col, normal, view),
    arrays of shape (H, W, sub*sub[, 3]), traced in float64 as camera.glsl and a ray-sphere test."""
    cam = frame_grid(spec)
    h, w = spec.height, spec.width
    offsets = (np.arange(sub) + 0.5) / sub
    ox, oy = np.meshgrid(offsets, offsets)
    px = np.arange(w)[None, :, None] + ox.ravel()[None, None, :]
    py = (h - 1 - np.arange(h))[:, None, None] + oy.ravel()[None, None, :]   # GL rows from the bottom
    ndc_x, ndc_y = 2 * px / w - 1, 2 * py / h - 1
    sx, sy = ndc_x * (w / h) * cam.half_height, ndc_y * cam.half_height
    rd = cam.forward + sx[..., None] * cam.right + sy[..., None] * cam.up
    rd = rd / np.linalg.norm(rd, axis=-1, keepdims=True)
    ro = np.broadcast_to(cam.position, rd.shape)
    t_best = np.full(rd.shape[:-1], np.inf)
    row = np.full(rd.shape[:-1], -1)
    col = np.full(rd.shape[:-1], -1)
    centers = sphere_centers(spec)
    for j in range(spec.rows):
        for i in range(spec.cols):
            oc = ro - centers[j, i]
            b = (oc * rd).sum(-1)
            disc = b * b - ((oc * oc).sum(-1) - spec.sphere_radius ** 2)
            t = -b - np.sqrt(np.maximum(disc, 0))
            better = (disc > 0) & (t > 0) & (t < t_best)
            t_best = np.where(better, t, t_best)
            row, col = np.where(better, j, row), np.where(better, i, col)
    hit = np.isfinite(t_best)
    p = ro + rd * np.where(hit, t_best, 0)[..., None]
    normal = (p - centers[np.maximum(row, 0), np.maximum(col, 0)]) / spec.sphere_radius
    return hit, row, col, normal, -rd


def interior(spec, hits, min_ndotv):
    """Pixels whose every subsample hits the same sphere at NdotV >= min_ndotv."""
    hit, row, col, normal, view = hits
    ndotv = (normal * view).sum(-1)
    same = hit.all(-1) & (row == row[..., :1]).all(-1) & (col == col[..., :1]).all(-1)
    return same & (ndotv.min(-1) >= min_ndotv)


def table_bias(session, spec, hits, want, model="gltf", sheen=False):
    """Per pixel, the relative bias the reference's tables give a pixel of value ``want``
    (sdfpbr/features/reference/tables.py: the float64 quadrature in a 128^2 float32 table,
    read bilinearly, GPUs holding the filter's fractions in 8 bits): the energy compensation
    scales a pixel by at most E / E_read (f0 = 1, less below), at the worst of the pixel's
    subsamples; the sheen's albedo scaling min(1 - c E_s(N.V), 1 - c E_s(N.L)) moves a pixel of
    radiance up to 1 by c times the read error at N.V plus the worst at any N.L; plus BIAS for
    float32. Only pixels whose every subsample is on a sphere (interior's are) get a bound, the
    rest NaN: the float64 integrals are most of these tests' time."""
    from sdfpbr.features.reference.tables import compensation_table
    from sdfpbr.spec.material import MIN_PERCEPTUAL_ROUGHNESS
    table = compensation_table(model, session.cache, sheen).astype(np.float64)
    hit, row, col, normal, view = hits
    on_sphere = hit.all(-1)
    subsamples = hit.shape[-1]
    mu = np.clip((normal * view).sum(-1), shading_model.MIN_N_DOT_V, 1.0)[on_sphere].ravel()
    cells = np.stack([row, col], -1)[on_sphere].reshape(-1, 2)

    def per_subsample(name):
        return spec.material_array(name)[cells[:, 0], cells[:, 1]]
    roughness = np.maximum(per_subsample("roughness"), MIN_PERCEPTUAL_ROUGHNESS)
    a, b, _ = shading_model.dfg_integrate(mu, roughness, model=model, n=32)
    bound = np.full(on_sphere.shape, np.nan)
    bound[on_sphere] = (dfg_read_error(table, mu, roughness, a + b, "E") / (a + b)).reshape(-1, subsamples).max(-1)
    if not sheen:
        return bound + BIAS
    sheen_r = np.maximum(per_subsample("sheen_roughness"), MIN_PERCEPTUAL_ROUGHNESS)
    shade = per_subsample("sheen_color").max(-1)
    at_view = dfg_read_error(table, mu, sheen_r, lobes.sheen_albedo(mu, sheen_r), 3)
    at_light = 0.0
    n_dot_l = np.maximum(np.linspace(0.0, 1.0, 1025) ** 2, shading_model.MIN_N_DOT_V)
    for r_s in np.unique(sheen_r):
        rs = np.full(n_dot_l.shape, r_s)
        at_light = max(at_light, float(dfg_read_error(table, n_dot_l, rs, lobes.sheen_albedo(n_dot_l, rs), 3).max()))
    bound[on_sphere] += (shade * (at_view + at_light)).reshape(-1, subsamples).max(-1) / np.abs(want[on_sphere])
    return bound + BIAS


def check_converged(got, want, stderr, k=5.0, bias=BIAS):
    """Per pixel within k standard errors plus the bias bound, and the mean over all pixels
    (a far tighter test of bias) within 4 standard errors of that mean plus the bound."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    se = np.asarray(stderr, float)
    assert np.isfinite(se).all() and (se > 0).all()
    bound = bias * np.abs(want)                   # bias: relative, one for all pixels or one each
    excess = np.abs(got - want) - (k * se + bound)
    assert excess.max() <= 0, f"{(excess > 0).sum()} of {excess.size} pixels off, worst by {excess.max():.3g}"
    mean_diff = abs((got - want).mean())
    assert mean_diff <= 4 * np.sqrt((se ** 2).sum()) / se.size + bound.mean(), mean_diff



# ---- the floor under a sphere ----------------------------------------------------------------

def floor_points(spec, centres: np.ndarray):
    """Each pixel's camera ray on the floor plane: the point, a pixel's world size there, and
    whether the pixel shows open floor (rays passing within two pixels of a sphere at one of
    ``centres`` would hide or edge it, and are left out)."""
    cam = chart_frame(spec).camera
    d = cam.pixel_rays()[1]
    t = (ground_height(spec) - cam.position[1]) / d[..., 1]
    p = cam.position + d * t[..., None]
    pixel = 2 * cam.half_height * t / spec.height
    floor = d[..., 1] < 0
    for c in centres:
        along = ((c - cam.position) @ d.reshape(-1, 3).T).reshape(t.shape)
        floor &= np.linalg.norm(cam.position + d * along[..., None] - c, axis=-1) > spec.sphere_radius + 2 * pixel
    return p, pixel, floor


# The cells floor's shadow is averaged over these points of the pixel (shadow.glsl).
FOOTPRINT_POINTS = ((0.125, 0.375), (0.375, -0.125), (-0.125, -0.375), (-0.375, 0.125))


def footprint_offsets(spec, p: np.ndarray, pixel: np.ndarray) -> list[np.ndarray]:
    """The offsets from each floor point ``p`` (floor_points) of the four points the cells
    stage averages its floor's shadow over: a rotated grid on a pixel-wide square across the
    ray, one side level, slid along the ray onto the floor."""
    v = chart_frame(spec).camera.position - p
    v /= np.linalg.norm(v, axis=-1)[..., None]
    across = np.stack([v[..., 2], np.zeros_like(v[..., 0]), -v[..., 0]], axis=-1)
    h = across / np.linalg.norm(across, axis=-1)[..., None]
    w = np.cross(v, h)
    ex = pixel[..., None] * h
    ey = pixel[..., None] * (w - v * (w[..., 1] / np.maximum(v[..., 1], 0.05))[..., None])
    ey[..., 1] = 0.0   # on the floor, capped or not
    return [x * ex + y * ey for x, y in FOOTPRINT_POINTS]


# ---- glTF assets ---------------------------------------------------------------------------

def png_bytes(img: np.ndarray) -> bytes:
    buf = io.BytesIO()
    iio.imwrite(buf, img, extension=".png")
    return buf.getvalue()


def textured_glb(path, images, materials, samplers=()):
    """A .glb whose images (PNG bytes) lie in its binary buffer, one texture each (texture i
    reads image i with sampler i if given)."""
    import pygltflib
    from make_materials_glb import gltf_asset
    blob, views = b"", []
    for data in images:
        views.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data)))
        blob += data + b"\0" * (-len(data) % 4)
    doc = gltf_asset(materials)
    doc.buffers = [pygltflib.Buffer(byteLength=len(blob))]
    doc.bufferViews = views
    doc.images = [pygltflib.Image(bufferView=i, mimeType="image/png") for i in range(len(images))]
    doc.samplers = list(samplers)
    doc.textures = [pygltflib.Texture(source=i, sampler=i if i < len(samplers) else None) for i in range(len(images))]
    doc.set_binary_blob(blob)
    doc.save_binary(str(path))
    return str(path)


def textured(info_extensions=None, **pbr_extra):
    """A white, rough-0.5 dielectric whose base colour reads texture 0."""
    import pygltflib
    return pygltflib.Material(name="textured", pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
        baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.5,
        baseColorTexture=pygltflib.TextureInfo(index=0, extensions=info_extensions or {}), **pbr_extra))


# ---- processes -----------------------------------------------------------------------------

def blocked(tmp_path, module: str) -> dict:
    """An environment in which ``module`` fails to import, as if its extra were not installed."""
    blocker = tmp_path / "blocker"
    blocker.mkdir(exist_ok=True)
    (blocker / f"{module}.py").write_text("raise ImportError('blocked for this test')\n")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(blocker), os.environ.get("PYTHONPATH", "")])}


def dead_pid() -> int:
    """The pid of a process that has exited."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid
