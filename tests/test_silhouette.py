"""The edge pass's rings (shading/silhouette.py) hold every pixel a sphere's silhouette crosses:
checked in float64 against the silhouette distance edge_coverage.glsl computes, per pixel
centre, for layouts up to 8192² and down to spheres a few pixels wide. No GL."""
import numpy as np
import pytest

from sdfpbr.shading.camera import frame_grid, sphere_centers
from sdfpbr.shading.plan import chart_frame, edge_rings
from sdfpbr.shading.silhouette import SILHOUETTE_RING_PAD_PX
from sdfpbr.spec.chart_spec import make_spec

# A pixel's box is crossed by the silhouette when its centre lies within half the box's
# diagonal of it (edge_coverage.glsl's trapezoid: |s| < (|ds/dx| + |ds/dy|) / 2); the test
# asks for a little more, so that float32 rounding in the shader cannot put one outside.
CROSSED_PX = 0.5 * np.sqrt(2.0) + 0.05


def silhouette_distance_px(cam, centre, radius, x, y):
    """Distance in pixels (first order: s / |grad s|) from pixel centres (x, y: GL pixels of
    cam's frame) to the silhouette of the sphere at ``centre``, as edge_coverage.glsl measures it."""
    def s(px, py):
        ro, rd = cam.rays(2.0 * px / cam.width - 1.0, 2.0 * py / cam.height - 1.0)
        return np.linalg.norm(np.cross(centre - ro, rd), axis=-1) - radius
    s0 = s(x, y)
    gx, gy = s(x + 1.0, y) - s0, s(x, y + 1.0) - s0
    return s0 / np.maximum(np.hypot(gx, gy), 1e-30)


def covered(triangles, x, y):
    """Which pixel centres (x, y) lie inside any of the triangles ((n, 2), three a triangle)."""
    inside = np.zeros(x.shape, bool)
    for a, b, c in triangles.reshape(-1, 3, 2).astype(np.float64):
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        pick = (x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1]) & ~inside
        if not pick.any():
            continue
        px, py = x[pick], y[pick]
        def side(p, q):
            return (q[0] - p[0]) * (py - p[1]) - (q[1] - p[1]) * (px - p[0])
        d1, d2, d3 = side(a, b), side(b, c), side(c, a)
        hit = ~(((d1 < 0) | (d2 < 0) | (d3 < 0)) & ((d1 > 0) | (d2 > 0) | (d3 > 0)))
        inside[pick] = hit
    return inside


CELLS = [dict(width=1024, height=1024), dict(width=8192, height=8192), dict(width=256, height=256, rows=64, cols=64),
         dict(width=600, height=110, rows=1, cols=11), dict(width=333, height=271, rows=3, cols=4),
         dict(camera="orthographic"), dict(camera_distance_scale=1.7), dict(camera_azimuth=40.0),
         dict(width=128, height=128, rows=2, cols=9)]


@pytest.mark.parametrize("options", CELLS, ids=[",".join(f"{k}={v}" for k, v in c.items()) for c in CELLS])
def test_a_cells_ring_holds_every_pixel_its_silhouette_crosses(options):
    spec = make_spec(**options)
    frame = chart_frame(spec)
    shapes = edge_rings(frame)
    ring, instances = shapes.triangles, shapes.instances
    assert instances == spec.rows * spec.cols
    cam = frame.camera
    y, x = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    distance = silhouette_distance_px(cam, np.zeros(3), spec.sphere_radius, x, y)
    crossed = np.abs(distance) < CROSSED_PX
    assert crossed.any()
    inside = covered(ring, x[crossed], y[crossed])
    assert inside.all(), f"{(~inside).sum()} of {crossed.sum()} crossed pixels outside the ring"
    # and the ring is no wider than it says: nothing further than its pad (plus a pixel's
    # rasterization slack) from the silhouette
    if frame.sphere_radius_px > 2 * SILHOUETTE_RING_PAD_PX + 2:   # not a disc drawn whole
        far = np.abs(distance) > SILHOUETTE_RING_PAD_PX + 1.5
        assert not covered(ring, x[far], y[far]).any()


SHARED = [dict(stage="shared", width=400, height=300), dict(stage="shared", rows=2, cols=7, width=420, height=160),
          dict(stage="shared", camera_azimuth=20.0, camera_elevation=25.0, width=512, height=512)]


@pytest.mark.parametrize("options", SHARED, ids=["default", "2x7", "orbit"])
def test_the_shared_stages_rings_hold_every_pixel_a_silhouette_crosses(options):
    spec = make_spec(**options)
    shapes = edge_rings(chart_frame(spec))
    ring, instances = shapes.triangles, shapes.instances
    assert instances == 1
    cam = frame_grid(spec)
    y, x = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    for centre in sphere_centers(spec).reshape(-1, 3):
        crossed = np.abs(silhouette_distance_px(cam, centre, spec.sphere_radius, x, y)) < CROSSED_PX
        assert crossed.any()
        assert covered(ring, x[crossed], y[crossed]).all()


def test_the_check_can_fail():
    """A ring a third of a pixel wide misses crossed pixels: the check above is not vacuous."""
    spec = make_spec(width=512, height=512)
    frame = chart_frame(spec)
    ring = edge_rings(frame, pad=0.15).triangles
    cam = frame.camera
    y, x = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    crossed = np.abs(silhouette_distance_px(cam, np.zeros(3), spec.sphere_radius, x, y)) < CROSSED_PX
    assert not covered(ring, x[crossed], y[crossed]).all()
