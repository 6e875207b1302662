"""The random-scene accuracy suite (``sdfpbr bench --random N --seed S``): the chart judged on
scenes drawn from what users chart, not on the bench's hand-picked scenes.

Each scene is one sphere on its floor (one cell of the cells stage, or with ``stage="shared"``
the shared stage's one-sphere grid), drawn by ``draw_scenes``
from the distribution below. For each, the path-traced reference is rendered with two seeds,
with more samples until its noise can judge the targets; every preset is then measured per
region (mean luminance of the chart over the reference's, minus 1) and by LDR FLIP.

The distribution (probabilities per scene; every draw comes from one seeded generator):

======================  ========================================================================
environment             studio preset 0.2, sky preset 0.15, uniform 0.05, a random smooth
                        analytic sky 0.35, the same with a sun disc 0.25 (radius 1-4 degrees,
                        10-1000 times the sky's zenith radiance: high contrast)
lights                  none 0.5 (sky only), one 0.3, two or three 0.2; each directional 0.7
                        (elevation 10-80 degrees, angular radius 0.25-8 degrees) or point 0.3
                        (3-10 radii away, radius 0-0.5 R); illuminance 0.5-4
sphere roughness        0 (polished) 0.15, 0.02-0.1 0.1, else uniform 0-1
sphere metallic         0 0.35, 1 0.35, else uniform 0-1
base colour             white 0.15, near-black 0.1, else a random hue, saturation 0-0.9,
                        value 0.15-1 (linear)
KHR lobes               none 0.7, else one of clearcoat, sheen, ior, specular
alpha                   1 0.9, else 0.3-0.9 (blend)
floor colour            white 0.2, near-black 0.1, else grey or tinted 0.1-0.6
floor roughness         near-mirror (0.02-0.1) 0.15, else 0.2-1
======================  ========================================================================

Regions (``regions.region_masks``, shared with the peer renderer's check): the sphere's upper
and lower half, its silhouette pixels, the floor under the bulge (closer than R to the sphere's
axis), the ring just outside it (R to 1.3 R), the far floor and the background.
"""
from __future__ import annotations

import colorsys
import hashlib
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...spec.chart_spec import ChartSpec, Light, make_spec
from ...image.colour import luminance
from ...spec.presets import QUALITY_LEVELS
from .regions import REGIONS, region_masks

REGION_MIN_PIXELS = 12    # a region with fewer pixels is not judged (too small to mean anything)

# What the suite checks, per preset: the 95th percentile and the worst over scenes of a scene's
# largest region |bias|, and the mean LDR FLIP over the scenes whose reference can judge it.
TARGETS = {
    "high": {"bias_p95": 0.01, "bias_worst": 0.02, "flip": 0.012},
    "default": {"bias_p95": 0.03, "bias_worst": 0.06, "flip": 0.022},
}
# A reference judges a figure only when its noise is at most this share of it.
NOISE_SHARE = 1.0 / 3.0
ENV_SIZE = (256, 512)     # the random skies' texels (height, width): 0.7 degrees a texel


@dataclass
class RandomScene:
    name: str
    fields: dict                     # make_spec overrides (the env as a file once written)
    env: np.ndarray | None = None    # a random sky, written by env_file
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        return "; ".join(self.notes)


# ---- the distribution ---------------------------------------------------------------------------

def _pick(rng, weights: dict):
    names = list(weights)
    p = np.array([weights[n] for n in names], float)
    return names[rng.choice(len(names), p=p / p.sum())]


def _unit_from(elevation_deg: float, azimuth_deg: float) -> tuple[float, float, float]:
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    return (float(np.cos(e) * np.sin(a)), float(np.sin(e)), float(np.cos(e) * np.cos(a)))


