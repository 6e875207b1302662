"""What every renderer on a session shares, whatever its integrator: the tile loop, the scene
bindings (camera, grid, lights, environment, surface maps), the display pass (exposure, tone
map, OETF) and the decoding of the AOV targets. The chart's raymarcher and the reference's
path tracer differ only in how they gather light."""
from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..cache import content_key
from ..image.colour import BACKGROUND
from ..shading.camera import Camera
from ..shading.plan import ChartFrame
from ..shading.material_table import material_table, upload as upload_materials
from ..spec.chart_spec import MAX_GRID, ChartSpec
from .ibl import Environment, make_environment
from .programs import set_uniforms

RADIANCE_UNIT = 15   # texture unit the display pass reads the radiance from


def tiles(width: int, height: int, edge: int):
    """(x0, y0, w, h) of each tile, in GL pixel coordinates (y0 counts from the bottom)."""
    for y0 in range(0, height, edge):
        for x0 in range(0, width, edge):
            yield x0, y0, min(edge, width - x0), min(edge, height - y0)


def image_slices(height: int, x0: int, y0: int, w: int, h: int) -> tuple[slice, slice]:
    """Where a GL tile lands in a top-row-first image array."""
    return slice(height - y0 - h, height - y0), slice(x0, x0 + w)


GL_DTYPES = {np.dtype(np.uint8): "f1", np.dtype(np.float16): "f2", np.dtype(np.float32): "f4"}


def read_rgba(source, width: int, height: int, dtype=np.float32, pool: TargetPool | None = None,
              slot: int = 0, attachment: int = 0) -> np.ndarray:
    """RGBA pixels of a texture, or of a framebuffer's ``attachment``, top row first (GL rows
    run bottom-up). A framebuffer is read with glReadPixels: on NVIDIA 3–9x faster than reading
    its texture (a 2048² float target: 6 ms against 22–57), the same on llvmpipe. With ``pool``,
    the pixels land in the pool's kept array for (size, dtype, slot) rather than fresh memory,
    whose page faults cost more than the copy: the view is good until the next read into that
    slot, so copy it out first."""
    code = GL_DTYPES[np.dtype(dtype)]
    is_fbo = isinstance(source, moderngl.Framebuffer)
    if pool is None:
        data = (source.read(components=4, attachment=attachment, dtype=code) if is_fbo
                else source.read())
        return np.frombuffer(data, dtype).reshape(height, width, 4)[::-1]
    staging = pool.staging(width, height, dtype, slot)
    if is_fbo:
        source.read_into(staging, components=4, attachment=attachment, dtype=code)
    else:
        source.read_into(staging)
    return staging[::-1]


def array_key(array: np.ndarray) -> str:
    """A content key of an array (its dtype, shape and bytes)."""
    a = np.ascontiguousarray(array)
    return content_key(a.dtype.str, list(a.shape), a.tobytes())


def table_texture(ctx: moderngl.Context, array: np.ndarray) -> moderngl.Texture:
    """A small float table, (rows, cols) or (rows, cols, channels), as a texture read texel by
    texel (nearest; texel (col, row))."""
    data = np.ascontiguousarray(array, np.float32)
    channels = data.shape[2] if data.ndim == 3 else 1
    texture = ctx.texture((data.shape[1], data.shape[0]), channels, data.tobytes(), dtype="f4")
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return texture


