"""An independent path tracer as the bench's peer (``sdfpbr bench --peer mitsuba``): Mitsuba 3
(the 'peer' extra, LLVM backend) renders the bench's scenes with a glTF BSDF written from the
specification (peer_bsdf) in a scene built from the spec (peer_scene), and the bench

* validates sdfpbr's reference against it: per scene and region (sphere upper and lower half,
  silhouette, the floor under the sphere's bulge, the ring 1-1.3 R outside it, the far floor,
  the background), the mean luminance of each, with the noise of each from two seeds of each
  renderer (region_masks, region_stats);
* times it to each preset's error: the samples and wall time the peer needs to reach the error
  a preset has against the converged reference, and the ratio to the preset's draw
  (equal_error).

The peer renders each cell of the cells stage on its own film (one kernel for all: the cells
change only the BSDF's values), with the image's margins seen by the outer cells as sdfpbr
sees them; its noise is independent per pixel and per cell (each cell its own seed). Each
render costs some 45 ms besides its paths here (Mitsuba traces the Python BSDF anew): 1.1 s
for 25 cells, the floor of the peer's time at a few samples.
"""
from __future__ import annotations

import itertools
import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from ...errors import SpecError
from ...image.colour import luminance
from ...spec.chart_spec import ChartSpec
from .regions import REGIONS, region_masks

PEERS = ("mitsuba",)
EXTRA = "peer"
VARIANT = "llvm_ad_rgb"
MIN_LLVM = 16                  # the Dr.Jit LLVM backend's runtime (the issue's measurement: LLVM 19)
NOISE_SIGMAS = 4.0             # a region agrees when |reference - peer| <= this many combined sigmas


# ---- availability --------------------------------------------------------------------------

def peer_problem() -> str | None:
    """Why the peer cannot run here (one line with what to install), or None."""
    try:
        import drjit
        import mitsuba
    except ImportError:
        from ...extras import missing_extra
        return str(missing_extra(EXTRA, "--peer mitsuba"))
    if VARIANT not in mitsuba.variants():
        return f"this Mitsuba build has no {VARIANT} variant (variants: {', '.join(mitsuba.variants())})"
    try:
        mitsuba.set_variant(VARIANT)
        ok = drjit.has_backend(drjit.JitBackend.LLVM)
        version = tuple(drjit.detail.llvm_version()) if ok else ()
    except Exception as exc:  # noqa: BLE001 -- Dr.Jit raises its own types when it finds no LLVM
        ok, version = False, ()
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    else:
        detail = ""
    if not ok or version[:1] < (MIN_LLVM,):
        found = f"found LLVM {'.'.join(map(str, version))}" if version else (detail or "found none")
        return (f"the peer's LLVM backend needs an LLVM >= {MIN_LLVM} runtime ({found}): on Debian, "
                f"apt-get install libllvm19, or point DRJIT_LIBLLVM_PATH at a libLLVM.so")
    return None


def load_mitsuba():
    """Mitsuba with the peer's variant set, or SpecError naming what to install."""
    problem = peer_problem()
    if problem:
        raise SpecError(problem)
    import mitsuba as mi
    mi.set_variant(VARIANT)
    return mi


def check_peer(name: str) -> None:
    """A --peer value: a known peer that can run here, else SpecError (one line)."""
    if name not in PEERS:
        raise SpecError(f"unknown peer {name!r}; allowed: {', '.join(PEERS)}")
    load_mitsuba()


# ---- rendering -----------------------------------------------------------------------------

@dataclass
class PeerRender:
    hdr: np.ndarray        # (H, W, 3) float32 linear radiance, the spec's image layout
    samples: int           # per pixel
    seed: int
    seconds: float         # wall time of the renders (kernels already compiled)
    warmup_seconds: float = 0.0    # an untimed first render of one cell (or the image) at this count, where it compiled


