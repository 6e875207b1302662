"""How far in from each border of a cells-stage cell the shadow catcher fades out.

A cell's floor is its own: the sphere's long soft shadows (a low fill light's, the studio's
occlusion) still take ~10 % of the floor's light at the cell's border, where the next cell's
floor starts clear, so a page would show every cell's edge. The catcher's alpha therefore fades
to nothing towards each border (catcher_fade.glsl; the chart and the reference alike), over as
wide a band as each side allows: up to CATCHER_BAND_MAX of the cell's width (sides) or height
(top, bottom), but short of the shadows of the main lights -- those giving at least
MAIN_LIGHT_SHARE of the strongest one's floor illuminance -- penumbra included, so that those
stay whole; never under CATCHER_BAND_MIN, which the default key light's shadow clears on square
and wide cells (it keeps 7.5 % of a square cell's side). A narrow band makes a visible edge
where a long shadow is cut; a wide one on the sides the main shadows leave free fades it out
like a falling light. Where a main shadow comes nearer its border than CATCHER_BAND_MIN (cells
much taller than wide: the key light's shadow ends 2.4 % of a 93 x 450 cell's width from its
right side) no band can leave it whole, and the narrowest one would cut it within a few
pixels; there the band widens the deeper the shadow reaches into it, up to CATCHER_BAND_MAX
for a shadow at the border, so that it fades out instead."""
from __future__ import annotations

import functools
import math

import numpy as np

from ..spec.chart_spec import ChartSpec, make_spec
from .camera import frame_cell
from .cells import CellGrid

CATCHER_BAND_MIN = 0.07
CATCHER_BAND_MAX = 0.25    # the sphere's silhouette starts at 0.19 of a square cell's width
MAIN_LIGHT_SHARE = 0.25
SHADOW_GRID = 128          # floor points across the cell's shorter side where the shadows are found


def catcher_bands(spec: ChartSpec, grid: CellGrid) -> tuple[float, float, float, float]:
    """(left, right, top, bottom): each border's fade band as a share of the width (left, right)
    or height (top, bottom) of a cell of ``grid``, ``spec``'s cells."""
    scale = min(SHADOW_GRID / min(grid.cell_width, grid.cell_height),
                8 * SHADOW_GRID / max(grid.cell_width, grid.cell_height))
    w, h = max(2, round(grid.cell_width * scale)), max(2, round(grid.cell_height * scale))
    return _bands(spec.camera, spec.camera_azimuth, spec.camera_distance_scale, spec.sphere_radius, w, h,
                  tuple(main_lights(spec)))


def catcher_band_pixels(spec: ChartSpec, grid: CellGrid) -> tuple[float, float, float, float]:
    """catcher_fade.glsl's u_catcher_band: the bands in pixels, (left, right, bottom, top) in GL
    order (y up)."""
    left, right, top, bottom = catcher_bands(spec, grid)
    return (left * grid.cell_width, right * grid.cell_width, bottom * grid.cell_height, top * grid.cell_height)


def main_lights(spec: ChartSpec) -> list:
    """The lights whose shadows the fade leaves whole: those lighting the floor under the sphere
    with at least MAIN_LIGHT_SHARE of the strongest one's illuminance."""
    foot = np.array([0.0, -spec.sphere_radius, 0.0])

    def floor_illuminance(light) -> float:
        if light.kind == "directional":
            d = np.asarray(light.direction, float)
            return light.intensity * max(d[1] / np.linalg.norm(d), 0.0)
        to_light = np.asarray(light.position, float) - foot
        distance = float(np.linalg.norm(to_light))
        return light.intensity * max(to_light[1] / distance, 0.0) / max(distance * distance, 1e-12)

    lights = [light for light in spec.lights if light.kind in ("directional", "point")]
    strongest = max((floor_illuminance(light) for light in lights), default=0.0)
    return [light for light in lights if strongest > 0 and floor_illuminance(light) >= MAIN_LIGHT_SHARE * strongest]


@functools.lru_cache(maxsize=64)
def _bands(camera: str, azimuth: float, distance_scale: float, radius: float, width: int, height: int,
           lights: tuple) -> tuple[float, float, float, float]:
    spec = make_spec(stage="cells", rows=1, cols=1, width=width, height=height, camera=camera,
                     camera_azimuth=azimuth, camera_distance_scale=distance_scale, sphere_radius=radius)
    ro, rd = frame_cell(spec, (width, height)).pixel_rays()
    down = rd[..., 1] < 0
    t = np.where(down, (-radius - ro[..., 1]) / np.where(down, rd[..., 1], -1.0), 0.0)
    points = ro + t[..., None] * rd                       # the floor point of each pixel (the sphere at the origin)
    shadowed = np.zeros(down.shape, bool)
    for light in lights:
        if light.kind == "directional":
            to_light = np.broadcast_to(np.asarray(light.direction, float), points.shape)
            size = math.radians(light.angular_radius_deg)
        else:
            to_light = np.asarray(light.position, float) - points
            size = np.arcsin(np.minimum(light.radius / np.linalg.norm(to_light, axis=-1), 1.0))
        reach = np.linalg.norm(to_light, axis=-1) if light.kind == "point" else np.inf
        to_light = to_light / np.linalg.norm(to_light, axis=-1, keepdims=True)
        distance = np.linalg.norm(points, axis=-1)
        apart = np.arccos(np.clip((-points / distance[..., None] * to_light).sum(-1), -1.0, 1.0))
        # The light's disc touches the sphere's as seen from the floor point (umbra or penumbra),
        # and the sphere lies between the two (a point light may be nearer than the sphere).
        between = (-points * to_light).sum(-1) < reach
        shadowed |= down & between & (apart < np.arcsin(np.minimum(radius / distance, 1.0)) + size)
    ys, xs = np.nonzero(shadowed)
    if not len(xs):
        return (CATCHER_BAND_MAX,) * 4
    margin = 1.5   # grid points between the fade and the shadow
    nearest = (xs.min() / width, (width - 1 - xs.max()) / width, ys.min() / height, (height - 1 - ys.max()) / height)
    margins = (margin / width,) * 2 + (margin / height,) * 2
    return tuple(band_for_shadow_at(depth, share) for depth, share in zip(nearest, margins))


def band_for_shadow_at(depth: float, margin: float) -> float:
    """A side's band when the nearest main shadow lies ``depth`` (a share of the cell) from its
    border: up to ``margin`` short of it, between CATCHER_BAND_MIN and CATCHER_BAND_MAX; a
    shadow inside the narrowest band widens it linearly, to CATCHER_BAND_MAX at depth 0."""
    if depth < CATCHER_BAND_MIN:   # depth >= 0: a share of the cell
        return float(CATCHER_BAND_MIN
                     + (CATCHER_BAND_MAX - CATCHER_BAND_MIN) * (CATCHER_BAND_MIN - depth) / CATCHER_BAND_MIN)
    return float(min(max(depth - margin, CATCHER_BAND_MIN), CATCHER_BAND_MAX))