def random_sky(rng, sun: bool) -> tuple[np.ndarray, str]:
    """A smooth analytic sky as an equirect map (row 0 at the zenith): a zenith-to-horizon
    gradient, a brighter side toward a random azimuth, a ground below the horizon, and with
    ``sun`` a disc with a soft edge."""
    h, w = ENV_SIZE
    theta = (np.arange(h) + 0.5) / h * np.pi                     # from the zenith
    phi = ((np.arange(w) + 0.5) / w - 0.5) * 2 * np.pi          # env.glsl: atan(d.x, -d.z)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = np.stack([st * np.sin(phi)[None, :], np.broadcast_to(ct, (h, w)), -st * np.cos(phi)[None, :]], -1)
    zenith = rng.uniform(0.2, 1.0, 3) * rng.uniform(0.3, 1.5)
    horizon = rng.uniform(0.4, 1.0, 3) * rng.uniform(0.5, 2.0)
    ground = rng.uniform(0.05, 0.6, 3) * rng.uniform(0.1, 0.6)
    up = np.clip(d[..., 1], 0.0, 1.0)[..., None]
    sky = horizon + (zenith - horizon) * np.sqrt(up)
    toward = np.array(_unit_from(0.0, rng.uniform(0, 360)))
    side = 1.0 + rng.uniform(0.0, 1.5) * np.clip(d @ toward, 0.0, 1.0) ** 2
    below = np.clip(-d[..., 1], 0.0, 1.0)[..., None]
    img = np.where(d[..., 1:2] >= 0, sky * side[..., None], ground + (horizon - ground) * np.exp(-8.0 * below))
    note = "random sky"
    if sun:
        radius = np.radians(rng.uniform(1.0, 4.0))
        elev, azim = rng.uniform(8.0, 75.0), rng.uniform(0.0, 360.0)
        s = np.array(_unit_from(elev, azim))
        angle = np.arccos(np.clip(d @ s, -1.0, 1.0))
        edge = np.clip((radius - angle) / (0.25 * radius) + 0.5, 0.0, 1.0)   # a soft quarter-radius rim
        contrast = float(10 ** rng.uniform(1.0, 3.0))
        img = img + edge[..., None] * (contrast * float(zenith.mean())) * rng.uniform(0.8, 1.0, 3)
        note = f"random sky, sun {np.degrees(radius):.1f} deg at {elev:.0f} deg, x{contrast:.0f}"
    return img.astype(np.float32), note


def _lights(rng) -> tuple[tuple[Light, ...], str]:
    count = _pick(rng, {0: 0.5, 1: 0.3, 2: 0.1, 3: 0.1})
    out, notes = [], []
    for _ in range(count):
        color = tuple(float(c) for c in rng.uniform(0.7, 1.0, 3))
        e = float(rng.uniform(0.5, 4.0))
        elev, azim = rng.uniform(10.0, 80.0), rng.uniform(0.0, 360.0)
        if rng.random() < 0.7:
            radius = float(rng.uniform(0.25, 8.0))
            out.append(Light("directional", direction=_unit_from(elev, azim), color=color, intensity=e,
                             angular_radius_deg=radius))
            notes.append(f"sun {radius:.1f} deg")
        else:
            dist = float(rng.uniform(3.0, 10.0))
            pos = tuple(dist * c for c in _unit_from(elev, azim))
            out.append(Light("point", position=pos, color=color, intensity=e * dist * dist,
                             radius=float(rng.uniform(0.0, 0.5)), range=1000.0))
            notes.append("point light")
    return tuple(out), (", ".join(notes) if notes else "no lights")


def _color(rng, white: float, black: float, lo: float, hi: float) -> tuple[tuple[float, float, float], str]:
    kind = _pick(rng, {"white": white, "black": black, "color": 1.0 - white - black})
    if kind == "white":
        v = float(rng.uniform(0.85, 1.0))
        return (v, v, v), "white"
    if kind == "black":
        v = float(rng.uniform(0.01, 0.04))
        return (v, v, v), "near-black"
    rgb = colorsys.hsv_to_rgb(rng.uniform(0, 1), rng.uniform(0, 0.9), rng.uniform(lo, hi))
    return tuple(float(c) for c in rgb), "colour"


