"""The bench's scenes as a Mitsuba 3 scene: what the peer path tracer renders.

Geometry: the cells stage's one sphere of radius R at the origin on its own floor y = -R, seen
by the cell's camera (every cell alike; each cell's material set in turn), or the shared
stage's grid over one floor. The floor is a square 2 FLOOR_EXTENT R wide (floor_pieces): past
it a ray would see the environment below the horizon where sdfpbr's infinite floor stands, a
strip under the horizon of (camera height) / FLOOR_EXTENT rad (at 1e4 R it took 0.3 % off the
shared stage's far floor at 160 px, pixels at the horizon seeing sky).

Environment, lat-long conversion. sdfpbr reads its map at u = atan2(x, -z) / 2 pi + 1/2,
v = acos(y) / pi, texel (i, j) centred on ((i + 0.5) / W, (j + 0.5) / H), bilinear, u wrapping,
v clamped to the edge rows (env.glsl, a GL_LINEAR texture). Mitsuba's envmap reads
u = atan2(x, -z) / 2 pi (mod 1), v = acos(y) / pi, bilinear between knots at u = (i + 0.5) / W,
v = j / (H - 1) (envmap.cpp, 3.9; peer tests probe it). Its to_world = diag(-1, 1, -1), a half
turn about y, maps (x, z) to (-x, -z), which turns atan2 by pi: Mitsuba's u then equals
sdfpbr's exactly. A map file of W x H texels becomes a W x (2H + 1) envmap: the odd knots
j = 2k + 1 (v = (k + 0.5) / H) take texel row k, the even ones the mean of the rows beside
them (row 0 and row H - 1 at the poles, where GL clamps). Every knot of sdfpbr's bilinear
surface is then a knot of Mitsuba's, and between knots both are the same bilinear function:
the two maps agree everywhere, up to the precision of GL's filter weights (the reference's
view of a map file read 2e-5 under the peer's: tests/test_peer.py). The procedural environments
(env.glsl, written out below once for numpy and Dr.Jit) are evaluated exactly by the emitter; an
envmap of their values at PROCEDURAL_MAP knots only steers its sampling (its bilinear values took
0.02 % off the shared stage's sky at 160 px: outside the noise).

Lights, as sdfpbr's reference has them: a directional light of angular radius theta > 0 is a
disc of radiance E / (pi sin^2 theta) around its direction, seen by every ray (camera rays
too) and sampled uniformly in its cone; Mitsuba evaluates one environment emitter per scene,
so the discs join the environment map in one emitter (a mixture in sampling). theta = 0 is
Mitsuba's directional emitter. A point light of radius 0 is a point with sdfpbr's range
window, I w(d)^2 / d^2; one of radius > 0 (a sphere seen by bounces only, hiding nothing)
has no Mitsuba counterpart: such scenes are not comparable.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...image.colour import REC709_LUMINANCE
from ...shading.plan import ChartFrame
from ...spec.chart_spec import ChartSpec

PROCEDURAL_MAP = (1024, 513)    # envmap knots (W, H) that steer a procedural environment's sampling
FLOOR_EXTENT = 1e7              # the floor's half side, in sphere radii
INNER_FLOOR = 64.0              # the half side of its middle square (floor_pieces), in sphere radii
FLOOR_RATIO = 16.0              # each ring of the floor this much wider than the one within
SHADOW_REACH = 1e9              # an environment sample's shadow ray, in sphere radii: past the floor
FLIP_U = ((-1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, -1.0, 0.0), (0.0, 0.0, 0.0, 1.0))
SCENE_LOBES = ("specular",)     # the KHR lobes the peer's BSDF has (peer_bsdf)


def not_comparable(spec: ChartSpec) -> str | None:
    """Why the peer cannot render ``spec``'s reference scene, or None when it can."""
    if spec.brdf != "gltf":
        return f"BRDF model {spec.brdf} (the peer has glTF's)"
    if spec.camera != "perspective":
        return f"{spec.camera} camera"
    if spec.transparent or spec.backdrop:
        return "a transparent image (shadow catcher)"
    if spec.uses_textures():
        return "textured spheres"
    materials = cell_list(spec)
    lobes = sorted({lobe for m in materials for lobe in m.lobes()} - set(SCENE_LOBES))
    if lobes:
        return f"KHR lobes the peer lacks: {', '.join(lobes)}"
    if any(m.see_through or m.alpha < 1.0 for m in materials):
        return "see-through spheres (alpha)"
    if any(light.kind == "point" and light.radius > 0.0 for light in spec.lights):
        return "a point light with a radius (a sphere seen by bounces only)"
    return None


