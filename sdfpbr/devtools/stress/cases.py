"""The sweep's configurations: seeded draws over the edges, grouped into families that share
a composed program. Every configuration is a pure function of the seed."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...shading.camera import MARGIN
from ...spec.chart_spec import MATERIAL_PRESETS, ChartSpec, Light, make_spec
from ...spec.presets import (BRDF_MODELS, CAMERAS, ENV_PRESETS, HDR_PRECISIONS, INTERSECTIONS, QUALITY_LEVELS,
                             TONEMAPPERS)

EDGE_ROUGHNESS = (0.0, 1e-6, 1e-3, 0.045, 0.5, 1.0)
EDGE_METALLIC = (0.0, 0.5, 1.0)
EDGE_BASE = (0.0, 0.5, 1.0)
ANGULAR_RADII_DEG = (0.0, 1e-3, 0.5, 2.5, 45.0)
SMALL_SIDES = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)
MEDIUM_SIDES = (96, 128, 192, 256)
GRID_SIDES = (1, 2, 3, 5, 8, 16, 32)
# spacing / (2 radius): overlapping, touching, the default, far apart, very far apart.
GEOMETRY = {"overlapping": 0.5, "touching": 1.0, "default": 1.25, "far apart": 10.0, "very far": 1000.0}
SPEC_MAX_INTENSITY = 1e12   # the largest light intensity and exposure a spec accepts
SPEC_MAX_EV = 40.0
TILED_TILE = 12           # the tile edge of the "egl-tiled" renderer (not a power of two)


@dataclass
class Case:
    index: int
    kind: str                 # "sweep" | "furnace" | "monotonic"
    backend: str              # "egl" | "osmesa" | "egl-tiled"
    spec: ChartSpec
    labels: dict              # dimension -> bucket, for the summary table
    probe: tuple | None = None   # monotonic: (image row, column of sphere 0, pixels per column, normal)
    aovs: bool = True


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
        "brdf": d.pick(BRDF_MODELS, (0.75, 0.25)),
        "camera": d.pick(CAMERAS, (0.7, 0.3)),
        "intersect": d.pick(INTERSECTIONS, (0.7, 0.3)),
        "multiscatter": d.chance(0.75),
        "hdr_precision": d.pick(HDR_PRECISIONS, (0.7, 0.3)),
        "rows": d.pick(GRID_SIDES, (0.1, 0.2, 0.25, 0.2, 0.1, 0.1, 0.05)),
        "quality": d.pick(QUALITY_LEVELS, (0.6, 0.4, 0.0) if quick else (0.55, 0.4, 0.05)),
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
        fam.update(env=d.pick(ENV_PRESETS), ibl=d.chance(0.8), ao=d.chance(0.6),
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
                            range=d.log_edge(1e-3, 1e3) * scene, radius=d.pick((0.0, 0.0, 0.02, 0.2)) * scene))
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
    # The sweep's geometric checks (probe pixels, smooth regions, firefly neighbourhoods) trace
    # the shared stage's one camera; the cells stage's geometry is tested in tests/test_stage.py.
    spec = make_spec(
        stage="shared", rows=rows, cols=cols, width=width, height=height, roughness=roughness, metallic=metallic,
        base_color=base, row_materials=materials, env=fam["env"], env_intensity=fam["env_intensity"],
        lights=lights, shadows=fam["shadows"], ao=fam["ao"], ground=fam["ground"], ibl=fam["ibl"],
        tonemap=d.pick(TONEMAPPERS), exposure=exposure, reinhard_white=d.pick((1e-3, 1.0, 4.0, 1e6)),
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
        "roughness": _edge_hits(spec.axis_values("x"), EDGE_ROUGHNESS),
        "metallic": _edge_hits(spec.axis_values("y"), EDGE_METALLIC),
        "base colour": "presets" if materials else ("grey " + f"{base[0]:g}" if len(set(base)) == 1 else "mixed"),
        "tone map": spec.tonemap, "env": f"{spec.env} x{_bucket_decade(spec.env_intensity)}",
        "brdf": spec.brdf + ("" if spec.multiscatter else " single"), "camera": spec.camera,
        "intersect": fam["intersect"], "spp": str(spec.spp), "quality": spec.quality,
    }
    return Case(index, kind, fam["backend"], spec, labels)


def _monotonic_case(d: _Draw, index: int, fam: dict) -> Case:
    """One row of spheres, orthographic and pixel-aligned (the spacing is a whole number of
    pixels), so the same pixel offset samples the same normal in every column; the light is
    placed so that this normal is exactly the highlight centre (h = n). The probe is a point
    sample: one ray through the pixel's centre (no antialiasing; with it, a sphere under 40 px
    in radius averages n x n points of each pixel's box, plan.sphere_samples, which a narrow
    lobe's peak falls between: 1/9 of it at n = 3, none at n = 2 or 4)."""
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
        stage="shared", rows=1, cols=cols, width=width, height=height, roughness=(lo, hi),
        metallic=(metallic, metallic),
        base_color=(base,) * 3, env="black", lights=(light,), shadows=False, ao=False, ground=False,
        ibl=False, camera="orthographic", camera_azimuth=0.0, camera_elevation=0.0, intersect="analytic",
        spacing=spacing, brdf=fam["brdf"], multiscatter=fam["multiscatter"], quality=fam["quality"],
        hdr_precision=fam["hdr_precision"], backend=fam["backend"].split("-")[0],
        exposure=float(d.rng.uniform(-20, 20)), tonemap=d.pick(TONEMAPPERS), antialias=False, labels=False)
    labels = {"kind": "monotonic", "backend": fam["backend"], "precision": fam["hdr_precision"],
              "roughness": _edge_hits(spec.axis_values("x"), EDGE_ROUGHNESS),
              "metallic": _edge_hits([metallic], EDGE_METALLIC), "base colour": f"grey {base:g}",
              "light intensity": [_bucket_decade(light.intensity)],
              "brdf": spec.brdf + ("" if spec.multiscatter else " single"),
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


@dataclass
class Outcome:
    """What running one case gave: its failed checks, its metrics and its time."""
    case: Case
    failures: list
    metrics: dict = field(default_factory=dict)
    seconds: float = 0.0