def draw_scene(rng, index: int) -> RandomScene:
    f: dict = {}
    notes = []
    env = None
    kind = _pick(rng, {"studio": 0.2, "sky": 0.15, "uniform": 0.05, "analytic": 0.35, "analytic-sun": 0.25})
    if kind in ("studio", "sky", "uniform"):
        f["env"] = kind
        notes.append(f"env {kind}")
    else:
        env, note = random_sky(rng, sun=kind == "analytic-sun")
        notes.append(note)
    lights, note = _lights(rng)
    f["lights"] = lights if lights else "none"
    notes.append(note)
    u = rng.random()
    rough = 0.0 if u < 0.15 else float(rng.uniform(0.02, 0.1)) if u < 0.25 else float(rng.uniform(0.0, 1.0))
    u = rng.random()
    metal = 0.0 if u < 0.35 else 1.0 if u < 0.7 else float(rng.uniform(0.0, 1.0))
    f["roughness"], f["metallic"] = rough, metal
    f["base_color"], cnote = _color(rng, 0.15, 0.1, 0.15, 1.0)
    notes.append(f"sphere r {rough:.2f} m {metal:.2f} {cnote}")
    lobe = _pick(rng, {"none": 0.7, "clearcoat": 0.075, "sheen": 0.075, "ior": 0.075, "specular": 0.075})
    if lobe == "clearcoat":
        f["clearcoat"], f["clearcoat_roughness"] = float(rng.uniform(0.3, 1.0)), float(rng.uniform(0.0, 0.5))
    elif lobe == "sheen":
        f["sheen_color"] = tuple(float(c) for c in rng.uniform(0.2, 1.0, 3))
        f["sheen_roughness"] = float(rng.uniform(0.2, 1.0))
    elif lobe == "ior":
        f["ior"] = float(rng.uniform(1.2, 2.5))
    elif lobe == "specular":
        f["specular"] = float(rng.uniform(0.0, 1.0))
        f["specular_color"] = tuple(float(c) for c in rng.uniform(0.5, 1.0, 3))
    if lobe != "none":
        notes.append(lobe)
    if rng.random() < 0.1:
        f["alpha"] = float(rng.uniform(0.3, 0.9))
        notes.append(f"alpha {f['alpha']:.2f}")
    f["ground_color"], gnote = _color(rng, 0.2, 0.1, 0.1, 0.6)
    f["ground_roughness"] = float(rng.uniform(0.02, 0.1)) if rng.random() < 0.15 else float(rng.uniform(0.2, 1.0))
    notes.append(f"floor {gnote} r {f['ground_roughness']:.2f}")
    return RandomScene(f"random-{index:03d}", f, env, notes)


def draw_scenes(count: int, seed: int) -> list[RandomScene]:
    """``count`` scenes from one generator seeded with ``seed``: the same seed, the same scenes,
    and the first k scenes of a longer run are the scenes of a run of k."""
    rng = np.random.default_rng([0x5DF, int(seed)])
    return [draw_scene(rng, i) for i in range(count)]


def env_dir() -> Path:
    """Where the random skies are written: a stable folder, so a scene's spec (which names its
    sky's file) and the references cached under it stay the same from run to run."""
    return Path(tempfile.gettempdir()) / f"sdfpbr-random-skies-{os.getuid() if hasattr(os, 'getuid') else 0}"


def env_file(env: np.ndarray) -> str:
    """The sky written as .npy, named by its content."""
    folder = env_dir()
    folder.mkdir(parents=True, exist_ok=True)
    data = np.ascontiguousarray(env, np.float32)
    path = folder / f"{hashlib.sha256(data.tobytes()).hexdigest()[:24]}.npy"
    if not path.is_file():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            np.save(fh, data)
        os.replace(tmp, path)
    return str(path)


def scene_spec(scene: RandomScene, size: tuple[int, int], preset: str, backend: str = "auto",
               stage: str = "cells") -> ChartSpec:
    """One sphere at the origin on its floor (y = -R) on either stage: the shared stage's one-
    sphere grid is the same scene through that stage's transport and camera."""
    fields = dict(scene.fields)
    if scene.env is not None:
        fields["env"] = env_file(scene.env)
    return make_spec(width=size[0], height=size[1], rows=1, cols=1, stage=stage, cell_borders=False,
                     quality=preset, backend=backend, **fields)


# ---- regions ----------------------------------------------------------------------------------

def region_means(hdr: np.ndarray, masks: dict) -> dict[str, float | None]:
    lum = luminance(hdr)
    return {k: (float(lum[m].mean()) if m.sum() >= REGION_MIN_PIXELS else None) for k, m in masks.items()}


def region_noise(a: dict, b: dict) -> dict[str, float | None]:
    """The two-seed noise of each region's mean: |a - b| over their mean."""
    out = {}
    for k in a:
        if a[k] is None or b[k] is None or a[k] + b[k] <= 0:
            out[k] = None
        else:
            out[k] = abs(a[k] - b[k]) / (0.5 * (a[k] + b[k]))
    return out


