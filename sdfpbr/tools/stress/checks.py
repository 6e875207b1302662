"""Seeded stress sweeps over the edges users reach for: roughness exactly 0, grazing
silhouettes, blinding or tiny lights, far cameras, giant images, half-float targets, both
backends. Every configuration is rendered and checked against properties derived without the
renderer (the checks are plain functions of arrays, tested on their own):

- finite:    no NaN, Inf or negative radiance; coverage in [0, 1];
- display:   the display image equals the float64 mirror's exposure -> tone map -> sRGB of
             the HDR within 1 LSB wherever the HDR is finite (a NaN born in the display pass
             shows up here);
- furnace:   in a uniform environment every sphere and ground pixel matches the float64
             split-sum expectation (REFERENCE.md section 3), the background the environment;
- firefly:   no pixel is brighter than FIREFLY_RATIO x its brightest neighbour where shading
             must vary smoothly (see ``isolated_outliers`` for why that region is safe);
- monotonic: at a highlight centre shared by every column the radiance falls as roughness
             rises (equal where the roughness clamp makes the lobes equal) and matches the
             float64 BRDF;
- tiles:     a render cut into small tiles equals the single-tile render bit for bit.

Configurations that share a composed program (same compile options) are grouped into
families, so a sweep compiles a few dozen programs, not thousands; one Renderer per backend
keeps programs, LUTs and IBL bakes across the whole sweep.
"""
from __future__ import annotations

import json
import math
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..oracle import mirror
from ..shading.camera import MARGIN, frame_grid
from ..spec.chart_spec import MATERIAL_PRESETS, ChartSpec, Light, make_spec

EDGE_ROUGHNESS = (0.0, 1e-6, 1e-3, 0.045, 0.5, 1.0)
EDGE_METALLIC = (0.0, 0.5, 1.0)
EDGE_BASE = (0.0, 0.5, 1.0)
ANGULAR_RADII_DEG = (0.0, 1e-3, 0.5, 2.5, 45.0)
SMALL_SIDES = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
MEDIUM_SIDES = (96, 128, 192, 256)
GRID_SIDES = (1, 2, 3, 5, 8, 16, 32)
TONEMAPS = ("none", "clamp", "reinhard", "reinhard-extended", "aces", "aces-hill", "neutral")
# spacing / (2 radius): overlapping, touching, the default, far apart, very far apart.
GEOMETRY = {"overlapping": 0.5, "touching": 1.0, "default": 1.25, "far apart": 10.0, "very far": 1000.0}
SPEC_MAX_INTENSITY = 1e12   # the largest light intensity and exposure a spec accepts
SPEC_MAX_EV = 40.0
TILED_TILE = 12           # the tile edge of the "egl-tiled" renderer (not a power of two)
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


# ---------------------------------------------------------------------------------------------
# Configurations
# ---------------------------------------------------------------------------------------------

@dataclass
class Case:
    index: int
    kind: str                 # "sweep" | "furnace" | "monotonic"
    backend: str              # "egl" | "osmesa" | "egl-tiled"
    spec: ChartSpec
    labels: dict              # dimension -> bucket, for the summary table
    probe: tuple | None = None   # monotonic: (image row, column of sphere 0, pixels per column, normal)
    aovs: bool = True


@dataclass
class Outcome:
    case: Case
    failures: list
    metrics: dict = field(default_factory=dict)
    seconds: float = 0.0


def _bucket_decade(x: float) -> str:
    return f"1e{int(round(math.log10(x))):+d}" if x > 0 else "0"


def _bucket_ev(ev: float) -> str:
    for hi, name in ((-20, "-40 (spec limit)"), (-10, "-20..-10"), (-1, "-10..-1"), (1, "-1..+1"), (10, "+1..+10"),
                     (20.5, "+10..+20")):
        if ev < hi:
            return name
    return "+40 (spec limit)"


def _bucket_size(w: int, h: int) -> str:
    long = max(w, h)
    for hi, name in ((1, "1"), (8, "2-8"), (64, "9-64"), (512, "65-512"), (2048, "513-2048"), (8192, "2049-8192")):
        if long <= hi:
            return name
    return ">8192"


def _bucket_grid(rows: int, cols: int) -> str:
    n = max(rows, cols)
    for hi, name in ((1, "1x1"), (4, "<=4"), (8, "<=8"), (16, "<=16")):
        if n <= hi:
            return name
    return "<=32"


def _edge_hits(values, edges) -> list[str]:
    return sorted({f"{e:g}" for e in edges for v in values if abs(v - e) <= 1e-12}, key=float)


class _Draw:
    """The seeded choices; every configuration is a pure function of the seed."""

    def __init__(self, seed: int):
        self.rng = np.random.default_rng(seed)

    def pick(self, seq, p=None):
        return seq[int(self.rng.choice(len(seq), p=p))]

    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)

    def log_edge(self, lo: float, hi: float, p_edge: float = 0.3) -> float:
        """Log-uniform in [lo, hi], with the ends themselves drawn p_edge of the time."""
        if self.chance(p_edge):
            return lo if self.chance(0.5) else hi
        return float(10.0 ** self.rng.uniform(math.log10(lo), math.log10(hi)))

    def unit(self) -> tuple:
        v = self.rng.normal(size=3)
        return tuple(float(c) for c in v / np.linalg.norm(v))


