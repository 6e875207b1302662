"""The analytic edge of shaders/edge_coverage.glsl in float64: a pixel box split at a sphere's
silhouette, the silhouette distance s taken as linear across the box. Over the box s is
s0 + U_a + U_b, U_a and U_b uniform of widths a = |ds/dx| and b = |ds/dy|; the covered share
is P(s < 0), a trapezoid's CDF, and the chart shades the covered part at points of that
distribution's quantiles."""
from __future__ import annotations

import numpy as np


def box_coverage(s0, a, b):
    """P(s0 + U_a + U_b < 0): the share of the pixel box inside the silhouette."""
    s0, a, b = np.broadcast_arrays(*(np.asarray(v, np.float64) for v in (s0, a, b)))
    w_max, w_min = np.maximum(a, b), np.minimum(a, b)
    h = 0.5 * (a + b)
    y = -s0
    flat = (np.abs(y) <= 0.5 * (w_max - w_min)) | (w_min < 1e-6 * w_max)
    linear = np.clip(0.5 + y / np.where(w_max > 0, w_max, 1.0), 0.0, 1.0)
    tail = (h - np.abs(y)) ** 2 / np.where(a * b > 0, 2.0 * a * b, 1.0)
    curved = np.where(y < 0, tail, 1.0 - tail)
    out = np.where(flat, linear, curved)
    return np.where(y <= -h, 0.0, np.where(y >= h, 1.0, out))


def box_quantile(p, a, b):
    """y with P(U_a + U_b < y) = p: the inverse of the trapezoid's CDF."""
    p, a, b = np.broadcast_arrays(*(np.asarray(v, np.float64) for v in (p, a, b)))
    w_max = np.maximum(a, b)
    h = 0.5 * (a + b)
    p_tail = 0.5 * np.minimum(a, b) / np.maximum(w_max, 1e-300)   # where the flat top begins
    low = -h + np.sqrt(2.0 * a * b * p)
    high = h - np.sqrt(2.0 * a * b * np.maximum(1.0 - p, 0.0))
    return np.where(p < p_tail, low, np.where(p > 1.0 - p_tail, high, (p - 0.5) * w_max))


def edge_sample_points(centre, s0, grad, samples: int):
    """The points (..., samples, 2) at which the chart shades the covered part of the box
    centred at ``centre`` (..., 2), s0 and grad (..., 2) the silhouette distance there and its
    change per pixel: at the covered part's own quantiles (k + 1/2) / samples of s (the
    shader's edge_sample_point)."""
    centre, grad = np.asarray(centre, np.float64), np.asarray(grad, np.float64)
    a, b = np.abs(grad[..., 0]), np.abs(grad[..., 1])
    c = box_coverage(s0, a, b)
    q = (np.arange(samples) + 0.5) / samples
    y = box_quantile(c[..., None] * q, a[..., None], b[..., None])
    g2 = np.maximum((grad * grad).sum(-1), 1e-300)
    return centre[..., None, :] + grad[..., None, :] * (y / g2[..., None])[..., None]