def bias_map(chart_hdr: np.ndarray, ref_hdr: np.ndarray) -> np.ndarray:
    """Per pixel, the chart's luminance over the reference's, minus 1 (NaN where the reference
    is black)."""
    c, r = luminance(chart_hdr), luminance(ref_hdr)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 1e-6, c / r - 1.0, np.nan)


# ---- the run ------------------------------------------------------------------------------------

@dataclass
class RandomConfig:
    count: int = 50
    seed: int = 1
    presets: tuple[str, ...] = QUALITY_LEVELS
    size: tuple[int, int] = (128, 128)
    ref_samples: int = 1024          # the first reference samples a seed; four times more while too noisy
    max_ref_samples: int = 4096         # 2 x 4096 spp at 128²: about 1 min on 2 idle cores
    backend: str = "auto"
    stage: str = "cells"
    heatmaps: str | None = None      # a folder for the worst scene's FLIP and bias maps
    log: object = None
    on_scene: object = None          # called with the report so far after each scene (a long run's partial JSON)


def needed_noise(biases: list[float | None], presets: list[str]) -> float | None:
    """The most noise a region's reference may have to judge the presets' biases there: a third
    of the smaller of each preset's |bias| and its target (a bias far above its target needs
    less precision to be called a miss)."""
    need = []
    for b, p in zip(biases, presets):
        if b is None:
            continue
        target = TARGETS.get(p, {}).get("bias_p95")
        need.append(NOISE_SHARE * (max(abs(b), target) if target is not None else abs(b)))
    return min(need) if need else None


def _judge_regions(chart_means: dict[str, dict], ref_means: dict, noise: dict, presets) -> dict[str, bool]:
    out = {}
    for k in REGIONS:
        if ref_means.get(k) is None or noise.get(k) is None:
            out[k] = False
            continue
        biases = [chart_means[p][k] / ref_means[k] - 1.0 if ref_means[k] > 0 else None for p in presets]
        need = needed_noise(biases, list(presets))
        out[k] = need is not None and noise[k] <= need
    return out


def run_scene(session, scene: RandomScene, cfg: RandomConfig, log) -> dict:
    from ...image.metrics import flip_ldr
    from .accuracy import get_reference
    specs = {p: scene_spec(scene, cfg.size, p, cfg.backend, cfg.stage) for p in cfg.presets}
    ref_spec = scene_spec(scene, cfg.size, "default", cfg.backend, cfg.stage)
    masks = region_masks(ref_spec)
    charts = {p: session.render(specs[p], aovs=False) for p in cfg.presets}
    chart_means = {p: region_means(charts[p].hdr, masks) for p in cfg.presets}
    samples = cfg.ref_samples
    while True:
        a = get_reference(session, ref_spec, samples, 0, log)
        b = get_reference(session, ref_spec, samples, 1, log)
        ma, mb = region_means(a.hdr, masks), region_means(b.hdr, masks)
        ref_hdr = 0.5 * (a.hdr.astype(np.float64) + b.hdr)
        ref_means = region_means(ref_hdr, masks)
        noise = region_noise(ma, mb)
        judged = _judge_regions(chart_means, ref_means, noise, cfg.presets)
        if all(judged[k] or ref_means[k] is None for k in REGIONS) or samples * 4 > cfg.max_ref_samples:
            break
        samples *= 4
    flip_noise = flip_ldr(a.image, b.image)[0]
    rows = {}
    for p in cfg.presets:
        bias = {k: (chart_means[p][k] / ref_means[k] - 1.0 if ref_means[k] else None) for k in REGIONS}
        flip = flip_ldr(charts[p].image, a.image)[0]
        rows[p] = {"bias": bias, "flip": flip, "flip_judged": bool(flip_noise <= NOISE_SHARE * max(
            flip, TARGETS.get(p, {}).get("flip", 0.0)))}
    return {"scene": scene.name, "summary": scene.summary(), "fields": _plain(scene.fields),
            "ref_samples": samples, "ref_seconds": a.seconds + b.seconds, "flip_noise": flip_noise,
            "region_pixels": {k: int(m.sum()) for k, m in masks.items()},
            "region_noise": noise, "region_judged": judged, "presets": rows,
            "_images": (charts, a, ref_hdr)}


def _plain(v):
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (tuple, list)):
        return [_plain(x) for x in v]
    if isinstance(v, Light):
        return {k: _plain(x) for k, x in vars(v).items()}
    return v


