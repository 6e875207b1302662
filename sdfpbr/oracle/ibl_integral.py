"""The exact image-based lighting integral, in float64, for an analytic environment.

``Lo(v) = integral over l of f(v, l) L(l) NdotL dl`` with f the chart's BRDF (glTF Appendix B,
height-correlated Smith, energy compensation per lobe as the shader applies it: each lobe's
specular scaled by 1 + f0 (1/E - 1), E the single-scatter albedo of shading_model.dfg_integrate).
This is what every IBL approximation of the chart (split sum, dominant direction, the sampled
path of ``high``) is judged against; it shares no code with them beyond the BRDF terms of
``mirror``.

The test environment (``LobeSky``) is a sky gradient plus a sharp bright lobe,
``L(d) = a + b max(d.y, 0) + c max(d . s, 0)^k`` (RGB a, b, c), defined here once; ``to_equirect``
writes it as the ``.npy`` equirect map that a chart spec takes as ``env=path`` (row 0 at the
zenith, u = atan2(d.x, -d.z) / 2pi + 0.5, the convention of env.glsl), so the GPU sees the same
function through the existing file environment and no preset is added to the spec.

Quadrature (deterministic Gauss-Legendre):
- specular: over the half vector with the measure D cos(theta_h) dw_h = du dphi / 2pi (D
  cancels), theta_h split where the integrand stops being smooth, as in shading_model.dfg_integrate;
  phi over the arc where NdotL > 0 (closed form), so the horizon is an end point, not a kink;
- diffuse: over l in (theta_l, phi) on the hemisphere around n.
The orders are chosen so that doubling them changes no value by more than 2e-4 relative
(``convergence`` reports it; tests/test_ibl_accuracy.py checks it), and a uniform environment
reproduces shading_model.furnace_expected to 1e-6.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import shading_model



@dataclass(frozen=True)
class LobeSky:
    """L(d) = a + b max(d.y, 0) + c max(d . s, 0)^k, RGB coefficients, s a unit vector."""
    a: tuple = (0.05, 0.06, 0.08)
    b: tuple = (0.35, 0.45, 0.65)
    c: tuple = (6.0, 5.0, 4.0)
    s: tuple = (0.40, 0.55, 0.73)
    k: float = 64.0

    @property
    def axis(self) -> np.ndarray:
        s = np.asarray(self.s, np.float64)
        return s / np.linalg.norm(s)

    def radiance(self, d: np.ndarray) -> np.ndarray:
        """(..., 3) directions (unit) -> (..., 3) radiance, float64."""
        d = np.asarray(d, np.float64)
        up = np.maximum(d[..., 1], 0.0)[..., None]
        lobe = np.maximum(d @ self.axis, 0.0)[..., None] ** self.k
        return np.asarray(self.a) + np.asarray(self.b) * up + np.asarray(self.c) * lobe

    def to_equirect(self, width: int = 1024) -> np.ndarray:
        """(width/2, width, 3) float32 equirect map in env.glsl's convention, texel centres."""
        h = width // 2
        theta = (np.arange(h) + 0.5) / h * np.pi
        psi = ((np.arange(width) + 0.5) / width - 0.5) * 2.0 * np.pi
        th, ps = np.meshgrid(theta, psi, indexing="ij")
        d = np.stack([np.sin(th) * np.sin(ps), np.cos(th), -np.sin(th) * np.cos(ps)], axis=-1)
        return self.radiance(d).astype(np.float32)


UNIFORM = LobeSky(a=(1.0, 1.0, 1.0), b=(0.0, 0.0, 0.0), c=(0.0, 0.0, 0.0))