def cell_list(spec: ChartSpec) -> list:
    """Every cell's Material, row by row, in one list."""
    return [m for row in spec.cell_materials() for m in row]


# ---- the environment ---------------------------------------------------------------------------

class NumpyOps:
    """The operations the environment's formula needs, in float64 numpy."""
    clip, sqrt, acos, power, abs, maximum, where = (np.clip, np.sqrt, np.arccos, np.power, np.abs, np.maximum,
                                                     np.where)


class DrJitOps:
    """The same operations in Dr.Jit (the emitter's exact evaluation)."""

    def __init__(self):
        import drjit as dr
        self.clip, self.sqrt, self.acos, self.power = dr.clip, dr.sqrt, dr.acos, dr.power
        self.abs, self.maximum, self.where = dr.abs, dr.maximum, dr.select


# env.glsl's procedural environments: colours and soft caps (axis, radius, softness).
STUDIO_SKY = ((0.30, 0.31, 0.34), (0.10, 0.11, 0.13))       # horizon, zenith: mixed by sqrt(y)
STUDIO_FLOOR = (0.06, 0.057, 0.054)
STUDIO_CAPS = (((3.2, 3.3, 3.6), (0.75, 0.35, 0.55), 0.30, 0.08),     # fill box
               ((4.0, 3.8, 3.5), (-0.35, 0.45, -0.82), 0.20, 0.05),   # rim
               ((1.2, 1.2, 1.2), (0.0, 1.0, 0.0), 0.35, 0.15))        # top box
SKY_ZENITH, SKY_HORIZON = (0.12, 0.25, 0.60), (0.75, 0.82, 0.95)
SKY_SUN, SKY_GROUND, SKY_HAZE = (1.0, 0.85, 0.6), (0.22, 0.19, 0.15), (0.3, 0.3, 0.32)


def environment_radiance(option: str, x, y, z, sun=(0.0, 1.0, 0.0), ops=NumpyOps) -> tuple:
    """env.glsl's procedural environments: radiance (r, g, b) along unit directions given by
    their components x, y, z (numpy arrays, or Dr.Jit ones with ops=DrJitOps()), before
    env_intensity. The one formula of both the sampling map and the emitter."""
    def saturate(v):
        return ops.clip(v, 0.0, 1.0)

    def smoothstep(e0, e1, v):
        t = saturate((v - e0) / (e1 - e0))
        return t * t * (3.0 - 2.0 * t)

    def soft_cap(axis, radius, softness):
        n = math.sqrt(sum(a * a for a in axis))
        cos = ops.clip((x * axis[0] + y * axis[1] + z * axis[2]) / n, -1.0, 1.0)
        return 1.0 - smoothstep(radius - softness, radius + softness, ops.acos(cos))

    if option == "uniform":
        return tuple(x * 0.0 + 1.0 for _ in range(3))
    if option == "black":
        return tuple(x * 0.0 for _ in range(3))
    if option == "studio":
        up = ops.sqrt(saturate(y))
        lift = 1.0 + 0.5 * smoothstep(-0.4, 0.0, y)
        horizon = 0.25 * ops.power(ops.maximum(1.0 - ops.abs(y), 0.0), 12.0)
        caps = [(colour, soft_cap(axis, radius, softness)) for colour, axis, radius, softness in STUDIO_CAPS]
        out = []
        for k in range(3):
            sky = STUDIO_SKY[0][k] + (STUDIO_SKY[1][k] - STUDIO_SKY[0][k]) * up
            c = ops.where(y >= 0.0, sky, STUDIO_FLOOR[k] * lift) + horizon
            for colour, weight in caps:
                c = c + colour[k] * weight
            out.append(c)
        return tuple(out)
    if option == "sky":
        up = ops.power(saturate(y), 0.45)
        mu = ops.maximum(x * sun[0] + y * sun[1] + z * sun[2], 0.0)
        glow = 0.6 * ops.power(mu, 8.0) + 2.0 * ops.power(mu, 64.0)
        lift = 0.6 + 0.4 * smoothstep(-0.3, 0.0, y)
        haze = ops.power(ops.maximum(1.0 - ops.abs(y), 0.0), 16.0)
        out = []
        for k in range(3):
            sky = SKY_HORIZON[k] + (SKY_ZENITH[k] - SKY_HORIZON[k]) * up + SKY_SUN[k] * glow
            out.append(ops.where(y >= 0.0, sky, SKY_GROUND[k] * lift) + SKY_HAZE[k] * haze)
        return tuple(out)
    raise ValueError(f"no procedural environment {option!r}")


