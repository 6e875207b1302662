"""Image-based lighting computed from the environment on the GPU: a float cubemap bake with a
full mip chain, GGX-prefiltered levels, SH9 irradiance, and the DFG LUT. Results are cached
on disk, keyed by the composed bake sources, their parameters and the environment's content."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import moderngl
import numpy as np

from ..cache import ArrayCache, content_key
from ..errors import SpecError
from ..inputs.environment import MAX_ENV_RADIANCE, fit_texture, load_env_file
from ..shading.compose import ComposedSource
from ..shading.plan import ChartFrame, IBLPlan, RenderPlan
from .gl import allocate_cube_levels, upload_cube_levels
from .programs import ProgramCache, set_uniforms

LOCAL = 8   # compute work-group edge


def prefilter_samples(base: int, level: int) -> int:
    """GGX samples per texel of prefiltered level ``level``: the preset's count times 4^level,
    so every level costs about the same (it has a quarter of the texels of the one above) and
    the rough levels, whose lobes are wide, read fine source mips instead of the coarse ones
    that over-blurred them (default preset, r = 1: +21 % mean with 64 samples and the old +1
    lod bias, 0.02 % now; tests/test_ibl_accuracy.py checks every level against the float64
    prefilter). Capped at 2^16: on llvmpipe, 2^18 and 2^20 samples per texel gave wrong levels
    (+33 % near a bright lobe; not investigated further), and 2^16 is already converged."""
    return min(base << (2 * level), 1 << 16) if level > 0 else base


def _geometry(scene_uniforms: dict) -> dict:
    """The stage's geometry a floor parallax table depends on."""
    return {name: float(scene_uniforms[name]) for name in ("u_radius", "u_ground_y")}


def _groups(n: int) -> int:
    return (n + LOCAL - 1) // LOCAL


@dataclass
class Environment:
    """What the chart program samples: the env as a texture (for file envs) plus its uniforms."""
    option: str
    uniforms: dict
    texture: moderngl.Texture | None
    content: str   # hash of what defines the radiance


def make_environment(ctx: moderngl.Context, frame: ChartFrame) -> Environment:
    """``frame``'s environment: its uniforms, and its file's texture where it is a file."""
    spec, option = frame.spec, frame.env
    uniforms = {"u_env_intensity": spec.env_intensity}
    if option == "sky":   # only the sky has a sun: other environments keep one bake as lights turn
        uniforms["u_sun_direction"] = frame.sun_direction
    texture = None
    content = content_key(option, uniforms)
    if option == "file":
        data = load_env_file(spec.env)
        brightest = float(data.max()) * spec.env_intensity
        if brightest > MAX_ENV_RADIANCE:   # each within its bound, their product not
            raise SpecError(f"environment {spec.env} times env_intensity {spec.env_intensity:g} reaches "
                            f"{brightest:.3g}; at most {MAX_ENV_RADIANCE:g} (the bakes' float32 sums overflow "
                            f"beyond): lower env_intensity or scale the file down")
        data = fit_texture(data, int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384)))
        texture = ctx.texture((data.shape[1], data.shape[0]), 3, data.tobytes(), dtype="f4")
        texture.repeat_x, texture.repeat_y = True, False
        content = content_key(option, uniforms, data.tobytes())
    return Environment(option, uniforms, texture, content)