@dataclass
class PeerSession:
    """One spec's Mitsuba scene, built once and rendered at any sample count and seed;
    ``options``: build_scene's keywords."""
    spec: ChartSpec
    max_bounces: int
    options: dict = field(default_factory=dict)
    scene: object = None
    compiled: set = field(default_factory=set)

    def __post_init__(self):
        from .peer_bsdf import albedo_table
        from .peer_scene import build_scene, cell_list
        load_mitsuba()
        self.scene = build_scene(self.spec, self.max_bounces, **self.options)
        for material in cell_list(self.spec):   # every cell's table now, not in a timed render
            albedo_table(material.roughness)

    def render(self, samples: int, seed: int) -> PeerRender:
        """The image at ``samples`` per pixel; cell k of n takes seed ``seed * n + k``."""
        import mitsuba as mi
        peer = self.scene
        spec = peer.spec
        warmup = 0.0
        if samples not in self.compiled:   # Dr.Jit compiles a kernel per sample count: not timed
            start = time.perf_counter()
            mi.render(peer.scene, spp=samples, seed=0)
            warmup = time.perf_counter() - start
            self.compiled.add(samples)
        hdr = np.zeros((spec.height, spec.width, 3), np.float32)
        start = time.perf_counter()
        if not peer.cells:
            hdr[:] = np.asarray(mi.render(peer.scene, spp=samples, seed=seed & 0xFFFFFFFF), np.float32)
        else:
            from .peer_scene import cell_list
            materials = cell_list(spec)
            count = spec.rows * spec.cols
            for index, (row, col) in enumerate(np.ndindex(spec.rows, spec.cols)):
                peer.sphere_bsdfs[0].set(materials[index])
                film = np.asarray(mi.render(peer.scene, spp=samples, seed=(seed * count + index) & 0xFFFFFFFF),
                                  np.float32)
                (y0, y1, x0, x1), (fy, fx) = cell_window(peer, row, col)
                hdr[y0:y1, x0:x1] = film[fy:fy + y1 - y0, fx:fx + x1 - x0]
        seconds = time.perf_counter() - start
        return PeerRender(hdr, samples, seed, seconds, warmup)


def cell_window(peer, row: int, col: int) -> tuple[tuple[int, int, int, int], tuple[int, int]]:
    """Where cell (row, col) lies in the image, its margins included: (y0, y1, x0, x1), and
    the film pixel (fy, fx) of its corner (the film is the cell plus ``pad`` on every side)."""
    from ...shading.plan import reference_plan
    spec = peer.spec
    grid = reference_plan(spec).frame.grid
    x0 = 0 if col == 0 else grid.left + col * grid.cell_width
    x1 = spec.width if col == spec.cols - 1 else grid.left + (col + 1) * grid.cell_width
    y0 = 0 if row == 0 else grid.top + row * grid.cell_height
    y1 = spec.height if row == spec.rows - 1 else grid.top + (row + 1) * grid.cell_height
    fx = peer.pad[0] + x0 - (grid.left + col * grid.cell_width)
    fy = peer.pad[1] + y0 - (grid.top + row * grid.cell_height)
    return (y0, y1, x0, x1), (fy, fx)


def pixel_centre_hits(peer) -> tuple[np.ndarray, np.ndarray]:
    """The peer's camera and geometry at the pixel centres of cell (0, 0) (cells stage) or the
    image: (depth (H, W), inf on a miss; world normal (H, W, 3)), traced by Mitsuba."""
    import drjit as dr
    import mitsuba as mi
    spec = peer.spec
    (y0, y1, x0, x1), (fy, fx) = cell_window(peer, 0, 0) if peer.cells else ((0, spec.height, 0, spec.width), (0, 0))
    h, w = y1 - y0, x1 - x0
    ys, xs = np.mgrid[0:h, 0:w]
    film_w, film_h = peer.film_size
    pos = mi.Point2f(((xs + fx + 0.5) / film_w).ravel().astype(np.float32),
                     ((ys + fy + 0.5) / film_h).ravel().astype(np.float32))
    n = h * w
    rays, _ = peer.sensor.sample_ray(dr.zeros(mi.Float, n), dr.zeros(mi.Float, n), pos, dr.zeros(mi.Point2f, n))
    si = peer.scene.ray_intersect(rays)
    valid = np.asarray(si.is_valid())
    # The distance from the eye (Mitsuba's rays start at the near plane: si.t is short of it).
    distance = np.linalg.norm(np.asarray(si.p, np.float64).T - np.asarray(peer.camera.position, np.float64), axis=-1)
    depth = np.where(valid, distance, np.inf).reshape(h, w)
    normal = np.asarray(si.n).T.reshape(h, w, 3)
    normal[~valid.reshape(h, w)] = 0.0
    return depth, normal


