"""The sweep's checks: plain functions of arrays (a render's HDR, display image and AOVs)
against properties derived without the renderer; each is tested on its own."""
from __future__ import annotations

import math

import numpy as np

from ...oracle import display, shading_model
from ...oracle.furnace import FurnaceTable
from ...image.colour import BACKGROUND
from ...shading.plan import chart_frame, render_plan
from ...spec.chart_spec import ChartSpec

FIREFLY_RATIO = 4.0
# Angular scale (radians) of the sharpest features of each preset environment: the studio's
# softbox edges (smoothstep half-width 0.05) and the sky's horizon haze; a file can be anything.
ENV_FEATURE_RAD = {"studio": 0.05, "sky": 0.06}
FIREFLY_MAX_PIXELS = 4_000_000
DISPLAY_LSB = 1
FURNACE_MIN_NDOTV = 0.1   # below this the LUT's NdotV resolution, not the shading, dominates
FURNACE_RTOL = {"draft": 2.5e-2, "default": 1e-2, "high": 1e-2}
FURNACE_FLOOR = 2e-2        # of the environment: below it errors are judged absolutely
MONOTONIC_RTOL_EQUAL = 1e-2     # columns whose clamped roughness is equal
MIRROR_RTOL = {"draft": 4e-2, "default": 1.5e-2, "high": 1.5e-2}
HALF_EPS = 2.0 ** -10     # relative rounding of a half float (with a factor-2 margin)
HALF_SUBNORMAL = 2.0 ** -24   # absolute step of half subnormals (values below 2^-14)


def check_finite(hdr: np.ndarray, alpha: np.ndarray) -> list[str]:
    out = []
    bad = ~np.isfinite(hdr)
    if bad.any():
        out.append(f"{int(np.isnan(hdr).any(-1).sum())} NaN and {int(np.isinf(hdr).any(-1).sum())} Inf HDR pixels")
    neg = np.nan_to_num(hdr, nan=0.0) < 0
    if neg.any():
        out.append(f"{int(neg.any(-1).sum())} pixels with negative radiance (min {float(np.nanmin(hdr)):.3g})")
    if not (np.isfinite(alpha).all() and alpha.min() >= 0 and alpha.max() <= 1):
        out.append("coverage outside [0, 1]")
    return out


