"""A camera that frames the sphere grid (or each cell's sphere), and the projection the chart
labels use. Both the shader (through these uniforms) and the layout use this one definition;
the plan picks a spec's camera once (shading/plan.py chart_frame)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..spec.chart_spec import ChartSpec
from .cells import CELL_FILL

FOV_Y_DEG = 30.0
MARGIN = 1.06


@dataclass(frozen=True)
class Camera:
    position: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    half_height: float          # tan(fov/2) (perspective) or half view height (orthographic)
    orthographic: bool
    width: int
    height: int

    def uniforms(self) -> dict:
        return {"u_cam_position": tuple(self.position), "u_cam_right": tuple(self.right),
                "u_cam_up": tuple(self.up), "u_cam_forward": tuple(self.forward),
                "u_cam_half_height": self.half_height, "u_resolution": (self.width, self.height)}

    def rays(self, ndc_x, ndc_y) -> tuple[np.ndarray, np.ndarray]:
        """Ray origins and unit directions (..., 3), float64, through points of the view in
        NDC (x right, y up, -1..1 across it), as camera.glsl's camera_ray makes them."""
        sx = (np.asarray(ndc_x, float) * (self.width / self.height) * self.half_height)[..., None]
        sy = (np.asarray(ndc_y, float) * self.half_height)[..., None]
        if self.orthographic:
            ro = self.position + sx * self.right + sy * self.up
            return ro, np.broadcast_to(self.forward, ro.shape)
        rd = self.forward + sx * self.right + sy * self.up
        rd = rd / np.linalg.norm(rd, axis=-1, keepdims=True)
        return np.broadcast_to(self.position, rd.shape), rd

    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Ray origins and unit directions (height, width, 3) through the centres of the view's
        pixels, row 0 on top."""
        ys, xs = np.mgrid[0:self.height, 0:self.width]
        return self.rays(2 * (xs + 0.5) / self.width - 1, 1 - 2 * (ys + 0.5) / self.height)

    def pixel_size(self, distance=1.0):
        """The world size of a pixel at ``distance`` along its ray (camera.glsl pixel_footprint)."""
        pixel = 2.0 * self.half_height / self.height
        distance = np.asarray(distance, float)
        return np.full_like(distance, pixel) if self.orthographic else pixel * distance

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (x right, y down, origin top-left) and the scale in px per world unit."""
        rel = np.asarray(points, float) - self.position
        x, y, z = rel @ self.right, rel @ self.up, rel @ self.forward
        aspect = self.width / self.height
        scale = np.full_like(z, 1.0) if self.orthographic else z
        ndc_x = x / (scale * self.half_height * aspect)
        ndc_y = y / (scale * self.half_height)
        px = np.stack([(ndc_x + 1) * 0.5 * self.width, (1 - ndc_y) * 0.5 * self.height], axis=-1)
        return px, 0.5 * self.height / (scale * self.half_height)


def sphere_centers(spec: ChartSpec) -> np.ndarray:
    """(rows, cols, 3) centres, row 0 on top, as in scene.glsl."""
    s = spec.spacing
    hx, hy = 0.5 * (spec.cols - 1) * s, 0.5 * (spec.rows - 1) * s
    cols = np.arange(spec.cols) * s - hx
    rows = hy - np.arange(spec.rows) * s
    c = np.zeros((spec.rows, spec.cols, 3))
    c[..., 0] = cols[None, :]
    c[..., 1] = rows[:, None]
    return c


def ground_height(spec: ChartSpec) -> float:
    """The floor's height: under the bottom row (shared stage), or under each sphere, which
    rests on it (cells stage, where every sphere sits at its own origin)."""
    if spec.stage == "cells":
        return -spec.sphere_radius
    return -0.5 * (spec.rows - 1) * spec.spacing - spec.sphere_radius


# ---- the cells stage: one camera per cell, the same for every cell ---------------------------
# Looking down this far keeps the floor's horizon above the top of every cell (the vertical
# field of view is FOV_Y_DEG), so each sphere stands on a seamless floor.
CELL_ELEVATION_DEG = 24.0
def frame_cell(spec: ChartSpec, cell_size: tuple[int, int]) -> Camera:
    """The camera of every cell, ``cell_size`` (width, height) pixels: it looks at its sphere,
    centred at the origin, from above."""
    cell_width, cell_height = cell_size
    aspect = cell_width / cell_height
    need = spec.sphere_radius / CELL_FILL * max(1.0, 1.0 / aspect)
    elev, azim = math.radians(CELL_ELEVATION_DEG), math.radians(spec.camera_azimuth)
    forward = np.array([-math.sin(azim) * math.cos(elev), -math.sin(elev), -math.cos(azim) * math.cos(elev)])
    right = np.array([math.cos(azim), 0.0, -math.sin(azim)])
    up = np.cross(right, forward)
    if spec.camera == "orthographic":
        position = -forward * 8.0 * spec.sphere_radius * spec.camera_distance_scale
        return Camera(position, right, up, forward, need, True, cell_width, cell_height)
    tan_half = math.tan(math.radians(FOV_Y_DEG) / 2)
    distance = need / tan_half * spec.camera_distance_scale
    return Camera(-forward * distance, right, up, forward, tan_half, False, cell_width, cell_height)