class TargetPool:
    """Render targets a session keeps from one render to the next, by (width, height, dtype):
    allocating a 1024² chart's float targets cost ~20 ms a render on llvmpipe, a tenth of its
    draw. Only what fits in ``budget`` bytes is kept (least recently used goes first), so a
    large render does not pin its tiles' memory after it returns."""

    def __init__(self, ctx: moderngl.Context, budget: int = 64 << 20, staging_budget: int = 128 << 20):
        self.ctx = ctx
        self.budget = budget
        self._free: dict[tuple, list] = {}    # key -> textures not in use, oldest key first
        # Arrays that reads land in, kept likewise: a read into fresh memory pays for the page
        # faults of every byte (a 2048² half-float target: 20 ms fresh, 3 ms kept, llvmpipe).
        self.staging_budget = staging_budget
        self._staging: dict[tuple, np.ndarray] = {}   # (width, height, dtype, slot), oldest first

    def staging(self, width: int, height: int, dtype, slot: int = 0) -> np.ndarray:
        """A (height, width, 4) array to read a target into, kept while under the staging budget."""
        key = (width, height, np.dtype(dtype).str, slot)
        array = self._staging.pop(key, None)
        if array is None:
            array = np.empty((height, width, 4), dtype)
        if array.nbytes <= self.staging_budget:
            self._staging[key] = array                       # most recently used last
            while sum(a.nbytes for a in self._staging.values()) > self.staging_budget:
                del self._staging[next(iter(self._staging))]
        return array

    @staticmethod
    def _bytes(key: tuple) -> int:
        width, height, dtype = key
        return width * height * 4 * int(dtype[1])

    def take(self, width: int, height: int, dtype: str) -> moderngl.Texture:
        """An RGBA texture of that size and dtype ('f1', 'f2', 'f4'), fresh or kept."""
        key = (width, height, dtype)
        kept = self._free.get(key)
        if kept:
            return kept.pop()
        return self.ctx.texture((width, height), 4, dtype=dtype)

    def give(self, texture: moderngl.Texture) -> None:
        """Return a texture taken from the pool: kept while the pool is under budget."""
        key = (texture.width, texture.height, texture.dtype)
        if self._bytes(key) > self.budget:   # a big render's tiles: never kept
            texture.release()
            return
        self._free.setdefault(key, []).append(texture)
        self._free[key] = self._free.pop(key)            # most recently used last
        total = sum(self._bytes(k) * len(v) for k, v in self._free.items())
        for k in list(self._free):
            while total > self.budget and self._free[k]:
                self._free[k].pop(0).release()
                total -= self._bytes(k)
            if not self._free[k]:
                del self._free[k]

    def kept(self) -> dict[tuple, int]:
        """How many textures are kept, by (width, height, dtype)."""
        return {key: len(v) for key, v in self._free.items()}

    def release(self) -> None:
        for kept in self._free.values():
            for tex in kept:
                tex.release()
        self._free.clear()
        self._staging.clear()


def chart_uniforms(frame: ChartFrame) -> dict:
    """The scene's uniforms: camera, grid, materials, ground, lights and the marching budget."""
    spec, cam, q = frame.spec, frame.camera, frame.quality
    directional = [light for light in spec.lights if light.kind == "directional"]
    point = [light for light in spec.lights if light.kind == "point"]
    scene_size = max(spec.rows, spec.cols) * spec.spacing + 2 * spec.sphere_radius
    u = {
        **cam.uniforms(),
        "u_grid": (spec.cols, spec.rows),
        "u_radius": spec.sphere_radius,
        "u_spacing": spec.spacing,
        "u_ground_y": frame.ground_y,
        "u_ground_color": spec.ground_color,
        "u_ground_roughness": spec.ground_roughness,
        "u_spp": spec.spp,
        "u_march_steps": q.march_steps,
        "u_march_far": float(np.linalg.norm(cam.position)) + 4.0 * scene_size,
        "u_hit_scale": q.hit_scale,
        "u_hit_epsilon": q.hit_epsilon,
        "u_shadow_steps": q.shadow_steps,
        "u_shadow_far": 2.0 * scene_size,
        "u_ao_taps": q.ao_taps,
        "u_ao_radius": 0.5 * spec.sphere_radius,
        "u_env_intensity": spec.env_intensity,
    }
    if frame.stage == "cells":
        u.update(frame.grid.uniforms(spec.height))
        if frame.catcher_band is not None:
            u["u_catcher_band"] = frame.catcher_band
    if directional:
        u["u_dir_light_direction"] = [light.direction for light in directional]
        u["u_dir_light_illuminance"] = [tuple(c * light.intensity for c in light.color) for light in directional]
        u["u_dir_light_angular_radius"] = [float(np.radians(light.angular_radius_deg)) for light in directional]
    if point:
        u["u_point_light_position"] = [light.position for light in point]
        u["u_point_light_intensity"] = [tuple(c * light.intensity for c in light.color) for light in point]
        u["u_point_light_range"] = [light.range for light in point]
        u["u_point_light_radius"] = [light.radius for light in point]
    return u