def _family(d: _Draw, kind: str, quick: bool, backends, number: int = 99) -> dict:
    """The compile-relevant choices (and the IBL bake's inputs) that a family shares; the first
    families take each backend in turn, so even a short sweep covers every one."""
    backend_p = {"egl": 0.72, "osmesa": 0.22, "egl-tiled": 0.06}
    names = [b for b in backend_p if b.split("-")[0] in backends]
    p = np.array([backend_p[b] for b in names])
    backend = d.pick(names, p / p.sum())
    fam = {
        "backend": names[number] if number < len(names) else backend,
        "brdf": d.pick(("gltf", "schlick-ggx"), (0.75, 0.25)),
        "camera": d.pick(("perspective", "orthographic"), (0.7, 0.3)),
        "intersect": d.pick(("analytic", "march"), (0.7, 0.3)),
        "multiscatter": d.chance(0.75),
        "hdr_precision": d.pick(("float32", "float16"), (0.7, 0.3)),
        "rows": d.pick(GRID_SIDES, (0.1, 0.2, 0.25, 0.2, 0.1, 0.1, 0.05)),
        "quality": d.pick(("draft", "default", "high"), (0.6, 0.4, 0.0) if quick else (0.55, 0.4, 0.05)),
        "ground": d.chance(0.5),
        "shadows": d.chance(0.7),
        # A few key-light directions per family: the IBL bake is keyed by the first directional
        # light (the sky's sun), so a fresh direction per configuration would mean a bake each.
        "directions": [d.unit() for _ in range(3)],
    }
    if kind == "furnace":
        fam.update(env="uniform", ibl=True, ao=False, transparent=False, n_dir=0, n_point=0,
                   env_intensity=d.pick((1.0, 1e-6, 1e6), (0.7, 0.15, 0.15)))
    else:
        fam.update(env=d.pick(("studio", "sky", "uniform", "black")), ibl=d.chance(0.8), ao=d.chance(0.6),
                   transparent=d.chance(0.12), n_dir=d.pick((0, 1, 2), (0.2, 0.6, 0.2)),
                   n_point=d.pick((0, 1), (0.5, 0.5)),
                   env_intensity=d.pick((1.0, 1e-6, 1e6), (0.8, 0.1, 0.1)))
    return fam


def _intensity(d: _Draw) -> float:
    """1e-6..1e6 as the issue asks, and now and then the spec's own limit 1e12."""
    return SPEC_MAX_INTENSITY if d.chance(0.02) else d.log_edge(1e-6, 1e6)


def _lights(d: _Draw, fam: dict, scene: float) -> tuple:
    lights = []
    for _ in range(fam["n_dir"]):
        lights.append(Light("directional", direction=d.pick(fam["directions"]), intensity=_intensity(d),
                            color=(1.0, 1.0, 1.0) if d.chance(0.6) else tuple(d.rng.random(3).tolist()),
                            angular_radius_deg=d.pick(ANGULAR_RADII_DEG)))
    for _ in range(fam["n_point"]):
        where = d.pick((0.01, 0.5, 1.0, 3.0))
        position = tuple(float(c) for c in d.rng.uniform(-1, 1, 3) * scene * where)
        lights.append(Light("point", position=position, intensity=_intensity(d),
                            range=d.log_edge(1e-3, 1e3) * scene))
    return tuple(lights)


def _size(d: _Draw) -> tuple[int, int]:
    long = d.pick(SMALL_SIDES) if d.chance(0.9) else d.pick(MEDIUM_SIDES)
    short = max(1, int(round(long * d.pick((1.0, 0.75, 0.5, 0.25, 1 / 16, 0.0)))))
    return (long, short) if d.chance(0.5) else (short, long)


