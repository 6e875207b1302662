"""Huge images: renders are cut into tiles no larger than the context allows; a tiled render
equals the untiled one bit for bit (so there is no seam), images wider than the GL limits
work, and host memory stays a fixed number of bytes per pixel."""
import tracemalloc

import numpy as np
import pytest

from sdfpbr.gpu.render import TILE
from sdfpbr.gpu.session import Session
from sdfpbr.spec.chart_spec import Light, make_spec

BASE = dict(width=90, height=70, rows=2, cols=3, quality="draft")
VARIANTS = [
    {},                                                        # studio IBL, AO, shadows, ground, both lights
    {"intersect": "march", "camera": "orthographic"},
    {"transparent": True, "ground": False, "spp": 3},
    {"hdr_precision": "float16", "lights": (Light("directional", direction=(0.2, 0.3, 0.93), intensity=1e5),)},
    {"env": "sky", "camera_azimuth": 35.0, "camera_elevation": 40.0, "tonemap": "neutral"},
]


def same(a, b) -> bool:
    ok = np.array_equal(a.hdr, b.hdr) and np.array_equal(a.alpha, b.alpha) and np.array_equal(a.image, b.image)
    return ok and all(np.array_equal(a.aov[k], b.aov[k], equal_nan=True) for k in a.aov)


@pytest.mark.parametrize("tile", [16, 36])
@pytest.mark.parametrize("variant", VARIANTS)
def test_tiled_render_equals_untiled(session, sibling, variant, tile):
    spec = make_spec(**BASE, **variant)
    tiled = sibling(tile=tile)
    assert tiled.tile == tile and spec.width > 2 * tile
    assert same(tiled.render(spec), session.render(spec))


@pytest.mark.parametrize("variant", VARIANTS + [{"x_axis": "exposure", "x_values": [-1.0, 0.0, 2.0], "stage": "cells"}])
@pytest.mark.parametrize("display", [{"tonemap": "reinhard-extended", "reinhard_white": 2.0},
                                     {"exposure": 1.5, "tonemap": "none"}])
def test_a_display_field_changed_redisplays_the_same_pixels_as_a_render(session, sibling, variant, display):
    """A spec that differs in display fields alone, shown from another render's radiance
    (Session.redisplay, what tone-map and exposure sweeps use), in tiles, is the image a render
    of it gives, bit for bit: the display pass reads the same texels."""
    from sdfpbr.spec.fields import same_radiance
    spec = make_spec(**BASE, **variant)
    shown = make_spec(spec, **display)
    assert same_radiance(spec, shown) and shown != spec
    tiled = sibling(tile=36)
    again = tiled.redisplay(shown, tiled.render(spec, aovs=False))
    np.testing.assert_array_equal(again.image, session.render(shown, aovs=False, hdr=False).image)
    assert not same_radiance(spec, make_spec(spec, spacing=2.6))


def test_no_step_at_tile_borders(sibling):
    """Independently of the untiled render: across a tile border neighbouring columns differ no
    more than neighbouring columns elsewhere in the same smooth region."""
    spec = make_spec(width=128, height=64, rows=1, cols=1, env="sky", ground=False, lights="none", quality="draft")
    res = sibling(tile=32).render(spec)
    steps = np.abs(np.diff(res.hdr.mean(-1), axis=1))[20:44]      # rows through the sphere and sky
    border = steps[:, [31, 63, 95]].mean()
    inside = np.delete(steps, [31, 63, 95], axis=1).mean()
    assert border <= 2 * inside


def test_tiles_follow_the_gl_limits_in_multiples_of_four(session):
    info = session.ctx.info
    limit = min(info["GL_MAX_TEXTURE_SIZE"], *info["GL_MAX_VIEWPORT_DIMS"])
    assert session.tile == min(TILE, limit)
    assert Session(session.ctx, session.cache, tile=10 ** 9).tile == limit // 4 * 4
    assert Session(session.ctx, session.cache, tile=7).tile == 4    # 4x4 blocks line up (see render.py)


def test_wider_than_the_gl_limit_renders_in_tiles(session, sibling):
    """An image wider than GL_MAX_TEXTURE_SIZE (and the viewport) cannot be one target; it
    renders in tiles and equals a render cut at other tile borders."""
    limit = session.ctx.info["GL_MAX_TEXTURE_SIZE"]
    spec = make_spec(width=limit + 100, height=3, rows=1, cols=9, quality="draft", labels=False)
    wide = sibling(tile=limit).render(spec)
    assert wide.hdr.shape == (3, limit + 100, 3) and np.isfinite(wide.hdr).all()
    assert set(np.unique(wide.aov["col"])) >= set(range(9))       # every sphere made it in
    assert same(wide, sibling(tile=4000).render(spec))


@pytest.mark.parametrize("aovs, bytes_per_pixel", [(True, 68), (False, 24)])
def test_host_memory_is_a_fixed_number_of_bytes_per_pixel(sibling, aovs, bytes_per_pixel):
    """The result holds hdr (12 B), alpha (4), image (4) and, with AOVs, normal (12), depth,
    row, col, roughness, metallic, ndotv, coverage (4 each): 60 B/pixel; tiles are read straight into
    those arrays, so the peak is that plus the AOVs' masks (~7 B) and one tile's staging."""
    spec = make_spec(width=384, height=384, rows=3, cols=3, quality="draft")
    small_tiles = sibling(tile=64)
    small_tiles.render(spec, aovs=aovs)                           # compile and bake outside the measurement
    tracemalloc.start()
    try:
        result = small_tiles.render(spec, aovs=aovs)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < bytes_per_pixel * spec.width * spec.height
    assert bool(result.aov) == aovs