@dataclass
class SceneBindings:
    """Uniforms and textures of one render of a scene; ``release`` frees what it uploaded."""
    camera: Camera
    environment: Environment
    uniforms: dict
    textures: list = field(default_factory=list)     # (sampler name, texture)
    owned: list = field(default_factory=list)        # textures uploaded for this render
    keys: dict = field(default_factory=dict)         # sampler name -> its texture's content key

    def add_texture(self, name: str, texture, owned: bool = False, key: str | None = None) -> None:
        """Bind ``texture`` to sampler ``name``; ``key``: a content key of what it holds (what
        is drawn from it may be cached under it: gpu/prepasses.py), None where it has none."""
        self.textures.append((name, texture))
        self.keys[name] = key
        if owned:
            self.owned.append(texture)

    def replace_texture(self, name: str, texture, key: str | None = None) -> None:
        """Set ``name`` to a texture this render owns, releasing the one it replaces."""
        i = self._release_bound(name)
        if i is None:
            self.add_texture(name, texture, owned=True, key=key)
            return
        self.textures[i] = (name, texture)
        self.keys[name] = key
        self.owned.append(texture)

    def forget(self, textures, uniforms) -> None:
        """Unbind ``textures`` (releasing those this render owns) and drop ``uniforms``: what a
        frame's own passes bind anew."""
        for name in textures:
            i = self._release_bound(name)
            if i is not None:
                del self.textures[i]
            self.keys.pop(name, None)
            self.uniforms.pop(name, None)   # its texture unit
        for name in uniforms:
            self.uniforms.pop(name, None)

    def _release_bound(self, name: str) -> int | None:
        """Where ``name`` is bound (None: nowhere), its texture released if this render owns it."""
        for i, (n, old) in enumerate(self.textures):
            if n == name:
                if old in self.owned:
                    self.owned.remove(old)
                    old.release()
                return i
        return None

    def texture_keys(self) -> dict:
        """Each bound sampler's content key (None: unknown)."""
        return {name: self.keys.get(name) for name, _ in self.textures}

    def bind(self) -> dict:
        """Put each texture on a unit; the uniforms with every sampler pointing at its unit."""
        for unit, (name, tex) in enumerate(self.textures):
            tex.use(unit)
            self.uniforms[name] = unit
        return self.uniforms

    def release(self) -> None:
        for tex in self.owned:
            tex.release()
        self.owned.clear()


def scene_bindings(ctx: moderngl.Context, frame: ChartFrame, uses_textures: bool, cache=None) -> SceneBindings:
    """Bindings for ``frame``'s scene: camera, grid, lights and marching budget, the environment
    (a texture for file environments) and the surface maps when the program composes them in
    (procedural ones kept in ``cache``, the session's ArrayCache)."""
    spec = frame.spec
    env = make_environment(ctx, frame)
    uniforms = chart_uniforms(frame)
    bindings = SceneBindings(frame.camera, env, {**uniforms, **env.uniforms})
    if env.texture is not None:
        bindings.add_texture("u_env_map", env.texture, owned=True, key=env.content)
    materials = material_table(spec.cell_materials())
    bindings.add_texture("u_cell_materials", upload_materials(ctx, materials), owned=True, key=array_key(materials))
    if uses_textures:
        from .textures import texture_set, upload, upload_kept
        maps = texture_set(spec, cache)
        kept = upload_kept(ctx, maps)
        for name, tex in (kept if kept is not None else upload(ctx, maps)).items():
            bindings.add_texture(name, tex, owned=kept is None)
        bindings.uniforms["u_map_layers"] = maps.layers
    return bindings


