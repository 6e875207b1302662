"""The cells stage's prepasses: what every cell shares, shaded once per cell pixel before the
chart's draw (the floor, each sphere's bounce on it, each slot's sphere), and read back by
every cell.

A prepass is a pure function of its program and what it is drawn with (the scene's uniforms, the
contents of its textures, the GL implementation), so it is kept in the disk cache under a key of
all of them: a chart drawn again (a docs build, a second `sdfpbr chart`) reads its prepasses
instead of compiling and drawing their programs, which on llvmpipe with Mesa's shader
cache cold is most of a start (BENCHMARKS.md). A prepass drawn with a texture whose content has no
key (a user's surface maps) is drawn every time; so is one whose program reads a uniform the
scene does not set (its value would not be in the key)."""
from __future__ import annotations

import functools
import hashlib
import math
from pathlib import Path

import moderngl
import numpy as np

from ..cache import content_key
from ..shading.compose import ComposedSource
from ..shading.plan import RenderPlan
from . import loop_guard
from .frame import SceneBindings, array_key, table_texture
from .programs import set_uniforms

PREPASS_KIND = "prepasses"   # the disk cache's kind for prepasses
# Prepasses kept on disk at most this big (their drawn texels). What the cache saves is mostly the
# prepasses' compile, the same at every size; what it costs (disk, the read-back and the packed
# copy in memory) grows with the image: a 2048² default chart's prepasses (11.5 + 2.8 + 1.5 MB)
# are kept, a 4096² one's sphere prepass (46 MB) is drawn each time.
PREPASS_CACHE_MAX_BYTES = 16 << 20


# What the prepass passes bind onto the scene, each frame anew: a frame's prepasses are keyed by the
# scene without the last frame's.
PREPASS_TEXTURES = ("u_floor_prepass", "u_bounce_cache", "u_bounce_prepass", "u_gather_prepass", "u_slot_cells",
                    "u_sphere_slots", "u_sphere_prepass")
PREPASS_UNIFORMS = ("u_prepass_origin", "u_bounce_cache_tile", "u_bounce_cache_drawn", "u_bounce_tile",
                    "u_bounce_step", "u_gather_tile", "u_gather_step", "u_sphere_origin", "u_sphere_tile",
                    "u_sphere_tiles_x")


def bind_frame(session, plan: RenderPlan, scene: SceneBindings, programs, cached: bool = True) -> None:
    """The per-frame work before the chart's draw: the cells stage's prepasses (passes of their
    own, part of what a frame costs), then every binding onto ``programs`` (the chart's).
    ``cached``: prepasses are read from and kept in the disk cache (the bench's draw timing
    draws them)."""
    scene.forget(PREPASS_TEXTURES, PREPASS_UNIFORMS)
    if plan.floor_prepass is not None:
        _floor_prepass(session, plan, scene, cached)
    if plan.bounce_cache is not None:
        _bounce_cache(session, plan, scene, cached)
    if plan.bounce_prepass is not None:
        _bounce_prepass(session, plan, scene, cached)
    if plan.gather_prepass is not None:
        _gather_prepass(session, plan, scene, cached)
    if plan.sphere_prepass is not None:
        _sphere_prepass(session, plan, scene, cached)
    bindings = scene.bind()
    for program in programs:
        set_uniforms(program, bindings)


@functools.cache
def code_digest() -> str:
    """sha256 of the Python that makes a prepass's inputs and reads it back (texture layouts,
    sampler states, uploads): gpu/ and shading/. A cache outlives upgrades."""
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent.parent
    for path in sorted([*root.joinpath("gpu").glob("*.py"), *root.joinpath("shading").glob("*.py")]):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def prepass_key(session, plan: RenderPlan, source: ComposedSource, scene: SceneBindings, size: tuple[int, int],
                boxes: list | None) -> str | None:
    """What a prepass drawn by ``source`` with ``scene`` now is made of: the program's text (and
    its vertex stage's), the prepass's size and drawn boxes, every uniform and every bound
    texture's content key, the code that makes them (code_digest) and the GL implementation
    (drivers round differently). None where a bound texture has no key."""
    textures = scene.texture_keys()
    if any(key is None for key in textures.values()):
        return None
    uniforms = {name: _plain(value) for name, value in scene.uniforms.items() if name not in textures}
    return content_key("prepass", source.text, plan.vertex.text, list(size), boxes, uniforms, textures,
                       code_digest(), session.renderer)


