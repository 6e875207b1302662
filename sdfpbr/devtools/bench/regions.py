"""The regions of a chart's image that the bench judges one by one: each sphere's upper and
lower half, its silhouette pixels, the floor under its bulge (closer than R to its axis), the
ring just outside it (FLOOR_RING), the far floor and the background. Found by float64 rays
through each pixel, the scene's own geometry: the random-scene suite and the peer renderer
both judge by these masks."""
from __future__ import annotations

import numpy as np

from ...spec.chart_spec import ChartSpec

FLOOR_RING = (1.0, 1.3)        # the ring round the sphere's foot, in radii from its axis
SUBPIXELS = 4                  # rays a side per pixel when finding silhouette pixels
REGIONS = ("sphere_upper", "sphere_lower", "silhouette", "floor_bulge", "floor_ring", "floor_far", "background")


def _pixel_local(spec: ChartSpec, frame) -> tuple[np.ndarray, np.ndarray]:
    """Each image pixel's lower-left corner in its view's pixels (GL: x right, y up): its cell's
    (margins belong to the nearest cell, as sdfpbr's cell_grid.glsl has it) or the image's."""
    ys, xs = np.mgrid[0:spec.height, 0:spec.width]
    gy = spec.height - 1 - ys
    if frame.stage != "cells":
        return xs.astype(np.float64), gy.astype(np.float64)
    grid = frame.grid
    bottom = spec.height - grid.top - grid.rows * grid.cell_height
    ix = np.minimum(np.maximum(xs - grid.left, 0) // grid.cell_width, grid.cols - 1)
    iy = np.minimum(np.maximum(gy - bottom, 0) // grid.cell_height, grid.rows - 1)
    return ((xs - grid.left - ix * grid.cell_width).astype(np.float64),
            (gy - bottom - iy * grid.cell_height).astype(np.float64))


def _trace(origins, dirs, centres, radius: float, ground_y: float | None):
    """Closest hits of rays (..., 3) on spheres and the floor, float64: (t, sphere index or -1
    for the floor, -2 for none)."""
    best = np.full(dirs.shape[:-1], np.inf)
    what = np.full(dirs.shape[:-1], -2, np.int64)
    if ground_y is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ground_y - origins[..., 1]) / dirs[..., 1]
        hit = (dirs[..., 1] < 0) & (t > 0)
        best = np.where(hit, t, best)
        what = np.where(hit, -1, what)
    for k, centre in enumerate(centres):
        oc = origins - centre
        b = np.sum(oc * dirs, axis=-1)
        c = np.sum(oc * oc, axis=-1) - radius * radius
        disc = b * b - c
        t = -b - np.sqrt(np.maximum(disc, 0.0))
        hit = (disc >= 0) & (t > 0) & (t < best)
        best = np.where(hit, t, best)
        what = np.where(hit, k, what)
    return best, what


def region_masks(spec: ChartSpec) -> dict[str, np.ndarray]:
    """(H, W) bool per region of REGIONS, from pixel-centre rays traced in float64: the sphere's
    upper and lower half (normal up or down), silhouette pixels (some of SUBPIXELS^2 rays per
    pixel meet a sphere, some do not), the floor by its distance rho from the nearest sphere's
    axis (under the bulge rho < R, the ring FLOOR_RING, beyond it far) and the background."""
    from ...shading.plan import reference_plan
    frame = reference_plan(spec).frame
    spec = frame.spec
    cam = frame.camera
    lx, ly = _pixel_local(spec, frame)
    centres = np.zeros((1, 3)) if frame.stage == "cells" else frame.sphere_centers.reshape(-1, 3)
    ground = float(frame.ground_y) if spec.ground else None
    r = spec.sphere_radius

    def trace(ox, oy):
        ro, rd = cam.rays(2.0 * (lx + ox) / cam.width - 1.0, 2.0 * (ly + oy) / cam.height - 1.0)
        ro = np.broadcast_to(ro, rd.shape)
        t, what = _trace(ro, rd, centres, r, ground)
        return ro, rd, t, what

    on_sphere = np.zeros(lx.shape, np.int64)
    for a in range(SUBPIXELS):
        for b in range(SUBPIXELS):
            _, _, _, what = trace((a + 0.5) / SUBPIXELS, (b + 0.5) / SUBPIXELS)
            on_sphere += what >= 0
    edge = (on_sphere > 0) & (on_sphere < SUBPIXELS * SUBPIXELS)
    ro, rd, t, what = trace(0.5, 0.5)
    p = ro + rd * np.where(np.isfinite(t), t, 0.0)[..., None]
    sphere = (what >= 0) & ~edge
    normal_y = np.where(sphere, (p[..., 1] - centres[np.maximum(what, 0), 1]) / r, 0.0)
    rho = np.min(np.hypot(p[..., None, 0] - centres[:, 0], p[..., None, 2] - centres[:, 2]), axis=-1)
    floor = (what == -1) & ~edge
    return {"sphere_upper": sphere & (normal_y > 0), "sphere_lower": sphere & (normal_y <= 0), "silhouette": edge,
            "floor_bulge": floor & (rho < r),
            "floor_ring": floor & (rho >= FLOOR_RING[0] * r) & (rho < FLOOR_RING[1] * r),
            "floor_far": floor & (rho >= FLOOR_RING[1] * r), "background": (what == -2) & ~edge}