def lat_long_direction(u, v) -> np.ndarray:
    """sdfpbr's lat-long map: the direction at (u, v) (sampling_env.glsl equirect_direction)."""
    theta, phi = np.pi * np.asarray(v, np.float64), 2.0 * np.pi * (np.asarray(u, np.float64) - 0.5)
    s = np.sin(theta)
    return np.stack(np.broadcast_arrays(s * np.sin(phi), np.cos(theta), -s * np.cos(phi)), axis=-1)


def envmap_knots(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of a Mitsuba envmap's knots, (height, width) each, in sdfpbr's coordinates (the
    envmap turned by FLIP_U): u = (i + 0.5) / W, v = j / (H - 1)."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)
    return np.broadcast_arrays(u[None, :], v[:, None])


def file_envmap(data: np.ndarray) -> np.ndarray:
    """sdfpbr's W x H map file as the W x (2H + 1) envmap of the same bilinear function."""
    data = np.asarray(data, np.float32)
    h = data.shape[0]
    out = np.empty((2 * h + 1, *data.shape[1:]), np.float32)
    out[1::2] = data
    out[2:-1:2] = 0.5 * (data[:-1] + data[1:])
    out[0], out[-1] = data[0], data[-1]
    return out


def environment_map(frame: ChartFrame) -> np.ndarray | None:
    """The envmap (H, W, 3) float32 of ``frame``'s environment (its preset or 'file'),
    env_intensity applied; None for a black one."""
    spec, env = frame.spec, frame.env
    if env == "black" or spec.env_intensity == 0.0:
        return None
    if env == "file":
        from ...inputs.environment import load_env_file
        data = file_envmap(load_env_file(spec.env))
    else:
        size = (2, 3) if env == "uniform" else PROCEDURAL_MAP
        d = lat_long_direction(*envmap_knots(*size))
        data = np.stack(environment_radiance(env, d[..., 0], d[..., 1], d[..., 2], frame.sun_direction), axis=-1)
    return np.ascontiguousarray(data * np.float32(spec.env_intensity), np.float32)


@dataclass(frozen=True)
class Disc:
    """A directional light of angular radius > 0: its cone and radiance."""
    direction: tuple[float, float, float]
    cos_theta: float
    radiance: tuple[float, float, float]
    illuminance: tuple[float, float, float]


def light_sources(spec: ChartSpec) -> tuple[list[Disc], list[dict]]:
    """(the discs, Mitsuba emitter dicts for the delta lights) of ``spec``'s lights."""
    discs, deltas = [], []
    for light in spec.lights:
        e = tuple(float(c) * light.intensity for c in light.color)
        if light.kind == "directional":
            theta = math.radians(light.angular_radius_deg)
            if theta > 0.0:
                scale = 1.0 / (math.pi * math.sin(theta) ** 2)
                discs.append(Disc(tuple(light.direction), math.cos(theta), tuple(c * scale for c in e), e))
            else:
                deltas.append({"type": "directional", "direction": [-c for c in light.direction],
                               "irradiance": {"type": "rgb", "value": list(e)}})
        else:
            deltas.append({"type": POINT_PLUGIN, "position": tuple(light.position), "intensity": e,
                           "range": float(light.range)})
    return discs, deltas


def environment_power(data: np.ndarray | None) -> float:
    """The luminance an environment map sends onto a surface facing it, about: pi times its
    mean over the sphere (a sampling weight only)."""
    if data is None:
        return 0.0
    lum = data.astype(np.float64) @ np.array(REC709_LUMINANCE)
    v = np.arange(data.shape[0]) / max(data.shape[0] - 1, 1)
    sin_theta = np.sin(np.pi * v)[:, None]
    return float(np.pi * np.sum(lum * sin_theta) / max(np.sum(np.broadcast_to(sin_theta, lum.shape)), 1e-30))


ENV_PLUGIN = "sdfpbr_environment"
POINT_PLUGIN = "sdfpbr_point"
_registered: dict = {}


def register_emitters() -> None:
    """Register the environment (map and discs) and the windowed point light with Mitsuba (the
    variant set first)."""
    if _registered:
        return
    import drjit as dr
    import mitsuba as mi

    class Environment(mi.Emitter):
        """An envmap plus discs, one environment emitter (setup gives it its parts)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_flags = mi.EmitterFlags.Infinite | mi.EmitterFlags.SpatiallyVarying
            self.envmap = None
            self.procedural = None
            self.discs = []
            self.reach = 1e6
            self.shares = [1.0]

        def setup(self, envmap, discs, env_power: float, reach: float, procedural=None) -> None:
            """procedural: (option, sun, intensity) of a procedural environment, evaluated
            exactly (the map then only steers sampling), or None (the map is the radiance)."""
            self.envmap, self.discs, self.reach = envmap, list(discs), float(reach)
            self.procedural = procedural
            # Techniques by the light they bring: the map's, each disc's illuminance.
            weights = [env_power if envmap is not None else 0.0] + \
                [max(float(np.dot(d.illuminance, REC709_LUMINANCE)), 1e-12) for d in self.discs]
            total = sum(weights) or 1.0
            self.shares = [w / total for w in weights]

        def _discs_radiance(self, d):
            out = mi.Color3f(0.0)
            for disc in self.discs:
                inside = dr.dot(d, mi.Vector3f(disc.direction)) >= disc.cos_theta
                out += dr.select(inside, mi.Color3f(disc.radiance), 0.0)
            return out

        def _radiance(self, d, active):
            value = self._discs_radiance(d)
            if self.procedural is not None:
                option, sun, intensity = self.procedural
                value += mi.Color3f(*environment_radiance(option, d.x, d.y, d.z, sun, DrJitOps())) * intensity
            elif self.envmap is not None:
                si = dr.zeros(mi.SurfaceInteraction3f)
                si.wi = -d
                value += self.envmap.eval(si, active)
            return value

        def _pdf(self, it, d, active):
            pdf = mi.Float(0.0)
            if self.envmap is not None and self.shares[0] > 0.0:
                ds = dr.zeros(mi.DirectionSample3f)
                ds.d = d
                pdf += self.shares[0] * self.envmap.pdf_direction(it, ds, active)
            for share, disc in zip(self.shares[1:], self.discs):
                inside = dr.dot(d, mi.Vector3f(disc.direction)) >= disc.cos_theta
                pdf += dr.select(inside, share / (2.0 * dr.pi * (1.0 - disc.cos_theta)), 0.0)
            return pdf

        def eval(self, si, active=True):
            return self._radiance(-si.wi, active)

        def sample_direction(self, it, sample, active=True):
            # One technique per sample, picked by sample.x, which is then reused rescaled.
            d = mi.Vector3f(0.0, 1.0, 0.0)
            start = 0.0
            for k, share in enumerate(self.shares):
                if share <= 0.0:
                    continue
                chosen = (sample.x >= start) & (sample.x < start + share) if k < len(self.shares) - 1 \
                    else sample.x >= start
                rescaled = mi.Point2f(dr.clip((sample.x - start) / share, 0.0, 0.99999994), sample.y)
                if k == 0:
                    ds_env, _ = self.envmap.sample_direction(it, rescaled, active & chosen)
                    d = dr.select(chosen, ds_env.d, d)
                else:
                    disc = self.discs[k - 1]
                    local = mi.warp.square_to_uniform_cone(rescaled, disc.cos_theta)
                    d = dr.select(chosen, mi.Frame3f(mi.Vector3f(disc.direction)).to_world(local), d)
                start += share
            pdf = self._pdf(it, d, active)
            ds = dr.zeros(mi.DirectionSample3f)
            ds.d = d
            ds.pdf = pdf
            ds.dist = self.reach
            ds.p = it.p + d * self.reach
            ds.n = -d
            ds.delta = False
            ds.emitter = mi.EmitterPtr(self)
            ok = active & (pdf > 0.0)
            weight = dr.select(ok, self._radiance(d, ok) / dr.maximum(pdf, 1e-30), 0.0)
            return ds, weight

        def pdf_direction(self, it, ds, active=True):
            return self._pdf(it, ds.d, active)

        def eval_direction(self, it, ds, active=True):
            return self._radiance(ds.d, active)

        def sample_wavelengths(self, si, sample, active=True):
            return dr.zeros(mi.Wavelength), self._radiance(-si.wi, active)

        def bbox(self):
            return mi.ScalarBoundingBox3f()

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"{ENV_PLUGIN}[discs={len(self.discs)}, map={self.envmap is not None}]"

    class PointLight(mi.Emitter):
        """sdfpbr's point light: I w(d)^2 / d^2, w = saturate(1 - (d / range)^4) (lights.glsl)."""

        def __init__(self, props):
            super().__init__(props)
            self.m_flags = mi.EmitterFlags.DeltaPosition
            self.setup((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0)

        def setup(self, position, intensity, light_range: float) -> None:
            self.scalar_position = tuple(float(c) for c in position)
            self.position = mi.Point3f(self.scalar_position)
            self.intensity = mi.Color3f(tuple(float(c) for c in intensity))
            self.range = float(light_range)

        def sample_direction(self, it, sample, active=True):
            to_light = self.position - it.p
            dist = dr.norm(to_light)
            ds = dr.zeros(mi.DirectionSample3f)
            ds.p = self.position
            ds.d = to_light / dist
            ds.dist = dist
            ds.pdf = 1.0
            ds.n = -ds.d
            ds.delta = True
            ds.emitter = mi.EmitterPtr(self)
            w = dr.clip(1.0 - dr.square(dr.square(dist / self.range)), 0.0, 1.0)
            return ds, self.intensity * (w * w / dr.maximum(dist * dist, 1e-4))

        def pdf_direction(self, it, ds, active=True):
            return mi.Float(0.0)

        def eval(self, si, active=True):
            return mi.Color3f(0.0)

        def eval_direction(self, it, ds, active=True):
            return mi.Color3f(0.0)

        def sample_wavelengths(self, si, sample, active=True):
            return dr.zeros(mi.Wavelength), self.intensity

        def bbox(self):
            return mi.ScalarBoundingBox3f(mi.ScalarPoint3f(self.scalar_position))

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return POINT_PLUGIN

    mi.register_emitter(ENV_PLUGIN, lambda props: Environment(props))
    mi.register_emitter(POINT_PLUGIN, lambda props: PointLight(props))
    _registered.update(environment=Environment, point=PointLight)


# ---- the scene ---------------------------------------------------------------------------------

@dataclass
class PeerScene:
    """A Mitsuba scene of one spec: its film covers one cell (cells stage, with ``pad`` pixels
    of the cell's own view beyond it on each side, where the image's margins reach) or the
    image (shared stage). ``sphere_bsdfs``: one per cell (shared) or the one sphere's (cells)."""
    spec: ChartSpec
    scene: object
    sensor: object
    film_size: tuple[int, int]
    pad: tuple[int, int]
    sphere_bsdfs: list
    floor_bsdf: object | None
    camera: object
    cells: bool


def floor_pieces(y0: float, radius: float) -> list:
    """The floor's rectangles as 4x4 to_world matrices (Mitsuba's rectangle: x, y in [-1, 1],
    normal +z; here its x, y and z to the world's x, -z and y, facing up). Mitsuba places a
    rectangle's hits from their coordinates on it, in float32, so a hit is off by some 1e-7 of
    the rectangle's size (one 1e7 R square moved the sphere's shadow by 0.6 R). So the floor is
    a square of half side INNER_FLOOR R and rings of four rectangles each FLOOR_RATIO times
    wider, up to FLOOR_EXTENT R, each ring reaching in to half the side of the one within:
    wherever a ray meets the floor, the rectangle it meets is at most 2 FLOOR_RATIO times the
    hit's distance from the middle, and the hit within some 1e-6 of that distance."""
    def piece(cx, cz, hx, hz):
        return [[hx, 0.0, 0.0, cx], [0.0, 0.0, hz, y0], [0.0, -hz, 0.0, cz], [0.0, 0.0, 0.0, 1.0]]
    size = INNER_FLOOR * radius
    pieces = [piece(0.0, 0.0, size, size)]
    while size < FLOOR_EXTENT * radius:
        inner, size = 0.5 * size, size * FLOOR_RATIO
        mid, half = 0.5 * (inner + size), 0.5 * (size - inner)
        pieces += [piece(mid, 0.0, half, size), piece(-mid, 0.0, half, size),
                   piece(0.0, mid, size, half), piece(0.0, -mid, size, half)]
    return pieces


def _look_at(camera) -> object:
    import mitsuba as mi
    position = [float(c) for c in camera.position]
    target = [float(p + f) for p, f in zip(camera.position, camera.forward)]
    return mi.ScalarTransform4f().look_at(origin=position, target=target, up=[float(c) for c in camera.up])


def build_scene(spec: ChartSpec, max_bounces: int, envmap_to_world=FLIP_U) -> PeerScene:
    """The Mitsuba scene of ``spec``'s reference scene (sdfpbr.shading.plan.reference_scene:
    no bugs, the default preset), paths of ``max_bounces`` surface interactions as sdfpbr's
    reference counts them (1: direct light only), no Russian roulette. ``envmap_to_world``:
    the map's turn (4x4 rows), FLIP_U but where a check shows what another would do."""
    import mitsuba as mi

    from ...shading.plan import reference_plan
    from .peer_bsdf import plugin_class
    frame = reference_plan(spec).frame
    spec = frame.spec
    why = not_comparable(spec)
    if why:
        raise ValueError(f"the peer cannot render this scene: {why}")
    bsdf_class = plugin_class()
    register_emitters()
    cells = frame.stage == "cells"
    camera = frame.camera
    grid = frame.grid
    if cells:   # the image's margins beyond the grid belong to the outer cells' views
        right = spec.width - grid.left - grid.cols * grid.cell_width
        bottom = spec.height - grid.top - grid.rows * grid.cell_height
        pad = (max(grid.left, right), max(grid.top, bottom))
        size = (grid.cell_width + 2 * pad[0], grid.cell_height + 2 * pad[1])
        view_height = grid.cell_height
    else:
        pad, size, view_height = (0, 0), (spec.width, spec.height), spec.height
    # The film's vertical field of view: the camera's (tan = half_height over view_height
    # pixels) over the film's pixels, so each pixel keeps its ray.
    fov = 2.0 * math.degrees(math.atan(camera.half_height * size[1] / view_height))
    sensor = mi.load_dict({
        "type": "perspective", "fov": fov, "fov_axis": "y", "to_world": _look_at(camera),
        "near_clip": 1e-3 * spec.sphere_radius, "far_clip": 10.0 * SHADOW_REACH * spec.sphere_radius,
        "film": {"type": "hdrfilm", "width": size[0], "height": size[1], "pixel_format": "rgb",
                 "rfilter": {"type": "box"}, "sample_border": False},
        "sampler": {"type": "independent", "sample_count": 1},
    })
    multiscatter = {"multiscatter": bool(spec.multiscatter)}
    materials = cell_list(spec)
    objects = {"type": "scene", "sensor": sensor,
               "integrator": {"type": "path", "max_depth": max_bounces + 1, "rr_depth": max_bounces + 2}}
    sphere_bsdfs = []
    centers = np.zeros((1, 1, 3)) if cells else frame.sphere_centers
    for index, centre in enumerate(centers.reshape(-1, 3)):
        bsdf = bsdf_class(_properties(mi, multiscatter))
        bsdf.set(materials[index])
        sphere_bsdfs.append(bsdf)
        objects[f"sphere_{index}"] = {"type": "sphere", "center": [float(c) for c in centre],
                                      "radius": float(spec.sphere_radius), "bsdf": bsdf}
    floor_bsdf = None
    if spec.ground:
        from ...spec.material import Material
        floor_bsdf = bsdf_class(_properties(mi, multiscatter))
        floor_bsdf.set(Material(base_color=tuple(spec.ground_color), metallic=0.0, roughness=spec.ground_roughness))
        for k, matrix in enumerate(floor_pieces(float(frame.ground_y), spec.sphere_radius)):
            objects[f"floor_{k}"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(matrix), "bsdf": floor_bsdf}
    discs, deltas = light_sources(spec)
    data = environment_map(frame)
    if data is not None or discs:
        envmap = None
        if data is not None:
            envmap = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(data),
                                   "to_world": mi.ScalarTransform4f([list(r) for r in envmap_to_world])})
        environment = mi.load_dict({"type": ENV_PLUGIN})
        procedural = None
        if data is not None and frame.env != "file":
            procedural = (frame.env, tuple(float(c) for c in frame.sun_direction), float(spec.env_intensity))
        environment.setup(envmap, discs, environment_power(data), SHADOW_REACH * spec.sphere_radius, procedural)
        objects["environment"] = environment
    for k, light in enumerate(deltas):
        if light["type"] == POINT_PLUGIN:
            point = mi.load_dict({"type": POINT_PLUGIN})
            point.setup(light["position"], light["intensity"], light["range"])
            light = point
        objects[f"light_{k}"] = light
    scene = mi.load_dict(objects)
    return PeerScene(spec, scene, scene.sensors()[0], size, pad, sphere_bsdfs, floor_bsdf, camera, cells)


def _properties(mi, values: dict):
    props = mi.Properties()
    for k, v in values.items():
        props[k] = v
    return props