def worst_region(row: dict, preset: str) -> tuple[str | None, float | None]:
    """The judged region with the largest |bias| of one scene's preset."""
    best = (None, None)
    for k, b in row["presets"][preset]["bias"].items():
        if b is None or not row["region_judged"][k]:
            continue
        if best[1] is None or abs(b) > abs(best[1]):
            best = (k, b)
    return best


def summarize(rows: list[dict], presets) -> dict:
    out = {}
    for p in presets:
        worst = [(abs(worst_region(r, p)[1]) if worst_region(r, p)[1] is not None else None, r) for r in rows]
        judged = [(w, r) for w, r in worst if w is not None]
        values = np.array([w for w, _ in judged]) if judged else np.array([])
        flips = np.array([r["presets"][p]["flip"] for r in rows])
        flip_judged = [r["presets"][p]["flip"] for r in rows if r["presets"][p]["flip_judged"]]
        s = {"scenes": len(rows), "scenes_judged": len(judged),
             "bias_median": float(np.median(values)) if len(values) else None,
             "bias_p95": float(np.percentile(values, 95)) if len(values) else None,
             "bias_worst": float(values.max()) if len(values) else None,
             "flip_median": float(np.median(flips)) if len(flips) else None,
             "flip_p95": float(np.percentile(flips, 95)) if len(flips) else None,
             "flip_worst": float(flips.max()) if len(flips) else None,
             "flip_judged_scenes": len(flip_judged),
             "flip_judged_mean": float(np.mean(flip_judged)) if flip_judged else None,
             "per_region_p95": {}}
        for k in REGIONS:
            v = [abs(r["presets"][p]["bias"][k]) for r in rows
                 if r["presets"][p]["bias"][k] is not None and r["region_judged"][k]]
            s["per_region_p95"][k] = float(np.percentile(v, 95)) if v else None
        if judged:
            w, r = max(judged, key=lambda t: t[0])
            region, bias = worst_region(r, p)
            s["worst_scene"] = {"scene": r["scene"], "region": region, "bias": bias, "summary": r["summary"],
                                "flip": r["presets"][p]["flip"]}
        target = TARGETS.get(p)
        if target:
            s["targets"] = target
            s["met"] = {
                "bias_p95": s["bias_p95"] is not None and s["bias_p95"] <= target["bias_p95"],
                "bias_worst": s["bias_worst"] is not None and s["bias_worst"] <= target["bias_worst"],
                "flip": s["flip_judged_mean"] is not None and s["flip_judged_mean"] <= target["flip"]
                        and s["flip_judged_scenes"] >= 8,
            }
        out[p] = s
    return out