@dataclass
class EnvironmentLighting:
    """A prefiltered cube and its SH9. Loaded from the disk cache, the cube is uploaded on first
    use: on the cells stage the environment's own cube is read only to bake the stage probe
    and the ground table, which are cached too (a warm start never uploads it)."""
    cube: moderngl.TextureCube | None
    lods: int
    sh: np.ndarray    # (9, 3) irradiance coefficients, cosine lobe applied
    floor_irradiance_over_pi: np.ndarray   # (3,) E / pi of an upward normal, summed exactly
    key: str = ""     # the content key it was baked or loaded under
    load: Callable[[], moderngl.TextureCube] | None = None   # makes the cube when it is None
    # A stage probe's floor parallax table (IBLBaker.floor_parallax), made on first use; a light
    # orbit's later frames carry (orbit, turn) instead of a bake of their own, and their table,
    # like their cube, is the orbit's.
    floor_parallax: moderngl.TextureCube | None = None
    floor_parallax_key: str = ""   # what that table is made of
    orbit: tuple | None = None

    @property
    def prefiltered(self) -> moderngl.TextureCube:
        if self.cube is None:
            self.cube, self.load = self.load(), None
        return self.cube

    def release(self) -> None:
        if self.orbit is not None:   # the orbit's textures: released with it
            return
        for texture in (self.cube, self.floor_parallax):
            if texture is not None:
                texture.release()

    def uniforms(self) -> dict:
        return {"u_prefiltered_lods": float(self.lods), "u_sh": [tuple(map(float, c)) for c in self.sh],
                "u_floor_irradiance_over_pi": tuple(map(float, self.floor_irradiance_over_pi))}


@dataclass
class GroundTable:
    texture: moderngl.Texture     # (u_ground_ibl) RGBA float, ground_ibl.glsl's octahedral map
    key: str


KEPT_BAKES = 8   # bakes a session keeps on the GPU per kind; an orbit bakes a stage probe a frame


def _remember(store: dict, key: str, value, release) -> None:
    """Keep ``value`` under ``key``, the most recent last; beyond KEPT_BAKES the least
    recently used is released (its texture freed)."""
    store[key] = value
    while len(store) > KEPT_BAKES:
        release(store.pop(next(iter(store))))


def _recall(store: dict, key: str):
    """The value under ``key`` (marked most recently used), or None."""
    value = store.pop(key, None)
    if value is not None:
        store[key] = value
    return value