def expected_display(hdr: np.ndarray, alpha: np.ndarray, spec: ChartSpec) -> np.ndarray:
    """(H, W, 4) uint8 from the float64 model: un-premultiply (transparent), exposure, tone
    map, sRGB OETF; alpha 255 or the coverage."""
    x = hdr.astype(np.float64)
    a = alpha.astype(np.float64)
    if spec.transparent:
        x = np.where(a[..., None] > 0, x / np.where(a > 0, a, 1.0)[..., None], 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        y = display.srgb_oetf(display.tonemap(x * 2.0 ** spec.exposure, spec.tonemap, white=spec.reinhard_white))
    out = np.empty(hdr.shape[:2] + (4,), np.uint8)
    out[..., :3] = np.rint(np.nan_to_num(y) * 255.0)
    out[..., 3] = np.rint(np.clip(a, 0, 1) * 255.0) if spec.transparent else 255
    return out


def display_error(hdr, alpha, image, spec: ChartSpec, chunk_rows: int | None = None) -> tuple[int, int]:
    """(largest |GPU - mirror| in LSB, pixels over DISPLAY_LSB) where the HDR is finite; the
    cells' page-colour borders are the page colour."""
    H, W = hdr.shape[:2]
    chunk_rows = chunk_rows or max(1, 1_000_000 // max(W, 1))
    worst, bad = 0, 0
    frame = chart_frame(spec)
    for r0 in range(0, H, chunk_rows):
        sl = slice(r0, r0 + chunk_rows)
        want = expected_display(hdr[sl], alpha[sl], spec).astype(np.int16)
        want[frame.border_mask(slice(r0, r0 + len(want)))] = BACKGROUND   # the cells' borders
        diff = np.abs(want - image[sl].astype(np.int16)).max(-1)
        finite = np.isfinite(hdr[sl]).all(-1) & np.isfinite(alpha[sl])
        diff = np.where(finite, diff, 0)
        worst = max(worst, int(diff.max()) if diff.size else 0)
        bad += int((diff > DISPLAY_LSB).sum())
    return worst, bad


MIXED = -3   # surface id of a pixel whose radiance blends a sphere with what is beside it


def surface_ids(aov: dict, cols: int) -> np.ndarray:
    """Per pixel: the sphere index, -2 for the ground, -1 for the background, MIXED where an
    anti-aliased edge blends a sphere with its surroundings."""
    sphere = aov["row"] * cols + aov["col"]
    ground = (aov["row"] < 0) & np.isfinite(aov["depth"]) & (aov["ndotv"] >= -0.5)
    ids = np.where(aov["row"] >= 0, sphere, np.where(ground, -2, -1))
    if "coverage" in aov:
        ids = np.where((aov["coverage"] > 0) & (aov["coverage"] < 1), MIXED, ids)
    return ids


def _neighbours(a: np.ndarray):
    """The 8 neighbours of every interior pixel (arrays shaped like a[1:-1, 1:-1])."""
    H, W = a.shape[:2]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy or dx:
                yield a[1 + dy:H - 1 + dy, 1 + dx:W - 1 + dx]


def interior_mask(ids: np.ndarray) -> np.ndarray:
    """Pixels whose 3x3 neighbourhood is one surface (not the background); border pixels False."""
    out = np.zeros(ids.shape, bool)
    if ids.shape[0] < 3 or ids.shape[1] < 3:
        return out
    c = ids[1:-1, 1:-1]
    same = (c != -1) & (c != MIXED)
    for nb in _neighbours(ids):
        same &= nb == c
    out[1:-1, 1:-1] = same
    return out


def smooth_region(aov: dict, spec: ChartSpec, camera) -> np.ndarray:
    """Pixels where the continuous image must be smooth at the pixel scale (see
    isolated_outliers): all 9 pixels one surface, away from every highlight centre, from
    point lights closer than a few pixels and (with several samples a pixel) from spheres too
    small for the centre samples to see; where the environment has sharp features (the lit
    floor a sphere mirrors is one), only where the reflection moves across them slowly;
    ground excluded when it receives shadows."""
    ids = surface_ids(aov, spec.cols)
    H, W = ids.shape
    test = interior_mask(ids)
    if spec.shadows and spec.ground:
        test &= ids != -2
    if spec.spp > 1:
        test &= ~_near_small_spheres(spec, camera, H, W)
    if not test.any():
        return test
    n = aov["normal"].astype(np.float64)
    c = (slice(1, -1), slice(1, -1))
    dn = np.full((H, W), np.pi)   # largest angle between a pixel's normal and its neighbours'
    dn[c] = 0.0
    for nb in _neighbours(n):
        dn[c] = np.maximum(dn[c], np.arccos(np.clip((nb * n[c]).sum(-1), -1.0, 1.0)))
    dv = 0.0 if camera.orthographic else 2 * camera.half_height / H   # view direction, per pixel
    alpha_px = np.maximum(np.where(ids >= 0, np.nan_to_num(aov["roughness"]), spec.ground_roughness),
                          shading_model.MIN_PERCEPTUAL_ROUGHNESS) ** 2
    if spec.ibl and spec.env != "uniform" and spec.env != "black":
        # The reflected direction moves by up to 2 dn + dv a pixel; the prefiltered environment
        # varies on its own feature scale widened by the lobe. Sampled at least twice across
        # that scale a feature spreads over neighbours (which then hold >= ~half its peak);
        # crossed faster, it is a legitimately sharp, even one-pixel, reflection.
        test &= 2 * (2 * dn + dv) <= ENV_FEATURE_RAD.get(spec.env, 0.0) + 2 * alpha_px
    ro, rd = camera.pixel_rays()   # the shared stage's camera: the whole image
    if spec.ibl and spec.ground and spec.lights:
        test &= ~_reflects_lit_floor_unresolved(n, -rd, ids, dn, dv, alpha_px)
    depth = np.where(test, aov["depth"], 0.0)[..., None]
    p = ro + rd * depth
    v = -rd
    rough = np.where(ids >= 0, np.nan_to_num(aov["roughness"]), spec.ground_roughness)
    alpha_mat = np.maximum(rough, shading_model.MIN_PERCEPTUAL_ROUGHNESS) ** 2
    pixel_size = 2 * camera.half_height / H * (1.0 if camera.orthographic else depth[..., 0])
    for light in spec.lights:
        a, disc = alpha_mat, 0.0
        if light.kind == "directional":
            l = np.broadcast_to(np.asarray(light.direction), p.shape)
            # A disc light's highlight is the disc (half vectors within theta/2 of its centre's)
            # with edges as sharp as the material's own lobe (shading_model.d_ggx_disc).
            disc = 0.5 * math.radians(light.angular_radius_deg)
        else:
            to_light = np.asarray(light.position) - p
            dist = np.linalg.norm(to_light, axis=-1)
            l = to_light / np.maximum(dist, 1e-300)[..., None]
            test &= dist > 8 * pixel_size
            disc = 0.5 * np.arcsin(np.minimum(light.radius / np.maximum(dist, 1e-300), 1.0))   # a sphere light's
        h = shading_model.normalize(v + l)
        delta = np.maximum(np.arccos(np.clip((n * h).sum(-1), -1.0, 1.0)) - disc, 0.0)
        # h moves by dn_h = dn + dv/2 a pixel. D changes by at most exp(2 dn_h / alpha) per step
        # (its log slope peaks at 2/alpha), <= 2.4 when dn_h <= 0.44 alpha: a resolved lobe.
        # An unresolved one is skipped near its centre; beyond 4 dn_h its tail changes by
        # (1 + dn_h/delta)^4 <= 2.4 per step.
        dn_h = dn + dv / 2
        test &= (dn_h <= 0.44 * a) | (delta >= np.maximum(4 * dn_h, 3 * a))
    return test


def _reflects_lit_floor_unresolved(n, v, ids, dn, dv, alpha_px) -> np.ndarray:
    """Sphere pixels whose reflection can reach the lit floor, with a lobe too narrow to blur
    it at the pixel scale. With IBL and a ground the spheres' IBL is the stage probe: the
    environment above the horizon, the floor below it as the chart shades it. Under lights
    that floor has features of no width -- its shadows' edges (why ground pixels are not
    tested with shadows on), the spheres' mirror images of the lights ending at their
    tangent planes (sphere_mirror.glsl), its own glints of the lights (as narrow as its lobe,
    narrower for a near point light), and the horizon they end at -- so a sliver of them (the
    sunlit far floor between the shadows and the horizon) is a legitimate one-pixel
    reflection wherever a sphere's reflected direction crosses it in under two samples: the
    environment rule above with a feature scale of 0, 2 (2 dn + dv) > 2 alpha. The
    neighbourhood's reflected directions lie within 2 dn + dv of the pixel's, and the lobe
    reaches a few alpha beyond: the floor is in reach where r.y < sin(2 dn + dv + 3 alpha)."""
    r = 2 * (np.nan_to_num(n) * v).sum(-1)[..., None] * np.nan_to_num(n) - v
    move = 2 * dn + dv
    reach = np.sin(np.minimum(move + 3 * alpha_px, 0.5 * np.pi))
    return (ids >= 0) & (r[..., 1] < reach) & (move > alpha_px)


def _near_small_spheres(spec: ChartSpec, camera, H: int, W: int) -> np.ndarray:
    """Pixels within 2 pixels of a sphere whose image is under 2 pixels across: a pixel's
    other samples can hit it while its centre sample (the AOVs) sees the ground or sky."""
    centers = chart_frame(spec).sphere_centers.reshape(-1, 3)
    near = np.zeros((H, W), bool)
    px, scale = camera.project(centers)
    radius = spec.sphere_radius * np.abs(scale)
    depth = (centers - camera.position) @ camera.forward
    small = (radius < 2.0) & (depth > 0) & (px[:, 0] > -4) & (px[:, 0] < W + 4) & (px[:, 1] > -4) & (px[:, 1] < H + 4)
    for (x, y), r in zip(px[small], radius[small]):
        reach = r + 2.0
        x0, x1 = int(max(0, math.floor(x - reach))), int(min(W, math.ceil(x + reach)))
        y0, y1 = int(max(0, math.floor(y - reach))), int(min(H, math.ceil(y + reach)))
        near[y0:y1, x0:x1] = True
    return near


def isolated_outliers(hdr, aov, spec: ChartSpec, camera, ratio: float = FIREFLY_RATIO) -> tuple[float, int, int]:
    """Fireflies: pixels brighter than ``ratio`` x the brightest of their 8 neighbours, looked
    for only where the continuous image must be smooth at the pixel scale. Returns (worst
    ratio among tested pixels, pixels flagged, pixels tested).

    Why that region is safe to test: a one-pixel spike is legitimate when a feature is
    narrower than a pixel, and in this scene that happens only at (1) silhouettes and surface
    changes -- all 9 pixels must be one surface, never the background with its light discs;
    (2) highlights of lobes the pixels do not resolve -- where the half vector moves by
    dn_h > 0.44 alpha a pixel, pixels within max(4 dn_h, 3 alpha) of the highlight centre
    normalize(v + l) are skipped (dn_h: normal change to a neighbour plus half the view
    change; alpha includes the light's disc); (3) reflections of sharp environment features
    crossed in under two samples, the lit floor's among them (with IBL and a ground the
    spheres mirror the stage: under lights its shadows' edges and the horizon are features
    of no width, so a sphere's reflection of the floor is tested only where its lobe
    resolves it); (4) a point light closer than 8 pixel footprints; (5) with
    several samples a pixel, spheres under 2 pixels across that the centre samples (the AOVs)
    miss. Everywhere else GGX changes by at most ~2.4x between neighbours and the other
    factors (visibility, Fresnel, cosine, split-sum IBL, analytic AO) far less, so 4x is a
    wrong pixel, if it also stands out by 0.1 % of the image's 99th percentile. Ground
    pixels are skipped when shadows are on (a sub-pixel gap between shadows is real).
    """
    H, W = hdr.shape[:2]
    if H < 3 or W < 3 or not aov or H * W > FIREFLY_MAX_PIXELS:
        return 0.0, 0, 0
    test = smooth_region(aov, spec, camera)
    tested = int(test.sum())
    if not tested:
        return 0.0, 0, 0
    lum = np.nan_to_num(hdr.astype(np.float64), nan=0.0, posinf=0.0).max(-1)
    nmax = np.zeros((H, W))
    for nb in _neighbours(lum):
        nmax[1:-1, 1:-1] = np.maximum(nmax[1:-1, 1:-1], nb)
    # A spike must also matter: 0.1 % of the image's bright level (its 99th percentile; about
    # 3 LSB of sRGB near black when that level is display white), so relative wiggles of nearly
    # black values (a black metal's (1 - NdotV)^5 Fresnel near normal incidence changes 3x
    # between pixels at 1e-4 of the background) are not fireflies.
    floor = 1e-3 * float(np.percentile(lum, 99)) + 1e-30
    r = lum / (nmax + floor)
    worst = float(r[test].max())
    flagged = int((test & (r > ratio)).sum())
    return worst, flagged, tested


def furnace_error(hdr, aov, spec: ChartSpec, table: FurnaceTable) -> tuple[float, int, int]:
    """(worst relative error, pixels over tolerance, pixels tested) of a uniform-environment
    render against the float64 expectation; background pixels must equal the environment.
    One sample per pixel only: with more, a sample can land on a sphere smaller than a pixel
    that the centre sample (the AOVs) never saw."""
    if not aov or spec.spp != 1:
        return 0.0, 0, 0
    ids = surface_ids(aov, spec.cols)
    env = np.float64(np.float32(spec.env_intensity))
    half = spec.hdr_precision == "float16"
    got = hdr.astype(np.float64)
    worst, bad, tested = 0.0, 0, 0
    # Where the model exceeds the half range the target holds 65504 (the shader's clamp).
    cap = shading_model.HALF_MAX if half else np.inf
    rtol = FURNACE_RTOL[spec.quality] + (HALF_EPS if half else 0.0)
    atol = HALF_SUBNORMAL if half else 0.0

    background = (ids == -1) & (aov["ndotv"] == -1)
    if background.any():
        rel = np.maximum(np.abs(got[background] - min(env, cap)) - atol, 0.0) / min(env, cap)
        worst = max(worst, float(rel.max()))
        bad += int((rel > (HALF_EPS if half else 1e-6)).any(-1).sum())
        tested += int(background.sum())
    surf = interior_mask(ids) & (aov["ndotv"] >= FURNACE_MIN_NDOTV)
    if spec.ground:   # the spheres see the floor below them (a stage probe): no furnace for them
        surf &= ids < 0
    if not surf.any():
        return worst, bad, tested
    # The expectation at every surface pixel (spheres: their row and column; ground: its own).
    lit = (ids != -1) & (aov["ndotv"] >= 0)
    sphere = lit & (ids >= 0)
    rows, cols = np.clip(aov["row"], 0, None), np.clip(aov["col"], 0, None)
    rough = np.where(sphere, np.nan_to_num(aov["roughness"]), spec.ground_roughness)[lit]
    base = np.where(sphere[..., None], spec.material_array("base_color")[rows, cols],
                    np.asarray(spec.ground_color, np.float64))[lit]
    metal = np.where(sphere, np.nan_to_num(aov["metallic"]), 0.0)[lit]
    want = np.full(hdr.shape, np.nan)
    want[lit] = np.minimum(env * table.expected(aov["ndotv"][lit], rough, base, metal, spec.brdf,
                                                spec.multiscatter), cap)
    g, w = got[surf], want[surf]
    # Beyond the half target's step, relative to the pixel's brightest channel (an error of 1e-3
    # in the red of a green pixel is not 5 %), and absolute below FURNACE_FLOOR (the LUT's
    # absolute accuracy matters there, not the ratio).
    err = np.maximum(np.abs(g - w) - atol, 0.0)
    rel = err / np.maximum(w.max(-1, keepdims=True), FURNACE_FLOOR * env)
    worst = max(worst, float(rel.max()))
    bad += int((rel > rtol).any(-1).sum())
    tested += int(surf.sum())
    return worst, bad, tested


def monotonic_error(hdr, aov, spec: ChartSpec, probe, camera) -> tuple[list[str], float, float]:
    """At the probe pixel of every column: the radiance must not rise with roughness (and must
    be equal where the clamp makes the lobes equal), and it must match the float64 BRDF.
    ``camera``: the render's, for the probe pixels' size. Returns (failures, worst relative
    rise, worst relative mirror error)."""
    row, px0, step, normal = probe
    light = spec.lights[0]
    values, normals, depths, failures = [], [], [], []
    for c in range(spec.cols):
        x = px0 + c * step
        if aov["col"][row, x] != c or aov["row"][row, x] != 0:
            return [f"probe pixel ({row}, {x}) is not on sphere {c}"], 0.0, 0.0
        values.append(float(hdr[row, x].astype(np.float64).mean()))
        normals.append(aov["normal"][row, x].astype(np.float64))
        depths.append(float(aov["depth"][row, x]))
    if max(np.abs(np.asarray(normals) - np.asarray(normal)).max(-1)) > 1e-4:
        failures.append("columns are not pixel-aligned: probe normals differ")
    rough = np.maximum(spec.material_array("roughness")[0], shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    half = spec.hdr_precision == "float16"
    atol = HALF_SUBNORMAL if half else 0.0
    clamped = half and max(values) >= shading_model.HALF_MAX * (1 - HALF_EPS)
    worst_rise = 0.0
    order = np.argsort(rough, kind="stable")
    for a, b in zip(order, order[1:]):
        va, vb = values[a], values[b]
        if clamped and min(va, vb) >= shading_model.HALF_MAX * (1 - HALF_EPS):
            continue
        scale = max(va, vb, 1e-300)
        if abs(rough[a] - rough[b]) < 1e-9:
            rise = max(abs(va - vb) - atol, 0.0) / scale
            if rise > MONOTONIC_RTOL_EQUAL:
                failures.append(f"equal clamped roughness {rough[a]:g}: {va:.6g} vs {vb:.6g}")
        else:
            rise = (vb - va) / scale
            if rise > 1e-4:
                failures.append(f"peak rises with roughness {rough[a]:g} -> {rough[b]:g}: {va:.6g} -> {vb:.6g}")
        worst_rise = max(worst_rise, rise)
    # The float64 BRDF at the probe, the light's disc shaded as the chart shades it
    # (shading_model.brdf's disc_angular_radius, widened by the pixel: shaded_light_angle), E
    # at the material's roughness.
    # Renormalised in float64: a float32 unit vector is off by ~6e-8 in length, which at
    # the peak of an alpha = 0.002 lobe reads as a 3e-4 rad tilt and a 5 % lower D.
    n = shading_model.normalize(np.asarray(normals))
    v = np.array([0.0, 0.0, 1.0])
    l = np.asarray(light.direction)
    e = None
    if spec.multiscatter:
        A, B, _ = shading_model.dfg_integrate(np.clip(n @ v, shading_model.MIN_N_DOT_V, 1), rough, model=spec.brdf)
        e = A + B
    scale = np.clip(n @ l, 0, None) * light.intensity
    disc = shading_model.shaded_light_angle(math.radians(light.angular_radius_deg),
                                            render_plan(spec).glint_share * camera.pixel_size(np.asarray(depths)),
                                            spec.sphere_radius)
    lobes = [shading_model.brdf(n, v, l, np.asarray(spec.base_color), metal, rough, model=spec.brdf,
                         multiscatter=spec.multiscatter, e_spec=e,
                         disc_angular_radius=disc).mean(-1) * scale
             for metal in (spec.material_array("metallic")[0, 0], 0.0, 1.0)]
    want, got = lobes[0], np.asarray(values)
    if spec.hdr_precision == "float16":
        want = np.minimum(want, shading_model.HALF_MAX)
    # GLSL mix(a, b, 1) may be evaluated as a + (b - a): a few float32 ulps of the larger lobe
    # remain (a black metal's Fresnel-only highlight sits 1e-7 below its dielectric lobe).
    mix_ulps = 4 * 2.0 ** -24 * np.maximum(lobes[1], lobes[2])
    rel = np.maximum(np.abs(got - want) - atol - mix_ulps, 0.0) / np.maximum(want, 1e-300)
    worst_mirror = float(rel.max())
    if worst_mirror > MIRROR_RTOL[spec.quality] + (HALF_EPS if half else 0):
        failures.append(f"highlight centre differs from the float64 BRDF by {worst_mirror:.3g} "
                        f"(got {got.tolist()}, want {want.tolist()})")
    return failures, worst_rise, worst_mirror


def tiles_equal(a, b) -> bool:
    same = np.array_equal(a.hdr, b.hdr, equal_nan=True) and np.array_equal(a.image, b.image)
    same = same and np.array_equal(a.alpha, b.alpha, equal_nan=True)
    for k in a.aov:
        same = same and np.array_equal(a.aov[k], b.aov[k], equal_nan=True)
    return same