def write_maps(folder: Path, row: dict, presets) -> list[Path]:
    """The FLIP and bias maps of one scene, per preset, and the scene's reference."""
    from ...image.io import write_png
    from ...image.metrics import flip_ldr, heatmap_image
    charts, ref, ref_hdr = row["_images"]
    folder.mkdir(parents=True, exist_ok=True)
    zoom = max(1, 384 // max(ref.image.shape[:2]))    # small cells drawn large enough to read

    def big(a):
        return np.repeat(np.repeat(a, zoom, axis=0), zoom, axis=1)

    paths = []
    for p in presets:
        flip_mean, flip_map = flip_ldr(charts[p].image, ref.image)
        path = folder / f"flip_{row['scene']}_{p}.png"
        write_png(path, heatmap_image(big(flip_map), title=f"{row['scene']} / {p}: LDR FLIP, mean {flip_mean:.4f}"))
        paths.append(path)
        path = folder / f"bias_{row['scene']}_{p}.png"
        write_png(path, heatmap_image(big(bias_map(charts[p].hdr, ref_hdr)), title=f"{row['scene']} / {p}: "
                                      "luminance / reference - 1", vmin=-0.1, vmax=0.1, colormap="coolwarm"))
        paths.append(path)
        path = folder / f"chart_{row['scene']}_{p}.png"
        write_png(path, big(charts[p].image))
        paths.append(path)
    path = folder / f"reference_{row['scene']}.png"
    write_png(path, big(ref.image))
    return paths + [path]


def run_random(cfg: RandomConfig) -> dict:
    """Draw cfg.count scenes and judge every preset on each; returns {machine, settings, scenes,
    summary}."""
    import time

    from ...gpu.session import default_session
    log = cfg.log or (lambda line: None)
    session = default_session(cfg.backend, 0)
    rows = []
    start = time.perf_counter()
    for i, scene in enumerate(draw_scenes(cfg.count, cfg.seed)):
        log(f"[{i + 1}/{cfg.count}] {scene.name}: {scene.summary()}")
        row = run_scene(session, scene, cfg, None)
        rows.append(row)
        log("  " + "  ".join(f"{p} worst {_fmt_bias(worst_region(row, p))} FLIP {row['presets'][p]['flip']:.4f}"
                             for p in cfg.presets)
            + f"  (reference {row['ref_samples']} spp x 2, {time.perf_counter() - start:.0f} s so far)")
        if cfg.on_scene:
            cfg.on_scene(_report(session, cfg, rows, complete=False))
    report = _report(session, cfg, rows, complete=True)
    if cfg.heatmaps:
        for p in cfg.presets:
            worst = report["summary"][p].get("worst_scene")
            if worst:
                row = next(r for r in rows if r["scene"] == worst["scene"])
                write_maps(Path(cfg.heatmaps), row, cfg.presets)
    for r in rows:
        r.pop("_images")
    return report


def _report(session, cfg: RandomConfig, rows: list[dict], complete: bool) -> dict:
    from .run import machine_info
    settings = {k: v for k, v in vars(cfg).items() if k not in ("log", "on_scene")}
    scenes = [{k: v for k, v in r.items() if k != "_images"} for r in rows]
    return {"machine": machine_info(session), "settings": settings, "complete": complete,
            "scenes": scenes, "summary": summarize(rows, cfg.presets)}


def _fmt_bias(region_bias) -> str:
    region, bias = region_bias
    return "-" if bias is None else f"{bias * 100:+.1f}% ({region})"


def format_random(report: dict) -> str:
    """The distribution table, the targets beside it."""
    s = report["summary"]
    lines = [f"random scenes: {len(report['scenes'])} of {report['settings']['count']} "
             f"(seed {report['settings']['seed']}), "
             f"{report['settings']['size'][0]}x{report['settings']['size'][1]}, one sphere each, "
             f"{report['settings']['stage']} stage",
             "",
             "largest |bias| of a scene's regions (mean luminance / reference - 1), over scenes:",
             f"{'preset':10s} {'median':>8s} {'95th':>8s} {'worst':>8s}   {'target 95th / worst':>20s}  met",]
    for p, v in s.items():
        t = v.get("targets")
        tt = f"{t['bias_p95'] * 100:.0f}% / {t['bias_worst'] * 100:.0f}%" if t else "-"
        met = ("yes" if v["met"]["bias_p95"] and v["met"]["bias_worst"] else "no") if t else ""
        lines.append(f"{p:10s} {_pct(v['bias_median'])} {_pct(v['bias_p95'])} {_pct(v['bias_worst'])}"
                     f"   {tt:>20s}  {met}")
    lines += ["", "LDR FLIP over scenes (judged: scenes whose reference noise is at most a third of it):",
              f"{'preset':10s} {'median':>8s} {'95th':>8s} {'worst':>8s} {'judged':>7s} {'mean':>8s}   target  met"]
    for p, v in s.items():
        t = v.get("targets")
        lines.append(f"{p:10s} {_num(v['flip_median'])} {_num(v['flip_p95'])} {_num(v['flip_worst'])} "
                     f"{v['flip_judged_scenes']:7d} {_num(v['flip_judged_mean'])}   "
                     + (f"{t['flip']:.3f}  {'yes' if v['met']['flip'] else 'no'}" if t else "-"))
    lines += ["", "95th percentile |bias| per region:",
              f"{'preset':10s} " + " ".join(f"{k:>13s}" for k in REGIONS)]
    for p, v in s.items():
        lines.append(f"{p:10s} " + " ".join(f"{_pct(v['per_region_p95'][k]):>13s}" for k in REGIONS))
    lines.append("")
    for p, v in s.items():
        w = v.get("worst_scene")
        if w:
            lines.append(f"worst at {p}: {w['scene']} {w['region']} {w['bias'] * 100:+.1f}%, FLIP {w['flip']:.4f} "
                         f"({w['summary']})")
    return "\n".join(lines)


def _pct(v) -> str:
    return f"{'-':>8s}" if v is None else f"{v * 100:7.2f}%"


def _num(v) -> str:
    return f"{'-':>8s}" if v is None else f"{v:8.4f}"