def turned_sh(sh: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """SH9 irradiance coefficients (ibl.glsl's polynomial in n) of the same light turned by
    ``rotation`` (3 x 3): e'(n) = e(R^T n). The polynomial is a constant, a linear and a
    quadratic form on the unit sphere; the forms turn (b' = R b, M' = R M R^T) and M' is put
    back in the basis's shape with x^2 + y^2 + z^2 = 1 (its xx and yy parts opposite)."""
    u = np.asarray(sh, np.float64)
    R = np.asarray(rotation, np.float64)
    M = np.zeros((3, 3) + u.shape[1:])
    M[0, 0], M[1, 1], M[2, 2] = u[8], -u[8], 3.0 * u[6]
    M[0, 1] = M[1, 0] = u[4] / 2
    M[1, 2] = M[2, 1] = u[5] / 2
    M[0, 2] = M[2, 0] = u[7] / 2
    b = np.stack([u[3], u[1], u[2]])                     # x, y, z
    M = np.einsum("ia,ab...,jb->ij...", R, M, R)
    b = np.einsum("ia,a...->i...", R, b)
    t = (M[0, 0] + M[1, 1]) / 2                           # x^2 + y^2 + z^2 = 1 takes t I away
    out = np.empty_like(u)
    out[8], out[6] = M[0, 0] - t, (M[2, 2] - t) / 3
    out[4], out[5], out[7] = 2 * M[0, 1], 2 * M[1, 2], 2 * M[0, 2]
    out[3], out[1], out[2] = b
    out[0] = u[0] - u[6] + t + out[6]
    return out.astype(np.asarray(sh).dtype)


def turn_about_vertical(start, end) -> np.ndarray | None:
    """The turn about the vertical (y) axis that takes direction ``start`` to ``end``, as the
    3 x 3 matrix (c, 0, s; 0, 1, 0; -s, 0, c) that animate.orbit_specs applies; None when
    no such turn does (another height, or a vertical light)."""
    x0, y0, z0 = start
    x1, y1, z1 = end
    r0, r1 = math.hypot(x0, z0), math.hypot(x1, z1)
    if abs(y0 - y1) > 1e-6 or r0 < 1e-6 or abs(r0 - r1) > 1e-6 * max(r0, 1.0):
        return None
    c, s = (x0 * x1 + z0 * z1) / (r0 * r1), (x1 * z0 - z1 * x0) / (r0 * r1)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class _Orbit:
    """A light orbit's first frame, per scene (IBLBaker.turning_light): the key light's direction
    then, the probe baked with every light and with the key light off, and the cube each later
    frame's probe is composed into."""
    direction: tuple
    full: EnvironmentLighting
    rest: EnvironmentLighting
    frame: moderngl.TextureCube | None = None
    floor_parallax: moderngl.TextureCube | None = None   # a later frame's table, turned likewise

    def release(self) -> None:
        kept = (self.full, self.rest, self.frame, self.floor_parallax)   # full is rest when the key light is dark
        for texture in {id(t): t for t in kept if t is not None}.values():
            texture.release()


@dataclass
class _Turning:
    light: int                                      # index among the directional lights
    orbits: dict = field(default_factory=dict)      # scene key (all but the key's direction) -> _Orbit


class IBLBaker:
    def __init__(self, ctx: moderngl.Context, programs: ProgramCache, cache: ArrayCache, renderer: str):
        """``renderer``: the GL implementation's name. The bakes are its (drivers round
        differently), so they are kept on disk under it: one cache shared by two drivers keeps
        each one's, and a render reads the bakes its own driver made."""
        self.ctx = ctx
        self.programs = programs
        self.cache = cache
        self.renderer = renderer
        self._dfg: dict[str, moderngl.Texture] = {}
        self._lighting: dict[str, EnvironmentLighting] = {}   # least recently used first
        self._ground: dict[str, GroundTable] = {}
        self._turning: _Turning | None = None

    def _stored(self, kind: str, key: str) -> dict | None:
        return self.cache.get(kind, content_key(key, self.renderer))

    def _store(self, kind: str, key: str, arrays: dict) -> None:
        self.cache.put(kind, content_key(key, self.renderer), arrays)

    def begin_orbit(self, light: int = 0) -> None:
        """From now until end_orbit, directional light ``light`` turns about the vertical between
        renders (a light orbit): each cells-stage probe after a scene's first is composed from
        that first frame's two bakes (turn_probe_main.glsl), not baked again. Session.turning_light
        holds the session around both calls."""
        self.end_orbit()
        self._turning = _Turning(light)

    def end_orbit(self) -> None:
        """Release what the orbit kept (the context current)."""
        turning, self._turning = self._turning, None
        for orbit in (turning.orbits.values() if turning else ()):
            orbit.release()

    # ---- DFG LUT -------------------------------------------------------------------------
    @staticmethod
    def dfg_key(plan: RenderPlan) -> str:
        return content_key(plan.dfg.text, plan.dfg_size, plan.dfg_samples)

    def dfg(self, plan: RenderPlan) -> moderngl.Texture:
        """The plan's DFG LUT (its source says which model, and whether the ibl-direct-k bug
        builds it with the direct-light Schlick k)."""
        source, size, samples = plan.dfg, plan.dfg_size, plan.dfg_samples
        key = self.dfg_key(plan)
        if key not in self._dfg:
            cached = self._stored("dfg", key)
            if cached is not None:
                table = cached["table"]
            else:
                table = self.compute_dfg_table(source, size, samples)
                self._store("dfg", key, {"table": table})
            tex = self.ctx.texture((size, size), 4, np.ascontiguousarray(table, np.float32).tobytes(), dtype="f4")
            tex.repeat_x = tex.repeat_y = False   # CLAMP_TO_EDGE, linear data
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._dfg[key] = tex
        return self._dfg[key]

    def compute_dfg_table(self, source, size: int, samples: int) -> np.ndarray:
        """(size, size, 4) float32: [j, i] = (A, B, C, 1) at NdotV i/(size-1), r j/(size-1)."""
        program = self.programs.compute(source)
        target = self.ctx.texture((size, size), 4, dtype="f4")
        set_uniforms(program, {"u_size": size, "u_samples": samples})
        target.bind_to_image(0, read=False, write=True)
        program.run(_groups(size), _groups(size), 1)
        self.ctx.memory_barrier()
        table = np.frombuffer(target.read(), dtype=np.float32).reshape(size, size, 4).copy()
        target.release()
        return table

    # ---- environment -------------------------------------------------------------------
    def lighting(self, env: Environment, plan: IBLPlan) -> EnvironmentLighting:
        """The environment's prefiltered cube and SH9, baked once per content, cached on disk."""
        textures = [("u_env_map", env.texture)] if env.texture is not None else []
        return self._baked(plan, plan.env_bake, env.content, env.uniforms, lambda: textures)

    def ground_table(self, plan: RenderPlan, environment: EnvironmentLighting, dfg: moderngl.Texture,
                     scene_uniforms: dict) -> GroundTable:
        """The ground's IBL per view direction (ground_ibl_main.glsl) under ``environment``,
        baked once per environment, ground material and DFG LUT, cached on disk."""
        source, size = plan.ibl.ground_table, plan.ibl.ground_table_size
        program = self.programs.compute(source)
        uniforms = {**scene_uniforms, **environment.uniforms()}
        read = {k: v for k, v in uniforms.items() if k in program}
        key = content_key(source.text, size, read, environment.key, self.dfg_key(plan))
        if _recall(self._ground, key) is None:
            cached = self._stored("ibl", key)
            if cached is not None:
                table = cached["table"]
            else:
                target = self.ctx.texture((size, size), 4, dtype="f4")
                environment.prefiltered.use(1)
                dfg.use(2)
                set_uniforms(program, {**read, "u_prefiltered": 1, "u_dfg": 2, "u_size": size})
                target.bind_to_image(0, read=False, write=True)
                program.run(_groups(size), _groups(size), 1)
                self.ctx.memory_barrier()
                table = np.frombuffer(target.read(), dtype=np.float32).reshape(size, size, 4).copy()
                target.release()
                self._store("ibl", key, {"table": table})
            tex = self.ctx.texture((size, size), 4, np.ascontiguousarray(table, np.float32).tobytes(), dtype="f4")
            tex.repeat_x = tex.repeat_y = False   # CLAMP_TO_EDGE: the square's edge is the horizon
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            _remember(self._ground, key, GroundTable(tex, key), lambda table: table.texture.release())
        return self._ground[key]

    def stage_lighting(self, plan: IBLPlan, probe: ComposedSource, environment: EnvironmentLighting,
                       scene_textures: list, scene_uniforms: dict, env: Environment,
                       depends_on: tuple = ()) -> EnvironmentLighting:
        """The stage probe (the radiance seen from a sphere's centre on the cells stage, from the
        grid's on the shared one: the environment above, the lit floor below), prefiltered and
        projected like the environment. The
        floor is shaded with the environment's lighting and the scene's textures (DFG LUT,
        ground table, environment map), which the probe program reads; ``depends_on``: the
        keys of baked inputs among them."""
        uniforms = {**scene_uniforms, **environment.uniforms()}
        program = self.programs.compute(probe)
        samplers = {name for name, _ in scene_textures} | {"u_prefiltered"}

        def textures() -> list:   # only for a bake: the environment's cube may stay on disk
            every = [*scene_textures, ("u_prefiltered", environment.prefiltered)]
            return [(name, tex) for name, tex in every if name in program]
        # What the probe's radiance depends on: the uniforms its program reads and the lighting.
        read = {k: v for k, v in uniforms.items() if k in program and k not in samplers}
        inputs = (environment.key, env.content, list(depends_on))
        if self._turning is not None and plan.turn_probe is not None:
            turned = self._orbit_probe(plan, probe, read, uniforms, textures, inputs)
            if turned is not None:
                return turned
        return self._baked(plan, probe, content_key(read, *inputs), uniforms, textures)

    def _orbit_probe(self, plan: IBLPlan, probe: ComposedSource, read: dict, uniforms: dict,
                     textures: Callable[[], list], inputs: tuple) -> EnvironmentLighting | None:
        """A light orbit's probe (see turning_light), or None where it must be baked (no such
        light, or the light moved otherwise than about the vertical)."""
        light = self._turning.light
        directions = list(read.get("u_dir_light_direction", ()))
        if light >= len(directions):
            return None
        scene = content_key({k: v for k, v in read.items() if k != "u_dir_light_direction"},
                            directions[:light] + directions[light + 1:], *inputs)
        orbit = self._turning.orbits.get(scene)
        if orbit is None:   # the first frame: the probe as always, and with the key light off
            full = self._baked(plan, probe, content_key(read, *inputs), uniforms, textures)
            dark = [tuple(c) for c in uniforms["u_dir_light_illuminance"]]
            dark[light] = (0.0, 0.0, 0.0)
            rest_read = {**read, "u_dir_light_illuminance": dark}
            with self.cache.reading_only():   # an orbit adds at most its first frame to the cache
                rest = self._baked(plan, probe, content_key(rest_read, *inputs),
                                   {**uniforms, "u_dir_light_illuminance": dark}, textures)
            for key in (full.key, rest.key):   # the orbit keeps them now (released with it)
                self._lighting.pop(key, None)
            self._turning.orbits[scene] = _Orbit(tuple(directions[light]), full, rest)
            return full
        turn = turn_about_vertical(orbit.direction, directions[light])
        if turn is None:
            return None
        return self._turned(plan, orbit, turn)

    def _turned(self, plan: IBLPlan, orbit: _Orbit, turn: np.ndarray) -> EnvironmentLighting:
        """rest + the key light's share turned (turn_probe_main.glsl per level; SH9 turned exactly)."""
        full, rest = orbit.full, orbit.rest
        size, levels = plan.size, full.lods + 1
        if orbit.frame is None:
            orbit.frame = self.ctx.texture_cube((size, size), 4, dtype="f4")
            orbit.frame.build_mipmaps(0, levels - 1)   # allocates the chain written below
            orbit.frame.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        program = self.programs.compute(plan.turn_probe)
        full.prefiltered.use(1)
        rest.prefiltered.use(2)
        # GLSL reads the 9 numbers column by column: R's rows become T = R^T's columns, the turn back.
        set_uniforms(program, {"u_full": 1, "u_rest": 2, "u_turn_back": tuple(turn.ravel())})
        for k in range(levels):
            s = size >> k
            set_uniforms(program, {"u_size": s, "u_lod": float(k)})
            orbit.frame.bind_to_image(0, read=False, write=True, level=k)
            program.run(_groups(s), _groups(s), 6)
        self.ctx.memory_barrier()
        sh = rest.sh + turned_sh(full.sh - rest.sh, turn)
        # A turn about the vertical leaves an upward normal's irradiance as it was.
        return EnvironmentLighting(orbit.frame, full.lods, sh.astype(np.float32), full.floor_irradiance_over_pi,
                                   content_key(plan.turn_probe.text, full.key, rest.key, turn.tolist()),
                                   orbit=(orbit, turn))

    # ---- the floor parallax table ---------------------------------------------------------
    def floor_parallax(self, plan: IBLPlan, lighting: EnvironmentLighting,
                       scene_uniforms: dict) -> moderngl.TextureCube:
        """The cells stage's floor parallax table of a stage probe (floor_parallax_main.glsl): the
        irradiance each sphere point gets from the floor beyond what the probe's, seen from the
        centre, gives it. Baked from the probe's level 0 once per probe and cached on disk with
        it; a light orbit's later frames turn the first frame's tables as they turn its probe
        (the stage is symmetric about the vertical through the sphere, so the table turns with
        the light)."""
        if lighting.floor_parallax is None:
            # What the table is made of (its cache key when baked; a light orbit's turned
            # lighting has a key of its own, which covers the turn), kept with it.
            lighting.floor_parallax_key = content_key(plan.floor_parallax.text, plan.floor_parallax_size,
                                                      plan.floor_parallax_samples, _geometry(scene_uniforms),
                                                      lighting.key)
            if lighting.orbit is not None:
                lighting.floor_parallax = self._turned_floor_parallax(plan, *lighting.orbit, scene_uniforms)
            else:
                lighting.floor_parallax = self._baked_floor_parallax(plan, lighting, scene_uniforms)
        return lighting.floor_parallax

    def _baked_floor_parallax(self, plan: IBLPlan, lighting: EnvironmentLighting,
                              scene_uniforms: dict) -> moderngl.TextureCube:
        source, size, samples = plan.floor_parallax, plan.floor_parallax_size, plan.floor_parallax_samples
        geometry = _geometry(scene_uniforms)
        key = lighting.floor_parallax_key
        cached = self._stored("ibl", key)
        if cached is not None:
            table = self._cube_from_levels(plan.copy_to_cube, [cached["table"]])
        else:
            table = self.ctx.texture_cube((size, size), 4, dtype="f4")
            program = self.programs.compute(source)
            lighting.prefiltered.use(0)
            set_uniforms(program, {**geometry, "u_probe": 0, "u_size": size, "u_samples": samples})
            table.bind_to_image(0, read=False, write=True, level=0)
            program.run(_groups(size), _groups(size), 6)
            self.ctx.memory_barrier()
            self._store("ibl", key, {"table": self._read_cube_level(plan.copy_from_cube, table, 0, size)})
        table.filter = (moderngl.LINEAR, moderngl.LINEAR)
        return table

    def _turned_floor_parallax(self, plan: IBLPlan, orbit: _Orbit, turn: np.ndarray,
                               scene_uniforms: dict) -> moderngl.TextureCube:
        """rest + the key light's share turned, as _turned composes the probe."""
        full = self.floor_parallax(plan, orbit.full, scene_uniforms)
        with self.cache.reading_only():   # as the orbit's probe with the key light off
            rest = self.floor_parallax(plan, orbit.rest, scene_uniforms)
        size = plan.floor_parallax_size
        if orbit.floor_parallax is None:
            orbit.floor_parallax = self.ctx.texture_cube((size, size), 4, dtype="f4")
            orbit.floor_parallax.filter = (moderngl.LINEAR, moderngl.LINEAR)
        program = self.programs.compute(plan.turn_probe)
        full.use(1)
        rest.use(2)
        set_uniforms(program, {"u_full": 1, "u_rest": 2, "u_turn_back": tuple(turn.ravel()),
                               "u_size": size, "u_lod": 0.0})
        orbit.floor_parallax.bind_to_image(0, read=False, write=True, level=0)
        program.run(_groups(size), _groups(size), 6)
        self.ctx.memory_barrier()
        return orbit.floor_parallax

    def _baked(self, plan: IBLPlan, program: ComposedSource, content: str, uniforms: dict,
               textures: Callable[[], list]) -> EnvironmentLighting:
        size = plan.size
        levels = plan.levels or max(1, int(math.log2(size)) - 1)      # down to 4 x 4 unless the plan says
        key = content_key(program.text, plan.prefilter.text, plan.irradiance.text, content,
                          plan.env_bake_size, size, plan.sh_size, levels,
                          [prefilter_samples(plan.samples, k) for k in range(levels)])
        kept = _recall(self._lighting, key)
        if kept is not None:
            return kept
        cached = self._stored("ibl", key)
        if cached is not None:
            arrays = [cached[f"level{k}"] for k in range(levels)]
            result = EnvironmentLighting(None, levels - 1, cached["sh"], cached["floor_irradiance_over_pi"], key,
                                         load=lambda: self._cube_from_levels(plan.copy_to_cube, arrays))
        else:
            result = self._bake(plan, levels, program, uniforms, textures())
            result.key = key
            arrays = {f"level{k}": self._read_cube_level(plan.copy_from_cube, result.prefiltered, k, size >> k)
                      for k in range(levels)}
            arrays["sh"] = result.sh
            arrays["floor_irradiance_over_pi"] = result.floor_irradiance_over_pi
            self._store("ibl", key, arrays)
        _remember(self._lighting, key, result, EnvironmentLighting.release)
        return result

    def read_level(self, plan: IBLPlan, lighting: EnvironmentLighting, level: int) -> np.ndarray:
        """One prefiltered level as (6, size, size, 4) float32, faces in GL order."""
        return self.read_cube(plan, lighting.prefiltered, level)

    def read_cube(self, plan: IBLPlan, cube: moderngl.TextureCube, level: int = 0) -> np.ndarray:
        """Level ``level`` of any float cube (a prefiltered map, a floor parallax table) as
        (6, size, size, 4) float32, faces in GL order, indexed [face, y, x] as
        oracle.ibl_integral.cube_directions lays out their directions."""
        return self._read_cube_level(plan.copy_from_cube, cube, level, cube.size[0] >> level)

    def _bake(self, plan: IBLPlan, levels: int, program: ComposedSource, uniforms: dict,
              textures: list) -> EnvironmentLighting:
        """Bake a radiance cube with ``program`` (the environment, or the cells stage's probe)
        reading ``textures`` ((sampler, texture) pairs), then GGX-prefilter it and project it
        to SH9."""
        ctx = self.ctx
        n = plan.env_bake_size
        source = ctx.texture_cube((n, n), 4, dtype="f4")
        bake = self.programs.compute(program)
        samplers = {}
        for unit, (name, tex) in enumerate(textures, start=1):   # unit 0 takes the source below
            tex.use(unit)
            samplers[name] = unit
        set_uniforms(bake, {**uniforms, **samplers, "u_size": n})
        source.bind_to_image(0, read=False, write=True, level=0)
        bake.run(_groups(n), _groups(n), 6)
        ctx.memory_barrier()
        source.build_mipmaps()
        source.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)

        size = plan.size
        target = ctx.texture_cube((size, size), 4, dtype="f4")
        allocate_cube_levels(ctx, target, levels)   # the chain we overwrite below
        prefilter = self.programs.compute(plan.prefilter)
        source.use(0)
        for k in range(levels):
            s = size >> k
            r = k / (levels - 1) if levels > 1 else 0.0   # lod = r (levels - 1), as ibl.glsl reads it
            set_uniforms(prefilter, {"u_source": 0, "u_size": s, "u_source_size": float(n),
                                     "u_perceptual_roughness": r, "u_samples": prefilter_samples(plan.samples, k)})
            target.bind_to_image(0, read=False, write=True, level=k)
            prefilter.run(_groups(s), _groups(s), 6)
            ctx.memory_barrier()
        target.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)

        sh_prog = self.programs.compute(plan.irradiance)
        sh_size = min(plan.sh_size, n)
        buffer = ctx.buffer(reserve=10 * 16)
        buffer.bind_to_storage_buffer(0)
        set_uniforms(sh_prog, {"u_source": 0, "u_source_lod": int(math.log2(n // sh_size)), "u_size": sh_size})
        sh_prog.run(1, 1, 1)
        ctx.memory_barrier()
        rows = np.frombuffer(buffer.read(), dtype=np.float32).reshape(10, 4)[:, :3].copy()
        buffer.release()
        source.release()
        return EnvironmentLighting(target, levels - 1, rows[:9], rows[9])

    def _read_cube_level(self, copy: ComposedSource, cube: moderngl.TextureCube, level: int, size: int) -> np.ndarray:
        array = self.ctx.texture_array((size, size, 6), 4, dtype="f4")
        program = self.programs.compute(copy)
        cube.bind_to_image(0, read=True, write=False, level=level)
        array.bind_to_image(1, read=False, write=True)
        set_uniforms(program, {"u_size": size})
        program.run(_groups(size), _groups(size), 6)
        self.ctx.memory_barrier()
        data = np.frombuffer(array.read(), dtype=np.float32).reshape(6, size, size, 4).copy()
        array.release()
        return data

    def _cube_from_levels(self, copy: ComposedSource, levels: list[np.ndarray]) -> moderngl.TextureCube:
        size = levels[0].shape[1]
        cube = self.ctx.texture_cube((size, size), 4, dtype="f4")
        cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        if upload_cube_levels(self.ctx, cube, levels):
            return cube
        allocate_cube_levels(self.ctx, cube, len(levels))
        program = self.programs.compute(copy)
        for k, data in enumerate(levels):
            s = data.shape[1]
            array = self.ctx.texture_array((s, s, 6), 4, np.ascontiguousarray(data, np.float32).tobytes(), dtype="f4")
            array.bind_to_image(0, read=True, write=False)
            cube.bind_to_image(1, read=False, write=True, level=k)
            set_uniforms(program, {"u_size": s})
            program.run(_groups(s), _groups(s), 6)
            self.ctx.memory_barrier()
            array.release()
        return cube