def silhouette(cam: Camera, centre, radius: float, points: int = 256) -> np.ndarray:
    """(points, 2) GL pixels (x right, y up from the lower-left of cam's frame) on the
    silhouette of the sphere at ``centre``: the circle where the rays from the eye touch it (the
    great circle facing the view, for an orthographic camera), projected."""
    centre = np.asarray(centre, float)
    if cam.orthographic:
        middle, ring, axis = centre, radius, cam.forward
    else:
        to_eye = cam.position - centre
        d = float(np.linalg.norm(to_eye))
        axis = to_eye / d
        middle, ring = centre + axis * (radius * radius / d), radius * math.sqrt(max(1.0 - (radius / d) ** 2, 0.0))
    u = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    angle = np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)[:, None]
    px, _ = cam.project(middle + ring * (np.cos(angle) * u + np.sin(angle) * w))
    return np.stack([px[:, 0], cam.height - px[:, 1]], axis=-1)


def cell_sphere_box(cam: Camera, radius: float, pad: float = 2.0) -> tuple[int, int, int, int]:
    """The pixels of a cell seen by ``cam`` (GL frame: x right, y up from the cell's lower-left)
    whose box comes within ``pad`` px of the silhouette of its sphere of ``radius``: (x0, y0,
    x1, y1), x1 and y1 past the end. The silhouette is projected from 256 of its points, whose
    polygon's edges pass within ring (1 - cos(pi / 256)) of the circle: far under pad."""
    px = silhouette(cam, np.zeros(3), radius)
    x0, x1 = px[:, 0].min() - pad, px[:, 0].max() + pad
    y0, y1 = px[:, 1].min() - pad, px[:, 1].max() + pad
    return math.floor(x0), math.floor(y0), math.ceil(x1), math.ceil(y1)


def sphere_discs(cam: Camera, centers: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of ``radius`` at ``centers`` (..., 3) on ``cam``'s image: (..., 2) centres and
    (...) radii in pixels (the projection's scale at each centre; <= 0 behind the camera)."""
    px, scale = cam.project(centers.reshape(-1, 3))
    return px.reshape(*centers.shape[:-1], 2), (radius * scale).reshape(centers.shape[:-1])


def silhouettes_apart(px: np.ndarray, radius: np.ndarray) -> bool:
    """Whether every pixel lies near one sphere's silhouette at most: no two neighbouring
    spheres of a grid, (rows, cols, 2) centres ``px`` and (rows, cols) radii ``radius`` on the
    image (sphere_discs), come within a pixel of each other (the cells stage's never do; the
    shared stage's may, seen from far round or above). The analytic edge needs it."""
    if np.any(radius <= 0):
        return False
    rows, cols = radius.shape
    radius = radius * 1.02   # perspective widens
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = (slice(0, rows - dr), slice(max(0, -dc), cols - max(0, dc)))
        b = (slice(dr, rows), slice(max(0, dc), cols + min(0, dc)))
        gap = np.linalg.norm(px[a] - px[b], axis=-1) - radius[a] - radius[b]
        if gap.size and gap.min() < 1.0:
            return False
    return True


def frame_grid(spec: ChartSpec) -> Camera:
    half_w = 0.5 * (spec.cols - 1) * spec.spacing + spec.sphere_radius
    half_h = 0.5 * (spec.rows - 1) * spec.spacing + spec.sphere_radius
    aspect = spec.width / spec.height
    need = max(half_h, half_w / aspect) * MARGIN
    elev, azim = math.radians(spec.camera_elevation), math.radians(spec.camera_azimuth)
    # Azimuth 0 looks down -z at the grid's front; positive azimuth orbits towards +x.
    forward = np.array([-math.sin(azim) * math.cos(elev), -math.sin(elev), -math.cos(azim) * math.cos(elev)])
    right = np.array([math.cos(azim), 0.0, -math.sin(azim)])
    up = np.cross(right, forward)
    if spec.camera == "orthographic":
        position = -forward * (need * 4.0 + 4.0 * spec.sphere_radius) * spec.camera_distance_scale
        return Camera(position, right, up, forward, need, True, spec.width, spec.height)
    tan_half = math.tan(math.radians(FOV_Y_DEG) / 2)
    distance = (need / tan_half + spec.sphere_radius) * spec.camera_distance_scale
    return Camera(-forward * distance, right, up, forward, tan_half, False, spec.width, spec.height)