# A float32 hit lies within some 1e-6 of its distance, times the floor's 1 / sin for grazing
# rays (2e-6 seen in a cell, 4e-5 at a shared stage's horizon, 1 / sin = 57); a camera off by
# a tenth of a pixel moves depth by 1e-3 and normals by 1e-2 at 32-pixel cells. Depth
# (relative) and normals (the length of their difference) must agree within:
GEOMETRY_TOL = 1e-4


def geometry_check(spec: ChartSpec, session=None) -> dict:
    """The peer's pixel-centre rays against the chart's AOVs (depth, normal), over cell (0, 0)
    (cells stage) or the image, silhouette pixels aside (a centre ray there grazes the sphere):
    pixels compared, pixels where one hits and the other misses, the largest depth and normal
    differences and whether both are within GEOMETRY_TOL."""
    from ...api import chart
    peer = PeerSession(spec, 1).scene
    depth, normal = pixel_centre_hits(peer)
    aov = chart(spec, aovs=True, session=session).aov
    (y0, y1, x0, x1), _ = cell_window(peer, 0, 0) if peer.cells else ((0, spec.height, 0, spec.width), (0, 0))
    chart_depth, chart_normal = aov["depth"][y0:y1, x0:x1], aov["normal"][y0:y1, x0:x1]
    keep = ~region_masks(spec)["silhouette"][y0:y1, x0:x1]
    hit, chart_hit = np.isfinite(depth), np.isfinite(chart_depth)
    both = keep & hit & chart_hit
    depth_diff = np.abs(depth[both] - chart_depth[both]) / chart_depth[both]
    normal_diff = np.linalg.norm(normal[both] - chart_normal[both].astype(np.float64), axis=-1)
    out = {"pixels": int(both.sum()), "hit_mismatch": int(np.sum(keep & (hit != chart_hit))),
           "depth_rel_max": float(depth_diff.max(initial=0.0)), "normal_max": float(normal_diff.max(initial=0.0))}
    out["ok"] = out["hit_mismatch"] == 0 and max(out["depth_rel_max"], out["normal_max"]) <= GEOMETRY_TOL
    return out


# ---- regions and validation ----------------------------------------------------------------

def region_stats(masks: dict, ref_a, ref_b, peer_a, peer_b) -> dict:
    """Per region: pixels, the mean luminance of each renderer (its two seeds averaged), their
    difference relative to the peer's, its sigma from the two seeds' per-pixel differences
    (independent pixels: a 2-seed mean's variance is (a - b)^2 / 4, per renderer), z and
    whether |z| <= NOISE_SIGMAS; and ``pixel_ratio``, the pixels' squared differences over
    their noise so estimated, summed: about 1 where the two images differ by noise alone, pixel
    by pixel (a region's mean can agree while its pixels do not, as in a turned environment
    whose light is spread alike)."""
    la, lb, pa, pb = (luminance(x) for x in (ref_a, ref_b, peer_a, peer_b))
    out = {}
    for name in REGIONS:
        m = masks.get(name)
        n = int(m.sum()) if m is not None else 0
        if n < 2:
            continue
        ref = 0.5 * (la[m] + lb[m])
        peer = 0.5 * (pa[m] + pb[m])
        noise = ((la[m] - lb[m]) ** 2 + (pa[m] - pb[m]) ** 2) / 4.0
        diff = float(ref.mean() - peer.mean())
        sigma = math.sqrt(float(noise.sum())) / n
        scale = abs(float(peer.mean())) or 1.0
        total = float(noise.sum())
        out[name] = {"pixels": n, "reference": float(ref.mean()), "peer": float(peer.mean()),
                     "rel_diff": diff / scale, "rel_sigma": sigma / scale,
                     "z": diff / sigma if sigma > 0 else (0.0 if diff == 0 else math.inf),
                     "within": bool(abs(diff) <= NOISE_SIGMAS * sigma),
                     "pixel_ratio": float(np.sum((ref - peer) ** 2)) / total if total > 0 else math.nan}
    return out


# ---- time to equal error -------------------------------------------------------------------

