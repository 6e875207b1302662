"""The spheres' silhouettes on the image, as polygons: the rings of triangles the chart's edge
pass draws over (chart_main.glsl EDGE_PIXELS), so that only the pixels a silhouette crosses
shade its second ray, and the boxes its sphere pass draws over (SPHERE_PIXELS), so that only
the pixels near a sphere shade it."""
from __future__ import annotations

import math

import numpy as np

from .camera import Camera, silhouette


# The edge pass (chart_main.glsl EDGE_PIXELS) draws a ring of triangles this many pixels to
# either side of each silhouette. It must hold every pixel whose box the silhouette crosses:
# their centres lie within half the box's diagonal (0.71 px) of the silhouette, which its
# polygon follows within SILHOUETTE_CHORD_PX (inside it: chords cut the curve), and the ring's
# outer edge lies at least pad cos(pi / 16) = 1.96 px beyond the polygon: 0.5 px to spare.
# Few, long chords: llvmpipe shades a 4 x 4 block once for every triangle that covers part of
# it, so thin triangles cost (the 512² shared stage's rings 73-87 ms with 0.1 px chords, 58 with 0.75).
SILHOUETTE_RING_PAD_PX = 2.0
SILHOUETTE_CHORD_PX = 0.75


def silhouette_ring(cam: Camera, centers: np.ndarray, radius: float, pad: float = SILHOUETTE_RING_PAD_PX) -> np.ndarray:
    """The edge pass's triangles round the silhouettes of the spheres of ``radius`` at
    ``centers`` (n, 3) seen by ``cam``: float32 (m, 2) GL pixels of its frame, three a triangle
    (the cells stage: one sphere at the origin in a cell's frame, drawn once per cell; the
    shared stage: every sphere in the image's frame). Each ring spans ``pad`` px to either side
    of its silhouette (the whole disc where the sphere is smaller than that)."""
    triangles = [_ring_triangles(*_outline(cam, c, radius), pad) for c in centers]
    return np.concatenate(triangles).astype(np.float32)


def _outline(cam: Camera, centre, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A sphere's silhouette as a polygon whose chords stay within SILHOUETTE_CHORD_PX of it,
    and the outward unit normals at its points. A circle of rho px with n points strays
    rho (1 - cos(pi / n)) ~ rho pi^2 / (2 n^2)."""
    _, scale = cam.project(np.asarray(centre, float)[None])
    rho = float(radius * scale[0]) * 1.1   # perspective stretches the outline a little
    n = int(min(max(math.ceil(math.pi * math.sqrt(rho / (2.0 * SILHOUETTE_CHORD_PX))), 16), 4096))
    p = silhouette(cam, centre, radius, n)
    tangent = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    normal *= np.sign(np.sum(normal * (p - p.mean(axis=0)), axis=-1, keepdims=True))   # outward
    return p, normal


def _ring_triangles(p: np.ndarray, normal: np.ndarray, pad: float) -> np.ndarray:
    middle = p.mean(axis=0)
    outer = p + pad * normal
    inner = p - pad * normal
    if np.linalg.norm(p - middle, axis=-1).min() <= 2.0 * pad:
        inner[:] = middle   # a small disc: all of it
    a, b = np.roll(inner, -1, axis=0), np.roll(outer, -1, axis=0)
    return np.stack([inner, outer, b, inner, b, a], axis=1).reshape(-1, 2)


def box_triangles(box: tuple[int, int, int, int]) -> np.ndarray:
    """The cells stage's sphere pass's triangles: two, over ``box`` (x0, y0, x1, y1), a box round
    a cell's sphere's silhouette (camera.cell_sphere_box: every pixel whose ray can meet the
    sphere), in the cell's frame. A box, not a disc: a software rasterizer shades a 4 x 4 block
    once for every triangle that covers part of it, so a disc's many thin triangles cost more
    than a box's corners."""
    x0, y0, x1, y1 = box
    corners = ((x0, y0), (x1, y0), (x1, y1), (x0, y0), (x1, y1), (x0, y1))
    return np.array(corners, np.float32)