def _plain(value):
    """A uniform's value as JSON holds it exactly (floats by their shortest repr, arrays by key)."""
    if isinstance(value, np.ndarray):
        return array_key(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _reads_only_the_scene(program, scene: SceneBindings) -> bool:
    """Everything ``program`` reads but its vertex attributes -- uniforms, samplers, blocks --
    is set by the scene (else its value, left on the program by an earlier draw, would be
    missing from the key)."""
    return all(name in scene.uniforms for name in program
               if not isinstance(program[name], moderngl.Attribute) and name not in loop_guard.NAMES)


def _prepass(session, plan: RenderPlan, source: ComposedSource, scene, size: tuple[int, int],
             boxes: list | None = None, cached: bool = True) -> tuple[moderngl.Texture, str | None]:
    """A float texture of ``size`` drawn by ``source`` with the scene's bindings (or read from
    the disk cache), filtered bilinearly between texel centres and clamped at its edges, and its
    key (None: not kept). ``boxes``: only these (x, y, width, height) texel boxes are drawn, the
    rest is 0."""
    ctx = session.ctx
    key = prepass_key(session, plan, source, scene, size, boxes) if cached else None
    count = sum(w * h for _, _, w, h in boxes) if boxes is not None else size[0] * size[1]
    kept = key is not None and count * 16 <= PREPASS_CACHE_MAX_BYTES   # RGBA float32
    stored = session.cache.get(PREPASS_KIND, key, require_finite=False) if kept else None
    if stored is not None:   # a bug's prepass may hold NaN on purpose: the checksum guards the entry
        prepass = _upload(ctx, stored["texels"], size, boxes)
    else:
        prepass, texels = _draw_prepass(session, source, scene, size, boxes, read=kept)
        if key is not None and not _reads_only_the_scene(session.programs.fragment(source), scene):
            key = None   # not all of what it was drawn with is in the key
        if key is not None and texels is not None:
            session.cache.put(PREPASS_KIND, key, {"texels": texels})
    prepass.repeat_x = prepass.repeat_y = False
    prepass.filter = (moderngl.LINEAR, moderngl.LINEAR)
    return prepass, key


def _draw_prepass(session, source: ComposedSource, scene, size: tuple[int, int], boxes: list | None,
                  read: bool) -> tuple[moderngl.Texture, np.ndarray | None]:
    """The prepass drawn, and with ``read`` its texels as the cache keeps them (_unpack)."""
    ctx = session.ctx
    program = session.programs.fragment(source)
    prepass = ctx.texture(size, 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[prepass])
    vao = ctx.vertex_array(program, [])
    guard = loop_guard.LoopGuard(ctx)
    try:
        fbo.use()
        set_uniforms(program, scene.bind())
        guard.arm(program)
        if boxes is None:
            vao.render(moderngl.TRIANGLES, vertices=3)
        else:
            fbo.clear()
            for box in boxes:
                fbo.scissor = box
                vao.render(moderngl.TRIANGLES, vertices=3)
            fbo.scissor = None
        cut = guard.cut()
        if cut:   # drawn wrong: neither used nor kept
            raise loop_guard.cut_error(session.renderer, cut, "this chart's prepass of its stage")
        # GL rows, bottom first; only the boxes' texels where it has them (glReadPixels of a
        # box: reading the whole sphere prepass took 35 ms at 1024² on llvmpipe).
        texels = None if not read else np.concatenate([
            np.frombuffer(fbo.read(viewport=box, components=4, dtype="f4"), np.float32)
            for box in (boxes or [(0, 0, *size)])])
    except BaseException:
        prepass.release()
        raise
    finally:
        guard.release()
        vao.release()
        fbo.release()
    return prepass, texels


def _upload(ctx, packed: np.ndarray, size: tuple[int, int], boxes: list | None) -> moderngl.Texture:
    """The prepass from what the cache keeps (all its texels, or its boxes' in order, the rest 0),
    written box by box: no full-size copy on the host."""
    if boxes is None:
        return ctx.texture(size, 4, np.ascontiguousarray(packed), dtype="f4")
    prepass = ctx.texture(size, 4, dtype="f4")
    try:
        fbo = ctx.framebuffer(color_attachments=[prepass])
        try:
            fbo.clear()
        finally:
            fbo.release()
        at = 0
        for x, y, w, h in boxes:
            prepass.write(np.ascontiguousarray(packed[at:at + w * h * 4]), viewport=(x, y, w, h))
            at += w * h * 4
    except BaseException:
        prepass.release()
        raise
    return prepass


def _floor_prepass(session, plan: RenderPlan, scene, cached: bool) -> None:
    """The cells stage's floor, shaded once per cell pixel (stage_floor_main.glsl): a float
    texture of the prepass's size, read back by every cell (bilinear filtering between texel
    centres, for the anti-aliased edges' and extra samples' positions)."""
    origin, size = plan.frame.prepass
    scene.uniforms["u_prepass_origin"] = origin
    scene.replace_texture("u_floor_prepass", *_prepass(session, plan, plan.floor_prepass, scene, size, cached=cached))


def _bounce_cache(session, plan: RenderPlan, scene, cached: bool) -> None:
    """Each cell's bounce cache (bounce_cache.glsl), drawn plan.bounce_iterations times, each
    draw reading the last (all zero before the first): one more round trip between the sphere
    and its floor a draw. A tile of bounce_cache_tile texels a side per cell."""
    grid = plan.frame.grid
    tile = plan.bounce_cache_tile
    size = (grid.cols * tile, grid.rows * tile)
    scene.uniforms.update(u_bounce_cache_tile=tile, u_bounce_cache_drawn=False)
    zero = np.zeros((1, 1, 4), np.float32)   # bound, never read (u_bounce_cache_drawn)
    scene.replace_texture("u_bounce_cache", session.ctx.texture((1, 1), 4, zero, dtype="f4"), key=array_key(zero))
    for _ in range(plan.bounce_iterations):
        scene.replace_texture("u_bounce_cache", *_prepass(session, plan, plan.bounce_cache, scene, size,
                                                          cached=cached))
        scene.uniforms["u_bounce_cache_drawn"] = True


def _prepass_grid(session, plan: RenderPlan, step: int) -> tuple[tuple[int, int], int]:
    """A tile per cell of texels ``step`` cell pixels apart over the prepass's extent, one more
    texel past its far edge so that every position interpolates; coarser for an image so wide
    that the tiles would not fit one texture. (tile, step)."""
    grid = plan.frame.grid
    _, (width, height) = plan.frame.prepass
    while True:
        tile = (math.ceil((width - 0.5) / step) + 1, math.ceil((height - 0.5) / step) + 1)
        if max(grid.cols * tile[0], grid.rows * tile[1]) <= session.max_texture_size:
            return tile, step
        step *= 2


def _bounce_prepass(session, plan: RenderPlan, scene, cached: bool) -> None:
    """Each cell's sphere's bounce on its floor (stage_bounce_main.glsl) on _prepass_grid's texels
    ``bounce_step`` cell pixels apart. The bounce varies over the sphere's size (as its form
    factor, ~ 1/d^2 at distance d): with h = R / 8 between texels, bilinear interpolation errs
    by about 0.75 (h / R)^2 of it (1.2 %) on the floor nearest the sphere, less further out
    (tests/test_stage.py)."""
    grid = plan.frame.grid
    tile, step = _prepass_grid(session, plan, plan.bounce_step)
    scene.uniforms.update(u_prepass_origin=plan.frame.prepass[0], u_bounce_tile=tile, u_bounce_step=float(step))
    size = (grid.cols * tile[0], grid.rows * tile[1])
    scene.replace_texture("u_bounce_prepass", *_prepass(session, plan, plan.bounce_prepass, scene, size, cached=cached))


def _gather_prepass(session, plan: RenderPlan, scene, cached: bool) -> None:
    """Each cell's sphere's light back from its bounce cache (stage_gather_main.glsl) on
    _prepass_grid's texels half the bounce prepass's step apart, drawn only over each tile's texels
    round the sphere's box (one texel beyond it each way, for the interpolation)."""
    grid = plan.frame.grid
    (ox, oy), _ = plan.frame.prepass
    tile, step = _prepass_grid(session, plan, max(plan.bounce_step // 2, 1))
    scene.uniforms.update(u_prepass_origin=(ox, oy), u_gather_tile=tile, u_gather_step=float(step))
    x0, y0, x1, y1 = plan.frame.sphere_box

    def span(lo, hi, origin, count):   # texels whose centre (origin + 0.5 + i step) is within a texel of [lo, hi]
        first = max(math.floor((lo - origin - 0.5) / step), 0)
        return first, min(math.ceil((hi - origin - 0.5) / step) + 1, count - 1) - first + 1
    (bx, bw), (by, bh) = span(x0, x1, ox, tile[0]), span(y0, y1, oy, tile[1])
    boxes = [(c * tile[0] + bx, r * tile[1] + by, bw, bh) for r in range(grid.rows) for c in range(grid.cols)]
    size = (grid.cols * tile[0], grid.rows * tile[1])
    scene.replace_texture("u_gather_prepass", *_prepass(session, plan, plan.gather_prepass, scene, size, boxes,
                                                        cached))


def _sphere_prepass(session, plan: RenderPlan, scene, cached: bool) -> None:
    """Each slot's sphere at metallic 0 and 1 once per cell pixel (stage_sphere_main.glsl), and
    the table of each cell's slot the chart mixes them by (shading/cells.py), each tile over
    the cell's pixels near its sphere (the frame's sphere box)."""
    layout = plan.sphere_layout
    ctx = session.ctx
    scene.uniforms.update(u_sphere_origin=layout.origin, u_sphere_tile=layout.tile, u_sphere_tiles_x=layout.tiles_x)
    for name, table in (("u_slot_cells", np.array([layout.slot_cells])), ("u_sphere_slots", layout.slots)):
        scene.replace_texture(name, table_texture(ctx, table), key=array_key(table))
    # Each tile only where its sphere can be: a software rasterizer would shade the sphere
    # for the floor's texels too (it runs both sides of a branch). Boxes, not the disc: it
    # shades a 4 x 4 block once for each triangle that covers part of it, so a disc's many
    # triangles cost more than the box's corners (measured: 28 -> 31-38 ms at 1024²).
    x0, y0, x1, y1 = plan.frame.sphere_box
    ox, oy = layout.origin
    tw, th = layout.tile
    x0, y0, x1, y1 = max(x0 - ox, 0), max(y0 - oy, 0), min(x1 - ox, tw), min(y1 - oy, th)
    boxes = [((i % layout.tiles_x) * tw + x0, (i // layout.tiles_x) * th + y0, x1 - x0, y1 - y0)
             for i in range(2 * len(layout.slot_cells))]
    prepass, key = _prepass(session, plan, plan.sphere_prepass, scene, layout.size, boxes, cached)
    prepass.filter = (moderngl.NEAREST, moderngl.NEAREST)
    scene.replace_texture("u_sphere_prepass", prepass, key=key)
