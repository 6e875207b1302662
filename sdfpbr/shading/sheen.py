"""Where the sheen lobe gathers its light, for the chart's sheen under the environment
(lobes_ibl.glsl): the mean direction c of its light, c = integral of l f_s N.L dl / E_s (sheen
colour 1), as (c_n, c_t) along N and along T, the tangent towards V. The Charlie lobe leans away
from N towards V and the horizon (back-scatter): at r 0.5 and N.V 0.5 its axis is 36 degrees off
N. Read along N, the irradiance missed it: a sphere's lower half got its floor for its sheen
(0.56-0.61 of the float64 integral under a sky over a floor five times darker), its upper half
the sky (1.39-1.59); read along c's axis with c's length, 0.95-1.07 (docs/lobes.md)."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..oracle.lobes import d_charlie, v_sheen
from ..oracle.mirror import MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS, gauss_legendre01

# The table's grid: sqrt(1 - N.V) from 0 to 1 (fine near normal incidence, where a smooth
# sheen's axis swings from N to the horizon), the sheen's perceptual roughness from 0 to 1.
SHEEN_CENTROID_STEPS = (17, 9)


def sheen_centroid(n_dot_v, sheen_roughness, n: int = 96) -> np.ndarray:
    """(c_n, c_t) of the sheen lobe at N.V and sheen roughness (broadcast), float64, by a
    Gauss-Legendre product rule over the hemisphere (theta_l, and phi_l over the half on V's
    side's plane of symmetry, doubled)."""
    mu, r = np.broadcast_arrays(np.clip(np.asarray(n_dot_v, np.float64), MIN_N_DOT_V, 1.0),
                                np.asarray(sheen_roughness, np.float64))
    shape = mu.shape
    mu, alpha = mu.ravel()[:, None, None], np.maximum(r.ravel(), MIN_PERCEPTUAL_ROUGHNESS)[:, None, None] ** 2
    x, w = gauss_legendre01(n)
    theta, phi = 0.5 * np.pi * x[:, None], np.pi * x[None, :]
    weight = (0.5 * np.pi * w[:, None]) * np.sin(theta) * (np.pi * w[None, :])
    n_dot_l, t_dot_l = np.cos(theta), np.sin(theta) * np.cos(phi)    # l in the frame (T, B, N)
    sin_v = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    half = np.sqrt(np.maximum(2.0 + 2.0 * (sin_v * t_dot_l + mu * n_dot_l), 1e-300))   # |l + v|
    n_dot_h = (mu + n_dot_l) / half
    f = d_charlie(n_dot_h, alpha) * v_sheen(n_dot_l, mu, alpha) * n_dot_l * weight
    e = f.sum(axis=(1, 2))
    c = np.stack([(f * n_dot_l).sum(axis=(1, 2)) / e, (f * t_dot_l).sum(axis=(1, 2)) / e], -1)
    return c.reshape(shape + (2,))


@lru_cache(maxsize=1)
def sheen_centroid_table() -> list:
    """The chart's table (u_sheen_centroid): (c_n, c_t) at sqrt(1 - N.V) = i / (steps - 1) and
    r = j / (steps - 1), entry i * r_steps + j, two entries a vec4 (a uniform array of vec4
    takes no padding), padded to an even count."""
    mu_steps, r_steps = SHEEN_CENTROID_STEPS
    x = np.linspace(0.0, 1.0, mu_steps)
    c = sheen_centroid((1.0 - x * x)[:, None], np.linspace(0.0, 1.0, r_steps)[None, :]).reshape(-1, 2)
    if len(c) % 2:
        c = np.concatenate([c, np.zeros((1, 2))])
    return [tuple(q) for q in c.reshape(-1, 4)]