def _sweep_case(d: _Draw, index: int, kind: str, fam: dict, size=None) -> Case:
    rows, cols = fam["rows"], d.pick(GRID_SIDES, (0.1, 0.2, 0.25, 0.2, 0.1, 0.1, 0.05))
    radius = d.pick((1e-3, 1.0, 1e3), (0.15, 0.7, 0.15))
    geometry = d.pick(tuple(GEOMETRY))
    spacing = min(max(GEOMETRY[geometry] * 2 * radius, 1e-4), 1e6)
    scene = max(rows, cols) * spacing + 2 * radius
    width, height = size or _size(d)
    roughness = (d.pick(EDGE_ROUGHNESS), d.pick(EDGE_ROUGHNESS))
    metallic = (d.pick(EDGE_METALLIC), d.pick(EDGE_METALLIC))
    base = (d.pick(EDGE_BASE),) * 3 if d.chance(0.8) else tuple(d.pick(EDGE_BASE) for _ in range(3))
    materials = tuple(d.pick(tuple(MATERIAL_PRESETS)) for _ in range(rows)) if d.chance(0.1) else ()
    exposure = d.pick((-20.0, 20.0)) if d.chance(0.3) else (0.0 if d.chance(0.2) else float(d.rng.uniform(-20, 20)))
    if d.chance(0.02):
        exposure = d.pick((-SPEC_MAX_EV, SPEC_MAX_EV))   # the spec's own limits, beyond the issue's
    distance = 1.0 if d.chance(0.4) else d.log_edge(1e-3, 1e3)
    elevation = d.pick((8.0, 0.0, 89.0, -89.0)) if d.chance(0.4) else float(d.rng.uniform(-89, 89))
    lights = _lights(d, fam, scene)
    spec = make_spec(
        rows=rows, cols=cols, width=width, height=height, roughness=roughness, metallic=metallic,
        base_color=base, row_materials=materials, env=fam["env"], env_intensity=fam["env_intensity"],
        lights=lights, shadows=fam["shadows"], ao=fam["ao"], ground=fam["ground"], ibl=fam["ibl"],
        tonemap=d.pick(TONEMAPS), exposure=exposure, reinhard_white=d.pick((1e-3, 1.0, 4.0, 1e6)),
        spp=1 if kind == "furnace" else d.pick((1, 1, 1, 2, 4)), multiscatter=fam["multiscatter"], brdf=fam["brdf"],
        camera=fam["camera"], camera_azimuth=0.0 if d.chance(0.4) else float(d.rng.uniform(-180, 180)),
        camera_elevation=elevation, camera_distance_scale=distance, intersect=fam["intersect"],
        sphere_radius=radius, spacing=spacing, transparent=fam["transparent"], quality=fam["quality"],
        backend=fam["backend"].split("-")[0], hdr_precision=fam["hdr_precision"],
        ground_color=tuple(d.rng.random(3).tolist()), ground_roughness=d.pick((0.0, 0.045, 0.8, 1.0)),
        labels=False)
    intensities = [l.intensity for l in lights]
    labels = {
        "kind": kind, "backend": fam["backend"], "precision": fam["hdr_precision"],
        "exposure EV": _bucket_ev(exposure), "camera distance": _bucket_decade(distance),
        "geometry": geometry, "grid": _bucket_grid(rows, cols), "size (long side)": _bucket_size(width, height),
        "light intensity": [_bucket_decade(i) for i in intensities] or ["no lights"],
        "roughness": _edge_hits(spec.column_roughness(), EDGE_ROUGHNESS),
        "metallic": _edge_hits(spec.row_metallic(), EDGE_METALLIC),
        "base colour": "presets" if materials else ("grey " + f"{base[0]:g}" if len(set(base)) == 1 else "mixed"),
        "tone map": spec.tonemap, "env": f"{spec.env} x{_bucket_decade(spec.env_intensity)}",
        "brdf": spec.brdf + ("" if spec.multiscatter else " single"), "camera": spec.camera,
        "intersect": fam["intersect"], "spp": str(spec.spp), "quality": spec.quality,
    }
    return Case(index, kind, fam["backend"], spec, labels)


def _monotonic_case(d: _Draw, index: int, fam: dict) -> Case:
    """One row of spheres, orthographic and pixel-aligned (the spacing is a whole number of
    pixels), so the same pixel offset samples the same normal in every column; the light is
    placed so that this normal is exactly the highlight centre (h = n)."""
    cols = d.pick((3, 4, 5, 6))
    lo, hi = sorted((d.pick(EDGE_ROUGHNESS), d.pick(EDGE_ROUGHNESS)))
    if lo == hi:
        lo, hi = 0.0, 1.0
    height = d.pick((24, 32, 48))
    pixel = 2.0 * MARGIN / height                  # world units per pixel (radius 1, height-bound)
    step = int(math.ceil(2.0 / pixel)) + d.pick((1, 3))     # pixels between sphere centres
    spacing = step * pixel
    width = int(math.ceil(height * ((cols - 1) * spacing / 2 + 1.0))) + 2
    # A pixel of sphere 0 whose normal faces the camera at NdotV in [0.45, 0.95].
    x0 = -(cols - 1) * spacing / 2
    n_dot_v = float(d.rng.uniform(0.45, 0.95))
    phi = float(d.rng.uniform(0, 2 * math.pi))
    s = math.sqrt(1 - n_dot_v ** 2)
    px = int(round((x0 + s * math.cos(phi)) / pixel + width / 2 - 0.5))
    py_gl = int(round(s * math.sin(phi) / pixel + height / 2 - 0.5))
    x, y = (px + 0.5 - width / 2) * pixel - x0, (py_gl + 0.5 - height / 2) * pixel
    normal = np.array([x, y, math.sqrt(max(1.0 - x * x - y * y, 0.0))])
    view = np.array([0.0, 0.0, 1.0])
    light_dir = 2 * normal.dot(view) * normal - view          # reflect(-v, n): h = n exactly
    metallic = d.pick(EDGE_METALLIC)
    base = d.pick(EDGE_BASE)
    light = Light("directional", direction=tuple(light_dir), intensity=d.log_edge(1e-6, 1e6),
                  angular_radius_deg=d.pick((0.0, 0.5, 2.5)))
    spec = make_spec(
        rows=1, cols=cols, width=width, height=height, roughness=(lo, hi), metallic=(metallic, metallic),
        base_color=(base,) * 3, env="black", lights=(light,), shadows=False, ao=False, ground=False,
        ibl=False, camera="orthographic", camera_azimuth=0.0, camera_elevation=0.0, intersect="analytic",
        spacing=spacing, brdf=fam["brdf"], multiscatter=fam["multiscatter"], quality=fam["quality"],
        hdr_precision=fam["hdr_precision"], backend=fam["backend"].split("-")[0],
        exposure=float(d.rng.uniform(-20, 20)), tonemap=d.pick(TONEMAPS), labels=False)
    labels = {"kind": "monotonic", "backend": fam["backend"], "precision": fam["hdr_precision"],
              "roughness": _edge_hits(spec.column_roughness(), EDGE_ROUGHNESS),
              "metallic": _edge_hits([metallic], EDGE_METALLIC), "base colour": f"grey {base:g}",
              "light intensity": [_bucket_decade(light.intensity)], "brdf": spec.brdf + ("" if spec.multiscatter else " single"),
              "quality": spec.quality}
    return Case(index, "monotonic", fam["backend"], spec, labels,
                probe=(height - 1 - py_gl, px, step, tuple(normal)))