def display_uniforms(frame: ChartFrame, origin: tuple[int, int] = (0, 0)) -> dict:
    """The display program's uniforms; ``origin``: the pass's pixel (0, 0) in the image."""
    spec = frame.spec
    out = {"u_exposure_scale": 2.0 ** spec.exposure, "u_reinhard_white": spec.reinhard_white,
           "u_radiance": RADIANCE_UNIT, **({"u_backdrop_srgb": tuple(spec.backdrop)} if spec.backdrop else {})}
    axis, border = frame.exposure_axis, frame.cell_border
    if axis or border:   # where the cells lie
        out.update(frame.grid.uniforms(spec.height), u_grid=(spec.cols, spec.rows), u_display_origin=origin)
    if axis:   # each column's (row's) EV relative to the spec's
        ev = [v - spec.exposure for v in spec.axis_values(axis)]
        out.update(u_axis_ev=ev + [0.0] * (MAX_GRID - len(ev)))   # the array is MAX_GRID long
    if border:
        out.update(u_cell_border=border, u_page_srgb=tuple(c / 255 for c in BACKGROUND[:3]))
    return out


def display_pass(ctx: moderngl.Context, program, radiance, frame: ChartFrame, width: int, height: int,
                 pool: TargetPool | None = None, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """Exposure, tone map and OETF of ``radiance`` (a float RGBA texture) of ``frame``'s chart
    through the display program: (height, width, 4) uint8, top row first. ``pool``: where its target and the array
    it is read into come from (then the result is good until the pool's next read: copy it
    out); ``origin``: the texture's pixel (0, 0) in the image (a tile's, GL coordinates)."""
    ldr = pool.take(width, height, "f1") if pool else ctx.texture((width, height), 4)
    fbo = ctx.framebuffer(color_attachments=[ldr])
    vao = ctx.vertex_array(program, [])
    try:
        fbo.use()
        radiance.use(RADIANCE_UNIT)
        set_uniforms(program, display_uniforms(frame, origin))
        vao.render(moderngl.TRIANGLES, vertices=3)
        return read_rgba(fbo, width, height, np.uint8, pool)
    finally:
        vao.release()
        fbo.release()
        if pool:
            pool.give(ldr)
        else:
            ldr.release()


class AOVBuffers:
    """The AOV images of a render, filled tile by tile from the two AOV targets every program
    writes ((normal, depth) and (col, row, NdotV)), decoded into the published layout."""

    def __init__(self, spec: ChartSpec, height: int, width: int):
        self.spec = spec
        self.normal = np.empty((height, width, 3), np.float32)
        self.depth = np.empty((height, width), np.float32)
        self.col = np.empty((height, width), np.int32)
        self.row = np.empty((height, width), np.int32)
        self.ndotv = np.empty((height, width), np.float32)
        self.coverage = np.empty((height, width), np.float32)

    def write(self, where: tuple[slice, slice], normal_depth: np.ndarray, cells: np.ndarray) -> None:
        self.normal[where] = normal_depth[..., :3]
        self.depth[where] = normal_depth[..., 3]
        np.rint(cells[..., 0], out=self.col[where], casting="unsafe")   # no float temporaries
        np.rint(cells[..., 1], out=self.row[where], casting="unsafe")
        self.ndotv[where] = cells[..., 2]
        self.coverage[where] = cells[..., 3]

    def finish(self) -> dict:
        """normal, depth, row, col, roughness, metallic, ndotv of the pixel-centre ray (-1 / NaN
        for background), and coverage: the share of the pixel's box the spheres cover (0 < c < 1
        at anti-aliased edges, whose radiance blends two surfaces)."""
        row, col = self.row, self.col
        sphere = (row >= 0) & (col >= 0)
        col[~sphere] = -1
        row[~sphere] = -1
        # Filled through the mask, so no full-size temporaries beyond the outputs.
        roughness = np.full(row.shape, np.nan, np.float32)
        metallic = np.full(row.shape, np.nan, np.float32)
        roughness[sphere] = self.spec.material_array("roughness").astype(np.float32)[row[sphere], col[sphere]]
        metallic[sphere] = self.spec.material_array("metallic").astype(np.float32)[row[sphere], col[sphere]]
        return {"normal": self.normal, "depth": self.depth, "row": row, "col": col,
                "roughness": roughness, "metallic": metallic, "ndotv": self.ndotv, "coverage": self.coverage}