def _frame(n, v):
    """Tangent x along v's projection, y = n x x (any x where v = n)."""
    mu = np.sum(n * v, axis=-1, keepdims=True)
    x = v - mu * n
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    fallback = np.where(np.abs(n[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    fallback = fallback - np.sum(fallback * n, -1, keepdims=True) * n
    fallback /= np.linalg.norm(fallback, axis=-1, keepdims=True)
    x = np.where(norm > 1e-9, x / np.maximum(norm, 1e-300), fallback)
    y = np.cross(n, x)
    return x, y


def specular_terms(n, v, r, env, n_theta, n_phi):
    """S_A = int (1 - Fc) f_spec L cos, S_B = int Fc f_spec L cos (F = 1, f_spec = D Vis),
    per pixel, RGB: (m, 3) each. With L = 1 these are the A, B of the DFG LUT."""
    mu = np.clip(np.sum(n * v, -1), shading_model.MIN_N_DOT_V, 1.0)
    alpha = r * r
    a2 = alpha * alpha
    sv = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    tx, ty = _frame(n, v)
    pieces, th_c = shading_model.half_vector_pieces(mu, alpha)
    x, w = shading_model.gauss_legendre01(n_theta)
    xs = x * x * (3.0 - 2.0 * x)
    ws = w * 6.0 * x * (1.0 - x)
    xp, wp = shading_model.gauss_legendre01(n_phi)
    SA = np.zeros(mu.shape + (3,))
    SB = np.zeros(mu.shape + (3,))
    mu3, sv3, a23, al3 = (t[:, None, None] for t in (mu, sv, a2, alpha))
    xt, wt = xs[None, :, None], ws[None, :, None]
    xq, wq = xp[None, None, :], wp[None, None, :]
    N, X, Y = (t[:, None, None, :] for t in (n, tx, ty))
    for lo, hi in pieces:
        use_u = (hi <= th_c)[:, None, None]
        c, s, w_th = shading_model.half_vector_nodes(lo[:, None, None], hi[:, None, None], a23, xt, wt, use_u)
        c0 = mu3 * (1.0 - 2.0 * c * c) / np.maximum(2.0 * c * s * sv3, 1e-300)
        phi_max = np.arccos(np.clip(c0, -1.0, 1.0))
        phi = phi_max * (2.0 * xq - 1.0)               # the whole arc: L is not symmetric
        cp, sp = np.cos(phi), np.sin(phi)
        v_dot_h = sv3 * s * cp + mu3 * c
        n_dot_l = np.maximum(2.0 * v_dot_h * c - mu3, 0.0)
        vis = shading_model.vis_smith_ggx_correlated(n_dot_l, mu3, al3)
        g = vis * n_dot_l * 4.0 * v_dot_h / np.maximum(c, 1e-300)
        wgt = w_th * 2.0 * phi_max * wq / (2.0 * np.pi)
        # l = 2 (v.h) h - v in world space.
        h = (s * cp)[..., None] * X + (s * sp)[..., None] * Y + c[..., None] * N
        vw = (sv3[..., None] * X + mu3[..., None] * N)
        l = 2.0 * v_dot_h[..., None] * h - vw
        l /= np.linalg.norm(l, axis=-1, keepdims=True)
        L = env.radiance(l)
        fc = shading_model.fresnel_weight(v_dot_h)
        SB += np.sum((g * fc * wgt)[..., None] * L, axis=(1, 2))
        SA += np.sum((g * (1.0 - fc) * wgt)[..., None] * L, axis=(1, 2))
    return SA, SB


def _diffuse_term(n, v, env, n_theta, n_phi):
    """S_C = int (1 - F_d(VdotH)) L cos / pi dl, F_d the dielectric Schlick (f0 0.04): (m, 3)."""
    tx, ty = _frame(n, v)
    x, w = shading_model.gauss_legendre01(n_theta)
    xp, wp = shading_model.gauss_legendre01(n_phi)
    th = 0.5 * np.pi * x[None, :, None]
    ph = 2.0 * np.pi * xp[None, None, :]
    st, ct = np.sin(th), np.cos(th)
    N, X, Y = (t[:, None, None, :] for t in (n, tx, ty))
    l = (st * np.cos(ph))[..., None] * X + (st * np.sin(ph))[..., None] * Y + ct[..., None] * N
    vv = v[:, None, None, :]
    v_dot_h = np.sqrt(np.clip(0.5 * (1.0 + np.sum(vv * l, -1)), 0.0, 1.0))
    one_minus_fd = 1.0 - (shading_model.DIELECTRIC_F0
                          + (1.0 - shading_model.DIELECTRIC_F0) * shading_model.fresnel_weight(v_dot_h))
    wgt = (0.5 * np.pi * w[None, :, None]) * st * ct * (2.0 * np.pi * wp[None, None, :]) / np.pi
    return np.sum((one_minus_fd * wgt)[..., None] * env.radiance(l), axis=(1, 2))


# Orders (per theta piece / phi): doubling them moves no value by more than 2e-4 relative on
# the chart's materials under LobeSky (tests/test_ibl_accuracy.py::test_oracle_converged).
ORDERS = {"spec_theta": 48, "spec_phi": 96, "diff_theta": 64, "diff_phi": 128}


def ibl_integral(n, v, base_color, metallic, perceptual_roughness, env: LobeSky, multiscatter=True,
                 orders: dict | None = None, chunk: int = 64) -> np.ndarray:
    """Exact Lo (m, 3) at m shading points: n, v (m, 3) unit; base_color (3,) or (m, 3);
    metallic, perceptual_roughness (m,) or scalars (roughness clamped as the shader does)."""
    o = {**ORDERS, **(orders or {})}
    n = shading_model.normalize(np.atleast_2d(n))
    v = shading_model.normalize(np.atleast_2d(v))
    m = n.shape[0]
    r = np.maximum(np.broadcast_to(np.asarray(perceptual_roughness, np.float64), (m,)),
                   shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    metal = np.broadcast_to(np.asarray(metallic, np.float64), (m,))[:, None]
    base = np.broadcast_to(np.asarray(base_color, np.float64), (m, 3))
    mu = np.clip(np.sum(n * v, -1), shading_model.MIN_N_DOT_V, 1.0)
    SA = np.empty((m, 3))
    SB = np.empty((m, 3))
    SC = np.empty((m, 3))
    for s in range(0, m, chunk):
        sl = slice(s, s + chunk)
        SA[sl], SB[sl] = specular_terms(n[sl], v[sl], r[sl], env, o["spec_theta"], o["spec_phi"])
        SC[sl] = _diffuse_term(n[sl], v[sl], env, o["diff_theta"], o["diff_phi"])
    A, B, _ = shading_model.dfg_integrate(mu, r)
    e = (A + B)[:, None]
    comp_d = 1.0 + shading_model.DIELECTRIC_F0 * (1.0 / e - 1.0) if multiscatter else 1.0
    comp_m = 1.0 + base * (1.0 / e - 1.0) if multiscatter else 1.0
    spec_d = (shading_model.DIELECTRIC_F0 * SA + SB) * comp_d
    spec_m = (base * SA + SB) * comp_m
    dielectric = base * SC + spec_d
    return (1.0 - metal) * dielectric + metal * spec_m


def prefiltered(directions, perceptual_roughness, env: LobeSky, n_theta: int = 96, n_phi: int = 96,
                kernel: str = "cosine") -> np.ndarray:
    """The float64 GGX prefilter with V = N = R, as the bake defines it:
    P(R) = int L(l) w D cos(theta_h) dw_h / int w D cos(theta_h) dw_h (NdotL > 0), with
    w = NdotL (kernel "cosine") or NdotL Vis(NdotL, 1) (kernel "brdf", height-correlated
    Smith), at (m, 3) directions; r = 0 is the environment itself."""
    d = shading_model.normalize(np.atleast_2d(directions))
    r = max(float(perceptual_roughness), 0.0)
    if r == 0.0:
        return env.radiance(d)
    a2 = max(r, shading_model.MIN_PERCEPTUAL_ROUGHNESS) ** 4
    # theta_h in [0, pi/4] (NdotL = cos 2 theta_h > 0), u the CDF variable of D cos.
    u_max = shading_model.u_of_theta(np.sin(np.pi / 4), np.cos(np.pi / 4), a2)
    x, w = shading_model.gauss_legendre01(n_theta)
    xp, wp = shading_model.gauss_legendre01(n_phi)
    # Two pieces in u so the peak of small lobes and the tail both get nodes.
    th_c = min(np.arctan(3.0 * np.sqrt(a2)), np.pi / 4)
    u_c = shading_model.u_of_theta(np.sin(th_c), np.cos(th_c), a2)
    tx, ty = _frame(d, d)
    N, X, Y = (t[:, None, None, :] for t in (d, tx, ty))
    num = np.zeros((d.shape[0], 3))
    den = 0.0
    for lo, hi in ((0.0, u_c), (u_c, u_max)):
        if hi <= lo:
            continue
        u = (lo + (hi - lo) * x)[None, :, None]
        q = 1.0 + (a2 - 1.0) * u
        c = np.sqrt(np.clip((1.0 - u) / q, 0.0, 1.0))
        s = np.sqrt(np.clip(a2 * u / q, 0.0, 1.0))
        ph = 2.0 * np.pi * xp[None, None, :]
        n_dot_l = np.maximum(2.0 * c * c - 1.0, 0.0)
        wgt = (hi - lo) * w[None, :, None] * wp[None, None, :] * n_dot_l
        if kernel == "brdf":
            wgt = wgt * shading_model.vis_smith_ggx_correlated(n_dot_l, 1.0, np.sqrt(a2))
        h = (s * np.cos(ph))[..., None] * X + (s * np.sin(ph))[..., None] * Y + c[..., None] * N
        l = 2.0 * c[..., None] * h - N
        num += np.sum(wgt[..., None] * env.radiance(l), axis=(1, 2))
        den += float(np.sum(wgt))
    return num / den


def cube_directions(size: int) -> np.ndarray:
    """(6, size, size, 3) texel-centre directions in the GL face order of cubemap.glsl,
    indexed [face, y, x] as the IBL bake's read_level returns them."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    s, t = np.meshgrid(c, c)   # s along x (columns), t along y (rows)
    one = np.ones_like(s)
    faces = [(one, -t, -s), (-one, -t, s), (s, one, t), (s, -one, -t), (s, -t, one), (-s, -t, -one)]
    d = np.stack([np.stack(f, -1) for f in faces])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)