def _big_sizes(quick: bool) -> list[tuple[int, int, bool]]:
    """(width, height, aovs): strips that exercise tiling, beyond-GL-limit widths, giants."""
    if quick:
        return [(3000, 5, True), (5, 2500, True)]
    return [(8192, 12, True), (12, 8192, True), (8192, 48, True), (16500, 3, True), (4096, 1024, True),
            (2048, 2048, True), (8192, 8192, False)]


def generate_cases(seed: int = 0, count: int = 10_000, quick: bool = False,
                   backends=("egl", "osmesa")) -> list[Case]:
    """The sweep for a seed: families of configurations sharing a composed program, plus a few
    big images. Same seed, same list."""
    d = _Draw(seed)
    big = _big_sizes(quick)
    n_monotonic = max(2, count // 12)
    n_furnace = max(2, count // 4)
    n_sweep = max(1, count - n_monotonic - n_furnace - len(big))
    per_family = 40 if quick else 160
    cases: list[Case] = []
    number = 0
    for kind, n in (("sweep", n_sweep), ("furnace", n_furnace), ("monotonic", n_monotonic)):
        families = max(1, round(n / per_family))
        for f in range(families):
            fam = _family(d, kind, quick, backends, number)
            number += 1
            share = n // families + (1 if f < n % families else 0)
            for _ in range(share):
                if kind == "monotonic":
                    cases.append(_monotonic_case(d, len(cases), {**fam, "rows": 1}))
                else:
                    cases.append(_sweep_case(d, len(cases), kind, fam))
    for width, height, aovs in big:
        fam = _family(d, "sweep", quick, ("egl",))
        fam.update(quality="draft", backend="egl", rows=d.pick((1, 3, 5)))
        case = _sweep_case(d, len(cases), "sweep", fam, size=(width, height))
        case.aovs = aovs
        cases.append(case)
    return cases


# ---------------------------------------------------------------------------------------------
# Checks: plain functions of arrays
# ---------------------------------------------------------------------------------------------

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
    """(H, W, 4) uint8 from the float64 mirror: un-premultiply (transparent), exposure, tone
    map, sRGB OETF; alpha 255 or the coverage."""
    x = hdr.astype(np.float64)
    a = alpha.astype(np.float64)
    if spec.transparent:
        x = np.where(a[..., None] > 0, x / np.where(a > 0, a, 1.0)[..., None], 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        y = mirror.srgb_oetf(mirror.tonemap(x * 2.0 ** spec.exposure, spec.tonemap, white=spec.reinhard_white))
    out = np.empty(hdr.shape[:2] + (4,), np.uint8)
    out[..., :3] = np.rint(np.nan_to_num(y) * 255.0)
    out[..., 3] = np.rint(np.clip(a, 0, 1) * 255.0) if spec.transparent else 255
    return out


def display_error(hdr, alpha, image, spec: ChartSpec, chunk_rows: int | None = None) -> tuple[int, int]:
    """(largest |GPU - mirror| in LSB, pixels over DISPLAY_LSB) where the HDR is finite."""
    H, W = hdr.shape[:2]
    chunk_rows = chunk_rows or max(1, 1_000_000 // max(W, 1))
    worst, bad = 0, 0
    for r0 in range(0, H, chunk_rows):
        sl = slice(r0, r0 + chunk_rows)
        want = expected_display(hdr[sl], alpha[sl], spec).astype(np.int16)
        diff = np.abs(want - image[sl].astype(np.int16)).max(-1)
        finite = np.isfinite(hdr[sl]).all(-1) & np.isfinite(alpha[sl])
        diff = np.where(finite, diff, 0)
        worst = max(worst, int(diff.max()) if diff.size else 0)
        bad += int((diff > DISPLAY_LSB).sum())
    return worst, bad


def surface_ids(aov: dict, cols: int) -> np.ndarray:
    """Per pixel: the sphere index, -2 for the ground, -1 for the background."""
    sphere = aov["row"] * cols + aov["col"]
    ground = (aov["row"] < 0) & np.isfinite(aov["depth"]) & (aov["ndotv"] >= -0.5)
    return np.where(aov["row"] >= 0, sphere, np.where(ground, -2, -1))


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
    same = c != -1
    for nb in _neighbours(ids):
        same &= nb == c
    out[1:-1, 1:-1] = same
    return out


def pixel_rays(camera, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Ray origins and unit directions (H, W, 3) of the pixel centres, as camera.glsl makes them."""
    ys, xs = np.mgrid[0:height, 0:width]
    ndc_x = 2 * (xs + 0.5) / width - 1
    ndc_y = 1 - 2 * (ys + 0.5) / height
    sx = (ndc_x * width / height * camera.half_height)[..., None]
    sy = (ndc_y * camera.half_height)[..., None]
    if camera.orthographic:
        ro = camera.position + sx * camera.right + sy * camera.up
        rd = np.broadcast_to(camera.forward, ro.shape)
    else:
        rd = camera.forward + sx * camera.right + sy * camera.up
        rd = rd / np.linalg.norm(rd, axis=-1, keepdims=True)
        ro = np.broadcast_to(camera.position, rd.shape)
    return ro, rd


def smooth_region(aov: dict, spec: ChartSpec, camera) -> np.ndarray:
    """Pixels where the continuous image must be smooth at the pixel scale (see
    isolated_outliers): all 9 pixels one surface, away from every highlight centre, from
    point lights closer than a few pixels and (with several samples a pixel) from spheres too
    small for the centre samples to see; where the environment has sharp features, only
    where the reflection moves across them slowly; ground excluded when it receives shadows."""
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
    if spec.ibl and spec.env != "uniform" and spec.env != "black":
        # The reflected direction moves by up to 2 dn + dv a pixel; the prefiltered environment
        # varies on its own feature scale widened by the lobe. Sampled at least twice across
        # that scale a feature spreads over neighbours (which then hold >= ~half its peak);
        # crossed faster, it is a legitimately sharp, even one-pixel, reflection.
        alpha_px = np.maximum(np.where(ids >= 0, np.nan_to_num(aov["roughness"]), spec.ground_roughness),
                              mirror.MIN_PERCEPTUAL_ROUGHNESS) ** 2
        test &= 2 * (2 * dn + dv) <= ENV_FEATURE_RAD.get(spec.env, 0.0) + 2 * alpha_px
    ro, rd = pixel_rays(camera, W, H)
    depth = np.where(test, aov["depth"], 0.0)[..., None]
    p = ro + rd * depth
    v = -rd
    rough = np.where(ids >= 0, np.nan_to_num(aov["roughness"]), spec.ground_roughness)
    alpha_mat = np.maximum(rough, mirror.MIN_PERCEPTUAL_ROUGHNESS) ** 2
    pixel_size = 2 * camera.half_height / H * (1.0 if camera.orthographic else depth[..., 0])
    for light in spec.lights:
        if light.kind == "directional":
            l = np.broadcast_to(np.asarray(light.direction), p.shape)
            a = np.minimum(1.0, alpha_mat + 0.5 * math.sin(math.radians(light.angular_radius_deg)))
        else:
            to_light = np.asarray(light.position) - p
            dist = np.linalg.norm(to_light, axis=-1)
            l = to_light / np.maximum(dist, 1e-300)[..., None]
            a = alpha_mat
            test &= dist > 8 * pixel_size
        h = mirror.normalize(v + l)
        delta = np.arccos(np.clip((n * h).sum(-1), -1.0, 1.0))
        # h moves by dn_h = dn + dv/2 a pixel. D changes by at most exp(2 dn_h / alpha) per step
        # (its log slope peaks at 2/alpha), <= 2.4 when dn_h <= 0.44 alpha: a resolved lobe.
        # An unresolved one is skipped near its centre; beyond 4 dn_h its tail changes by
        # (1 + dn_h/delta)^4 <= 2.4 per step.
        dn_h = dn + dv / 2
        test &= (dn_h <= 0.44 * a) | (delta >= np.maximum(4 * dn_h, 3 * a))
    return test


def _near_small_spheres(spec: ChartSpec, camera, H: int, W: int) -> np.ndarray:
    """Pixels within 2 pixels of a sphere whose image is under 2 pixels across: a pixel's
    other samples can hit it while its centre sample (the AOVs) sees the ground or sky."""
    from ..shading.camera import sphere_centers
    near = np.zeros((H, W), bool)
    px, scale = camera.project(sphere_centers(spec).reshape(-1, 3))
    radius = spec.sphere_radius * np.abs(scale)
    depth = (sphere_centers(spec).reshape(-1, 3) - camera.position) @ camera.forward
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
    crossed in under two samples; (4) a point light closer than 8 pixel footprints; (5) with
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


class FurnaceTable:
    """The float64 split-sum terms (A, B, C) of mirror.dfg_integrate, tabulated per roughness
    at N_MU values of NdotV and interpolated linearly (the interpolation error, < 1e-5 for
    NdotV >= 0.05, is checked in tests/test_stress.py against direct integration)."""

    N_MU = 1024
    QUADRATURE = 32   # Gauss-Legendre order; mirror.dfg_integrate says 32 agrees with 512 to 1e-9

    def __init__(self):
        self.mu = np.linspace(mirror.MIN_N_DOT_V, 1.0, self.N_MU)
        self._terms: dict = {}

    def terms(self, model: str, perceptual_roughness: float):
        r = max(float(perceptual_roughness), mirror.MIN_PERCEPTUAL_ROUGHNESS)
        key = (model, round(r, 12))
        if key not in self._terms:
            self._terms[key] = mirror.dfg_integrate(self.mu, r, model=model, n=self.QUADRATURE)
        return self._terms[key]

    def expected(self, n_dot_v, perceptual_roughness, base_color, metallic, model="gltf", multiscatter=True):
        """furnace_expected (radiance 1) at each pixel: (N,) inputs -> (N, 3)."""
        n_dot_v = np.clip(np.asarray(n_dot_v, np.float64), mirror.MIN_N_DOT_V, 1.0)
        rough = np.asarray(perceptual_roughness, np.float64)
        A, B, C = (np.empty_like(n_dot_v) for _ in range(3))
        for r in np.unique(rough):
            m = rough == r
            tA, tB, tC = self.terms(model, r)
            A[m], B[m], C[m] = (np.interp(n_dot_v[m], self.mu, t) for t in (tA, tB, tC))
        return mirror.furnace_from_dfg(A, B, C, base_color, metallic, multiscatter)


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
    cap = mirror.HALF_MAX if half else np.inf
    rtol = FURNACE_RTOL[spec.quality] + (HALF_EPS if half else 0.0)
    atol = HALF_SUBNORMAL if half else 0.0

    background = (ids == -1) & (aov["ndotv"] == -1)
    if background.any():
        rel = np.maximum(np.abs(got[background] - min(env, cap)) - atol, 0.0) / min(env, cap)
        worst = max(worst, float(rel.max()))
        bad += int((rel > (HALF_EPS if half else 1e-6)).any(-1).sum())
        tested += int(background.sum())
    surf = interior_mask(ids) & (aov["ndotv"] >= FURNACE_MIN_NDOTV)
    if not surf.any():
        return worst, bad, tested
    # The expectation at every surface pixel (spheres: their row and column; ground: its own).
    lit = (ids != -1) & (aov["ndotv"] >= 0)
    sphere = lit & (ids >= 0)
    rows = np.clip(aov["row"], 0, None)
    rough = np.where(sphere, np.nan_to_num(aov["roughness"]), spec.ground_roughness)[lit]
    base = np.where(sphere[..., None], np.asarray(spec.row_base_colors(), np.float64)[rows],
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


def monotonic_error(hdr, aov, spec: ChartSpec, probe) -> tuple[list[str], float, float]:
    """At the probe pixel of every column: the radiance must not rise with roughness (and must
    be equal where the clamp makes the lobes equal), and it must match the float64 BRDF.
    Returns (failures, worst relative rise, worst relative mirror error)."""
    row, px0, step, normal = probe
    light = spec.lights[0]
    values, normals, failures = [], [], []
    for c in range(spec.cols):
        x = px0 + c * step
        if aov["col"][row, x] != c or aov["row"][row, x] != 0:
            return [f"probe pixel ({row}, {x}) is not on sphere {c}"], 0.0, 0.0
        values.append(float(hdr[row, x].astype(np.float64).mean()))
        normals.append(aov["normal"][row, x].astype(np.float64))
    if max(np.abs(np.asarray(normals) - np.asarray(normal)).max(-1)) > 1e-4:
        failures.append("columns are not pixel-aligned: probe normals differ")
    rough = np.maximum(np.asarray(spec.column_roughness()), mirror.MIN_PERCEPTUAL_ROUGHNESS)
    half = spec.hdr_precision == "float16"
    atol = HALF_SUBNORMAL if half else 0.0
    clamped = half and max(values) >= mirror.HALF_MAX * (1 - HALF_EPS)
    worst_rise = 0.0
    order = np.argsort(rough, kind="stable")
    for a, b in zip(order, order[1:]):
        va, vb = values[a], values[b]
        if clamped and min(va, vb) >= mirror.HALF_MAX * (1 - HALF_EPS):
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
    # The float64 BRDF at the probe: the shader widens alpha by the light's disc (the mirror
    # takes it as perceptual sqrt(alpha_light)) and takes E at the material's roughness.
    worst_mirror = 0.0
    widened = light.angular_radius_deg > 0
    if not widened or spec.brdf == "gltf":
        # Renormalised in float64: a float32 unit vector is off by ~6e-8 in length, which at
        # the peak of an alpha = 0.002 lobe reads as a 3e-4 rad tilt and a 5 % lower D.
        n = mirror.normalize(np.asarray(normals))
        v = np.array([0.0, 0.0, 1.0])
        l = np.asarray(light.direction)
        alpha_light = np.minimum(1.0, rough ** 2 + 0.5 * math.sin(math.radians(light.angular_radius_deg)))
        e = None
        if spec.multiscatter:
            A, B, _ = mirror.dfg_integrate(np.clip(n @ v, mirror.MIN_N_DOT_V, 1), rough, model=spec.brdf)
            e = A + B
        scale = np.clip(n @ l, 0, None) * light.intensity
        lobes = [mirror.brdf(n, v, l, np.asarray(spec.base_color), metal, np.sqrt(alpha_light), model=spec.brdf,
                             multiscatter=spec.multiscatter, e_spec=e).mean(-1) * scale
                 for metal in (spec.row_metallic()[0], 0.0, 1.0)]
        want, got = lobes[0], np.asarray(values)
        if spec.hdr_precision == "float16":
            want = np.minimum(want, mirror.HALF_MAX)
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


# ---------------------------------------------------------------------------------------------
# Running
# ---------------------------------------------------------------------------------------------

def run_case(case: Case, renderers: dict, table: FurnaceTable) -> Outcome:
    start = time.perf_counter()
    spec = case.spec
    result = renderers[case.backend].render(spec, aovs=case.aovs)
    failures = check_finite(result.hdr, result.alpha)
    metrics = {}
    lsb, bad = display_error(result.hdr, result.alpha, result.image, spec)
    metrics["display_lsb"] = lsb
    if bad:
        failures.append(f"{bad} display pixels differ from the tone-mapped HDR by more than {DISPLAY_LSB} LSB (worst {lsb})")
    ratio, flagged, tested = isolated_outliers(result.hdr, result.aov, spec, frame_grid(spec))
    metrics["firefly_ratio"] = ratio
    metrics["firefly_tested"] = tested
    if flagged:
        failures.append(f"{flagged} isolated firefly pixels (worst {ratio:.3g}x the brightest neighbour)")
    grazing = result.aov["ndotv"][result.aov["row"] >= 0] if case.aovs else np.empty(0)
    metrics["min_ndotv"] = float(grazing.min()) if grazing.size else 1.0
    if case.kind == "furnace":
        err, bad, tested = furnace_error(result.hdr, result.aov, spec, table)
        metrics["furnace_err"] = err
        metrics["furnace_tested"] = tested
        if bad:
            failures.append(f"{bad} furnace pixels off the float64 expectation (worst relative {err:.3g})")
    if case.kind == "monotonic":
        fails, rise, mirror_err = monotonic_error(result.hdr, result.aov, spec, case.probe)
        metrics["monotonic_rise"] = rise
        metrics["mirror_err"] = mirror_err
        failures += fails
    if case.backend == "egl-tiled":
        if not tiles_equal(result, renderers["egl"].render(spec, aovs=case.aovs)):
            failures.append(f"a render in {TILED_TILE}-pixel tiles differs from the untiled render")
    return Outcome(case, failures, metrics, time.perf_counter() - start)


def make_renderers(cases: list[Case], cache=None) -> tuple[dict, list[str]]:
    """One Renderer per backend the cases use (plus a small-tile EGL one); backends that cannot
    start are reported, and their cases skipped."""
    from ..errors import GLUnavailable
    from ..gpu.gl import create_context
    from ..gpu.render import Renderer
    renderers, notes = {}, []
    for name in sorted({c.backend for c in cases} | ({"egl"} if any(c.backend == "egl-tiled" for c in cases) else set())):
        base = name.split("-")[0]
        try:
            ctx = renderers[base].ctx if base in renderers else create_context(base)
        except GLUnavailable as exc:
            notes.append(f"backend {name} skipped: {exc}")
            continue
        renderers[name] = Renderer(ctx, cache, tile=TILED_TILE if name == "egl-tiled" else None)
    return renderers, notes


class _PlainProgress:
    """A stand-in for tqdm: one line every 10 % (none when file is None)."""

    def __init__(self, total: int, file):
        self.total, self.n, self.file, self._next = total, 0, file, 0

    def update(self, k: int = 1) -> None:
        self.n += k
        if self.file is not None and (self.n >= self._next or self.n == self.total):
            print(f"stress: {self.n}/{self.total} configurations", file=self.file, flush=True)
            self._next = self.n + max(1, self.total // 10)

    def set_postfix_str(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass


def progress_bar(total: int, enabled: bool = True, file=None):
    file = file or sys.stderr
    if not enabled:
        return _PlainProgress(total, None)
    try:
        from tqdm import tqdm
    except ImportError:   # the 'progress' extra is optional
        return _PlainProgress(total, file)
    return tqdm(total=total, unit="cfg", file=file, dynamic_ncols=True, mininterval=0.5)


@dataclass
class Report:
    outcomes: list
    notes: list
    seconds: float
    seed: int

    @property
    def failures(self) -> list:
        return [o for o in self.outcomes if o.failures]

    def worst(self, metric: str) -> float:
        return max((o.metrics.get(metric, 0.0) for o in self.outcomes), default=0.0)

    def table(self) -> list[dict]:
        """Per dimension and bucket: configurations, failures, worst display LSB, furnace error,
        firefly ratio, monotonic rise, mirror error."""
        rows = defaultdict(lambda: {"configs": 0, "failures": 0, "display_lsb": 0, "furnace_err": 0.0,
                                    "firefly_ratio": 0.0, "mirror_err": 0.0})
        for o in self.outcomes:
            labels = dict(o.case.labels)
            labels["silhouette min NdotV"] = ("<1e-3" if o.metrics.get("min_ndotv", 1) < 1e-3 else
                                              "<1e-2" if o.metrics.get("min_ndotv", 1) < 1e-2 else ">=1e-2")
            for dim, values in labels.items():
                for value in values if isinstance(values, list) else [values]:
                    r = rows[(dim, value)]
                    r["configs"] += 1
                    r["failures"] += bool(o.failures)
                    for m in ("display_lsb", "furnace_err", "firefly_ratio", "mirror_err"):
                        r[m] = max(r[m], o.metrics.get(m, 0))
        return [{"dimension": d, "value": v, **r} for (d, v), r in rows.items()]

    def to_json(self) -> dict:
        return {"seed": self.seed, "configs": len(self.outcomes), "failures": len(self.failures),
                "seconds": round(self.seconds, 1), "notes": self.notes,
                "worst": {m: self.worst(m) for m in ("display_lsb", "furnace_err", "firefly_ratio",
                                                      "monotonic_rise", "mirror_err")},
                "checked": {"firefly pixels": int(sum(o.metrics.get("firefly_tested", 0) for o in self.outcomes)),
                            "furnace pixels": int(sum(o.metrics.get("furnace_tested", 0) for o in self.outcomes))},
                "table": self.table(),
                "failing": [{"index": o.case.index, "kind": o.case.kind, "backend": o.case.backend,
                             "failures": o.failures} for o in self.failures]}

    def format(self) -> str:
        lines = [f"{'dimension':22s} {'value':16s} {'configs':>7s} {'fail':>5s} {'LSB':>4s} "
                 f"{'furnace':>8s} {'firefly':>8s} {'mirror':>8s}"]
        for r in sorted(self.table(), key=lambda r: (r["dimension"], str(r["value"]))):
            lines.append(f"{r['dimension'][:22]:22s} {str(r['value'])[:16]:16s} {r['configs']:7d} {r['failures']:5d} "
                         f"{r['display_lsb']:4d} {r['furnace_err']:8.2e} {r['firefly_ratio']:8.3g} {r['mirror_err']:8.2e}")
        j = self.to_json()
        w = j["worst"]
        lines.append("")
        lines.append(f"{j['configs']} configurations (seed {self.seed}), {j['failures']} failing, {self.seconds:.1f} s; "
                     f"worst: display {w['display_lsb']} LSB, furnace {w['furnace_err']:.2e}, "
                     f"firefly ratio {w['firefly_ratio']:.3g} (limit {FIREFLY_RATIO:g}), "
                     f"monotonic rise {w['monotonic_rise']:.2e}, BRDF mirror {w['mirror_err']:.2e}; "
                     f"{j['checked']['firefly pixels']} pixels firefly-tested, "
                     f"{j['checked']['furnace pixels']} furnace-tested")
        lines += self.notes
        for o in self.failures[:20]:
            lines.append(f"FAIL #{o.case.index} [{o.case.kind}, {o.case.backend}]: " + "; ".join(o.failures))
        if len(self.failures) > 20:
            lines.append(f"... and {len(self.failures) - 20} more")
        return "\n".join(lines)


def run_sweep(cases: list[Case], renderers: dict, notes: list, seed: int = 0,
              failures_dir: Path | None = None, progress: bool = True) -> Report:
    table = FurnaceTable()
    runnable = [c for c in cases if c.backend in renderers]
    # Cases that share a program run together (the renderers cache every program anyway; this
    # keeps the working set small and the compile spikes at family boundaries).
    from ..gpu.render import chart_source
    runnable.sort(key=lambda c: (c.backend, chart_source(c.spec).digest, c.index))
    bar = progress_bar(len(runnable), progress)
    start = time.perf_counter()
    outcomes = []
    try:
        for case in runnable:
            try:
                outcome = run_case(case, renderers, table)
            except Exception as exc:   # a crash in one configuration is a failure, not the end
                outcome = Outcome(case, [f"render raised {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"])
            outcomes.append(outcome)
            if outcome.failures and failures_dir is not None:
                write_failure(failures_dir, outcome)
            bar.update(1)
    finally:
        bar.close()
    outcomes.sort(key=lambda o: o.case.index)
    return Report(outcomes, notes, time.perf_counter() - start, seed)


# ---------------------------------------------------------------------------------------------
# Failing configurations as ready-to-run TOML specs
# ---------------------------------------------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        # JSON escapes are TOML escapes, except that JSON writes characters beyond U+FFFF as
        # surrogate pairs (invalid in TOML) and leaves DEL raw (TOML wants it escaped).
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def spec_to_toml(spec: ChartSpec, comments=()) -> str:
    """A TOML spec that load_spec reads back to an equal ChartSpec."""
    d = spec.to_dict()
    lights = d.pop("lights")
    lines = [f"# {c}" for c in comments]
    lines += [f"{k} = {_toml_value(v)}" for k, v in d.items()]
    if not lights:
        lines.append("lights = []")
    for light in lights:
        lines += ["", "[[lights]]"] + [f"{k} = {_toml_value(v)}" for k, v in light.items()]
    return "\n".join(lines) + "\n"


def write_failure(directory: Path, outcome: Outcome) -> Path:
    from ..image.io import atomic_file
    case = outcome.case
    comments = [f"sdfpbr stress: configuration #{case.index} ({case.kind}, backend {case.backend}) failed:"]
    comments += [f"  {f}" for f in outcome.failures]
    if case.backend == "egl-tiled":
        comments.append(f"  (rendered with Renderer(..., tile={TILED_TILE}); sdfpbr chart uses full tiles)")
    comments.append(f"reproduce: sdfpbr chart --spec {case.index:05d}-{case.kind}.toml --hdr out.npy")
    path = Path(directory) / f"{case.index:05d}-{case.kind}.toml"
    with atomic_file(path) as f:
        f.write(spec_to_toml(case.spec, comments).encode())
    return path