def ladder(samples: int) -> list[int]:
    """The sample counts the peer is timed at: 1, 4, 16, ... up to ``samples`` (included)."""
    out, n = [], 1
    while n < samples:
        out.append(n)
        n *= 4
    return out + [samples]


def equal_error(target: float, curve: list[dict], key: str = "flip_mean") -> dict:
    """The peer's samples and seconds at error ``target``, from its curve (rows of samples,
    seconds, error), log-log interpolated between the rungs around it; past the last rung
    extrapolated along the last two (``extrapolated``); below the first rung's error, the first
    rung (``at_most``)."""
    pts = [(c["samples"], c["seconds"], c[key]) for c in curve if c.get(key) is not None and c[key] > 0]
    if not pts or not (target > 0):
        return {"samples": None, "seconds": None}
    if target >= pts[0][2]:
        return {"samples": pts[0][0], "seconds": pts[0][1], "at_most": True}
    for (n0, t0, e0), (n1, t1, e1) in itertools.pairwise(pts):
        if e1 <= target <= e0 and e0 > e1:
            f = math.log(e0 / target) / math.log(e0 / e1)
            return {"samples": n0 * (n1 / n0) ** f, "seconds": t0 * (t1 / t0) ** f}
    if len(pts) >= 2 and pts[-1][2] < pts[-2][2]:
        (n0, t0, e0), (n1, t1, e1) = pts[-2], pts[-1]
        f = math.log(e0 / target) / math.log(e0 / e1)
        return {"samples": n0 * (n1 / n0) ** f, "seconds": t0 * (t1 / t0) ** f, "extrapolated": True}
    return {"samples": None, "seconds": None, "unreached": True}


def display_image(session, spec: ChartSpec, hdr: np.ndarray) -> np.ndarray:
    """``hdr`` (H, W, 3) through the chart's display program, as the reference's image is made:
    (H, W, 4) uint8."""
    from ...gpu.frame import display_pass
    from ...shading.plan import reference_plan
    plan = reference_plan(spec)
    ctx = session.ctx
    h, w = hdr.shape[:2]
    rgba = np.concatenate([hdr, np.ones((h, w, 1), np.float32)], axis=-1)
    with session:
        tex = ctx.texture((w, h), 4, np.ascontiguousarray(rgba[::-1], np.float32).tobytes(), dtype="f4")
        try:
            return display_pass(ctx, session.programs.fragment(plan.display), tex, plan.frame, w, h).copy()
        finally:
            tex.release()


def error_figures(session, spec: ChartSpec, hdr: np.ndarray, ref) -> dict:
    """The bench's error figures of an image ``hdr`` against a reference (accuracy.Reference)."""
    from ...image import metrics
    mask = (ref.row >= 0) & (ref.col >= 0)
    flip, _ = metrics.flip_ldr(display_image(session, spec, hdr), ref.image)
    return {"flip_mean": float(flip),
            "rel_rmse": metrics.rel_rmse(hdr, ref.hdr, mask=mask if mask.any() else None)}


# ---- the bench's peer section --------------------------------------------------------------

def peer_report(cfg, report: dict, samples: int | None = None, log=None) -> dict:
    """The peer's section of a bench report: per scene, the validation (regions) and the
    time-to-equal-error of each preset row of ``report`` against the scene's reference."""
    from ...features.reference import DEFAULT_MAX_BOUNCES
    from ...gpu.session import default_session
    from .accuracy import get_reference
    from .peer_scene import not_comparable
    from .suite import scene_spec
    log = log or (lambda line: None)
    load_mitsuba()
    samples = samples or cfg.ref_samples
    session = default_session(cfg.backend, 0)
    scenes = []
    for scene in cfg.scenes:
        spec = scene_spec(scene, cfg)
        why = not_comparable(spec)
        if why:
            scenes.append({"scene": scene, "comparable": False, "reason": why})
            log(f"peer: {scene}: not comparable ({why})")
            continue
        ref_a = get_reference(session, spec, cfg.ref_samples, cfg.seed, log)
        ref_b = get_reference(session, spec, cfg.ref_samples, cfg.seed + 1, log)
        peer = PeerSession(spec, DEFAULT_MAX_BOUNCES)
        curve, renders = [], {}
        for n in ladder(samples):
            log(f"peer: {scene}: {n} samples/pixel ...")
            render = peer.render(n, cfg.seed)
            renders[n] = render
            curve.append({"samples": n, "seconds": render.seconds, "warmup_seconds": render.warmup_seconds,
                          **error_figures(session, spec, render.hdr, ref_a)})
        other = peer.render(samples, cfg.seed + 1)
        regions = region_stats(region_masks(spec), ref_a.hdr, ref_b.hdr, renders[samples].hdr, other.hdr)
        rows = []
        for row in report.get("rows", []):
            if row.get("scene") != scene or row.get("flip_mean") is None or not row.get("render_ms"):
                continue
            reach = equal_error(row["flip_mean"], curve)
            ratio = reach["seconds"] / (row["render_ms"] / 1000.0) if reach.get("seconds") else None
            rows.append({"preset": row["preset"], "flip_mean": row["flip_mean"], "render_ms": row["render_ms"],
                         "ref_judges": row.get("ref_judges"),
                         "peer_samples": reach.get("samples"), "peer_seconds": reach.get("seconds"),
                         "ratio": ratio, **{k: v for k, v in reach.items() if k not in ("samples", "seconds")}})
        scenes.append({"scene": scene, "comparable": True, "reference_samples": cfg.ref_samples,
                       "peer_samples": samples, "regions": regions,
                       "agrees": all(r["within"] for r in regions.values()), "curve": curve, "presets": rows})
        log(f"peer: {scene}: " + ("the reference agrees with the peer in every region" if scenes[-1]["agrees"]
                                  else "REGIONS DISAGREE: "
                                       + ", ".join(k for k, r in regions.items() if not r["within"])))
    import mitsuba
    return {"peer": "mitsuba", "version": mitsuba.__version__, "variant": VARIANT,
            "threads": os.cpu_count(), "noise_sigmas": NOISE_SIGMAS, "scenes": scenes}


def format_peer(section: dict) -> str:
    """The peer's tables: the validation per scene and region, then time to equal error."""
    lines = [(f"peer: Mitsuba {section['version']} ({section['variant']}); a region agrees when "
              f"|reference - peer| <= {section['noise_sigmas']:g} sigma of the two seeds' noise"), "",
             (f"{'scene':<10} {'region':<13} {'px':>6} {'reference':>10} {'peer':>10} {'diff %':>8} "
              f"{'sigma %':>8} {'z':>6}")]
    for s in section["scenes"]:
        if not s["comparable"]:
            lines.append(f"{s['scene']:<10} not comparable: {s['reason']}")
            continue
        for name, r in s["regions"].items():
            lines.append(f"{s['scene']:<10} {name:<13} {r['pixels']:>6} {r['reference']:>10.5f} {r['peer']:>10.5f} "
                         f"{100 * r['rel_diff']:>8.3f} {100 * r['rel_sigma']:>8.3f} {r['z']:>6.2f}"
                         + ("" if r["within"] else "  OUTSIDE NOISE"))
    lines += ["", (f"{'scene':<10} {'preset':<10} {'FLIP':>7} {'draw ms':>9} {'peer spp':>9} {'peer s':>9} "
                   f"{'ratio':>9}")]
    for s in section["scenes"]:
        for r in s.get("presets", []):
            spp = "-" if r["peer_samples"] is None else f"{r['peer_samples']:.3g}"
            secs = "-" if r["peer_seconds"] is None else f"{r['peer_seconds']:.3g}"
            ratio = "-" if r["ratio"] is None else f"{r['ratio']:.3g}"
            note = "  (at most: the peer's 1 spp is already as close)" if r.get("at_most") else \
                "  (extrapolated past the peer's samples)" if r.get("extrapolated") else \
                "  (the peer's curve does not reach it)" if r.get("unreached") else ""
            if r.get("ref_judges") is False:   # the preset's FLIP is mostly the reference's own noise
                note += "  (reference too noisy to judge the preset)"
            lines.append(f"{s['scene']:<10} {r['preset']:<10} {r['flip_mean']:>7.4f} {r['render_ms']:>9.1f} "
                         f"{spp:>9} {secs:>9} {ratio:>9}{note}")
    return "\n".join(lines)
