"""Float64 numpy model of the GLSL shading (the display side, tone maps and encodings, is in
sdfpbr.oracle.display).

The oracle for the shader tests and the generator/validator of lookup tables.
Pure numpy, vectorised with broadcasting. Vectors are arrays of shape (..., 3).

Naming: ``perceptual_roughness`` (r) is what users type and charts label;
``alpha`` = r * r is what the formulas use. ``Fc(x) = (1 - x)^5``.
docs/model.md gives the formulas and the test vectors.
"""

from __future__ import annotations

import numpy as np

from ..spec.material import MIN_PERCEPTUAL_ROUGHNESS

__all__ = [
    "MIN_PERCEPTUAL_ROUGHNESS",
    "MIN_N_DOT_V",
    "alpha_from_perceptual",
    "d_ggx",
    "d_ggx_half_safe",
    "HALF_MAX",
    "MIN_PERCEPTUAL_ROUGHNESS_FP16",
    "furnace_from_dfg",
    "vis_smith_ggx_correlated",
    "vis_schlick_ggx",
    "k_direct",
    "k_ibl",
    "fresnel_schlick",
    "visibility",
    "energy_compensation",
    "single_scatter_albedo",
    "ggx_lobe_integrals",
    "dfg_integrate",
    "e_avg",
    "dfg_table",
    "brdf",
    "d_ggx_disc",
    "disc_half_radius",
    "GLINT_SPREAD",
    "shaded_light_angle",
    "furnace_expected",
    "sample_sphere_cosine",
    "reflect",
    "normalize",
]

# Filament clamps NdotV so the visibility term never divides by 0 at the silhouette.
MIN_N_DOT_V = 1e-4
# Below this alpha the lobe is a delta for any quadrature we can afford: use the limit.
_ALPHA_DELTA = 1e-4
DIELECTRIC_F0 = 0.04
_TINY = 1e-300
# A sphere's light is shaded as a disc widened by the pixel (shade.glsl shaded_light_angle):
# across a pixel of world size p the reflected direction sweeps a box 2 p / R wide, which a disc
# of radius 2 / sqrt(3) p / R matches in variance (a box of width b: b^2 / 12 per axis; a disc
# of radius w: w^2 / 4).
GLINT_SPREAD = 2.0 / np.sqrt(3.0)
# Largest finite half float, and Filament's fp16 roughness guard: 0.089^4 = 6.3e-5 keeps alpha^2
# a normal half (>= 2^-14); with the half-safe D its peak 1/(pi alpha^2) = 5.1e3 stays finite.
HALF_MAX = 65504.0
MIN_PERCEPTUAL_ROUGHNESS_FP16 = 0.089


def _tiny(dtype):
    """The "avoid 0/0" guard in the given precision: 1e-300 in float64 (as always), else the
    smallest positive value the type holds (1e-300 would round to 0 in float16)."""
    dtype = np.dtype(dtype)
    return _TINY if dtype == np.float64 else np.finfo(dtype).smallest_subnormal

MODELS = ("gltf", "schlick-ggx")


def _check_model(model):
    if model not in MODELS:
        raise ValueError(f"unknown BRDF model {model!r}; expected one of {MODELS}")


# ---------------------------------------------------------------------------
# BRDF terms
# ---------------------------------------------------------------------------

def alpha_from_perceptual(perceptual_roughness, dtype=np.float64):
    """alpha = r * r."""
    r = np.asarray(perceptual_roughness, dtype=dtype)
    return r * r


# Every term below takes dtype: float64 is the oracle; float16 (or float32) evaluates the same
# formula with every operation rounded to that type, to show where it overflows or underflows.

def d_ggx(n_dot_h, alpha, dtype=np.float64):
    """GGX NDF a2 / (pi (NdotH^2 (a2 - 1) + 1)^2); 0 instead of NaN at alpha = 0, NdotH = 1."""
    nh = np.asarray(n_dot_h, dtype=dtype)
    a2 = np.asarray(alpha, dtype=dtype) ** 2
    # = NdotH^2 (a2 - 1) + 1, arranged so tiny a2 near NdotH = 1 does not cancel.
    t = (1.0 - nh) * (1.0 + nh) + nh * nh * a2
    return a2 / (np.pi * np.maximum(t * t, _tiny(dtype)))


def d_ggx_half_safe(n_dot_h, alpha, dtype=np.float64):
    """The same D written as (alpha / t)^2 / pi (Filament's mediump form): no t^2 and no a2
    alone, so in float16 it neither underflows near the peak nor loses alpha^2 to subnormals
    until the peak 1/(pi alpha^2) itself passes HALF_MAX. Equal to d_ggx in float64."""
    nh = np.asarray(n_dot_h, dtype=dtype)
    alpha = np.asarray(alpha, dtype=dtype)
    a = nh * alpha
    t = (1.0 - nh) * (1.0 + nh) + a * a
    k = alpha / np.maximum(t, _tiny(dtype))
    return k * k * (1.0 / np.pi)


def vis_smith_ggx_correlated(n_dot_l, n_dot_v, alpha, dtype=np.float64):
    """Height-correlated Smith visibility G / (4 NdotL NdotV); 0 where the denominator is 0."""
    nl = np.asarray(n_dot_l, dtype=dtype)
    nv = np.asarray(n_dot_v, dtype=dtype)
    a2 = np.asarray(alpha, dtype=dtype) ** 2
    gv = nl * np.sqrt(nv * nv * (1.0 - a2) + a2)
    gl = nv * np.sqrt(nl * nl * (1.0 - a2) + a2)
    denom = gv + gl
    return np.where(denom > 0.0, 0.5 / np.maximum(denom, _tiny(dtype)), 0.0)


def vis_schlick_ggx(n_dot_l, n_dot_v, k, dtype=np.float64):
    """Seeds' Schlick-GGX G1(l) G1(v) / (4 NdotL NdotV) = 1 / (4 (l(1-k)+k)(v(1-k)+k))."""
    nl = np.asarray(n_dot_l, dtype=dtype)
    nv = np.asarray(n_dot_v, dtype=dtype)
    k = np.asarray(k, dtype=dtype)
    denom = 4.0 * (nl * (1.0 - k) + k) * (nv * (1.0 - k) + k)
    return np.where(denom > 0.0, 1.0 / np.maximum(denom, _tiny(dtype)), 0.0)


def k_direct(perceptual_roughness, dtype=np.float64):
    """Schlick-GGX k for punctual lights: (r + 1)^2 / 8."""
    r = np.asarray(perceptual_roughness, dtype=dtype)
    return (r + 1.0) ** 2 / 8.0


def k_ibl(perceptual_roughness, dtype=np.float64):
    """Schlick-GGX k for image-based light: alpha / 2."""
    return alpha_from_perceptual(perceptual_roughness, dtype) / 2.0


def fresnel_weight(x):
    """Fc(x) = (1 - x)^5, x clipped first (pow of a slightly negative base is NaN in GLSL)."""
    return (1.0 - np.clip(x, 0.0, 1.0)) ** 5


def fresnel_schlick(f0, v_dot_h, dtype=np.float64):
    """Schlick Fresnel f0 + (1 - f0) (1 - x)^5, x clipped to [0, 1].

    f0 is a scalar or RGB (..., 3); an RGB f0 gets v_dot_h (...) expanded on the channel axis.
    """
    f0 = np.asarray(f0, dtype=dtype)
    x = np.asarray(v_dot_h, dtype=dtype)
    if f0.ndim >= 1 and f0.shape[-1] == 3:
        x = x[..., None]
    return f0 + (1.0 - f0) * fresnel_weight(x)


def visibility(model, n_dot_l, n_dot_v, perceptual_roughness, alpha, ibl, dtype=np.float64):
    if model == "gltf":
        return vis_smith_ggx_correlated(n_dot_l, n_dot_v, alpha, dtype)
    k = k_ibl(perceptual_roughness, dtype) if ibl else k_direct(perceptual_roughness, dtype)
    return vis_schlick_ggx(n_dot_l, n_dot_v, k, dtype)


# ---------------------------------------------------------------------------
# DFG / split-sum integrals (deterministic Gauss-Legendre quadrature)
# ---------------------------------------------------------------------------

_GL_CACHE: dict = {}


def gauss_legendre01(n):
    """Nodes and weights on [0, 1]."""
    if n not in _GL_CACHE:
        x, w = np.polynomial.legendre.leggauss(int(n))
        _GL_CACHE[n] = (0.5 * (x + 1.0), 0.5 * w)
    return _GL_CACHE[n]


def u_of_theta(sin_t, cos_t, a2):
    """Inverse of cos^2 = (1-u)/(1+(a2-1)u): the CDF of D cos in theta_h."""
    s2 = sin_t * sin_t
    return s2 / (a2 * cos_t * cos_t + s2)


def half_vector_pieces(mu, alpha):
    """The half vector's polar range split where the integrand stops being smooth (see
    _dfg_spec_flat): three (lo, hi) pieces, and th_c, below which u is the good variable."""
    theta_v = np.arccos(mu)
    th_a = 0.5 * (0.5 * np.pi - theta_v)
    th_b = 0.5 * (0.5 * np.pi + theta_v)
    th_c = np.arctan(3.0 * alpha)
    p1 = np.minimum(th_a, th_c)
    p2 = np.minimum(np.maximum(th_a, th_c), th_b)
    return ((np.zeros_like(mu), p1), (p1, p2), (p2, th_b)), th_c


def half_vector_nodes(lo3, hi3, a23, xt, wt, use_u):
    """Quadrature over the half vector's polar angle on [lo, hi] (broadcast arrays): the u
    variable of u_of_theta where D peaks (D flattened), s = ln(tan theta) in the tail, which
    spans decades when alpha is small (measure du = 2 a2 t^2 / (a2 + t^2)^2 ds, t = tan theta).
    Returns (cos, sin, weight) of each node; xt, wt: nodes and weights on [0, 1]."""
    u_lo = u_of_theta(np.sin(lo3), np.cos(lo3), a23)
    u_hi = u_of_theta(np.sin(hi3), np.cos(hi3), a23)
    u = u_lo + (u_hi - u_lo) * xt
    q = 1.0 + (a23 - 1.0) * u
    c_u = np.sqrt(np.clip((1.0 - u) / q, 0.0, 1.0))
    s_u = np.sqrt(np.clip(a23 * u / q, 0.0, 1.0))
    w_u = (u_hi - u_lo) * wt
    s_lo = np.log(np.maximum(np.tan(lo3), 1e-150))
    s_hi = np.log(np.maximum(np.tan(hi3), 1e-150))
    t = np.exp(s_lo + (s_hi - s_lo) * xt)
    c_t = 1.0 / np.sqrt(1.0 + t * t)
    s_t = t * c_t
    den = a23 + t * t
    w_t = (s_hi - s_lo) * wt * 2.0 * a23 * t * t / (den * den)
    return np.where(use_u, c_u, c_t), np.where(use_u, s_u, s_t), np.where(use_u, w_u, w_t)


def _dfg_spec_flat(mu, r, model, n, weight=None):
    """A, B for 1-D arrays mu, r (alpha >= _ALPHA_DELTA); weight(n_dot_l, mu): an optional smooth
    factor on the integrand (the layers' scaling of the lobe, sdfpbr.oracle.lobes).

    Integrates over the half vector h with the measure D cos(theta_h) dw_h = du dphi / (2 pi),
    so E = int Vis NdotL 4 VdotH / NdotH du dphi / (2 pi). theta_h is split where the
    integrand stops being smooth so Gauss-Legendre converges fast:
      th_a = (90 - theta_v)/2: above it part of the phi circle sends l below the horizon;
      th_b = (90 + theta_v)/2: above it all of it does (the integral ends there);
      th_c = atan(3 alpha): below it u is the good variable (the D peak), above it ln(tan).
    In each piece phi runs over [0, phi_max] where NdotL > 0 (closed form), doubled by symmetry.
    """
    alpha = r * r
    a2 = alpha * alpha
    sv = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    pieces, th_c = half_vector_pieces(mu, alpha)

    x, w = gauss_legendre01(n)
    # theta nodes through the smoothstep x = 3y^2 - 2y^3: the phi range opens like a square
    # root at the piece ends, and the vanishing Jacobian turns that into a smooth integrand.
    xs = x * x * (3.0 - 2.0 * x)
    ws = w * 6.0 * x * (1.0 - x)
    A = np.zeros_like(mu)
    B = np.zeros_like(mu)
    # Shapes: (m, 1, 1) per input, (1, n, 1) theta nodes, (1, 1, n) phi nodes.
    mu3, sv3, a23, r3, al3 = (t[:, None, None] for t in (mu, sv, a2, r, alpha))
    xt, wt = xs[None, :, None], ws[None, :, None]
    xp, wp = x[None, None, :], w[None, None, :]
    for lo, hi in pieces:
        use_u = (hi <= th_c)[:, None, None]
        c, s, w_th = half_vector_nodes(lo[:, None, None], hi[:, None, None], a23, xt, wt, use_u)
        # NdotL = 2 VdotH c - mu > 0  <=>  cos(phi) > c0.
        num = mu3 * (1.0 - 2.0 * c * c)
        c0 = num / np.maximum(2.0 * c * s * sv3, _TINY)
        phi_max = np.arccos(np.clip(c0, -1.0, 1.0))
        phi = phi_max * xp
        v_dot_h = sv3 * s * np.cos(phi) + mu3 * c
        n_dot_l = np.maximum(2.0 * v_dot_h * c - mu3, 0.0)
        vis = visibility(model, n_dot_l, mu3, r3, al3, ibl=True)
        g = vis * n_dot_l * 4.0 * v_dot_h / np.maximum(c, _TINY)
        # Weight: w_theta * phi_max w_phi * 2 (symmetry) / (2 pi).
        wgt = w_th * phi_max * wp / np.pi
        if weight is not None:
            wgt = wgt * weight(n_dot_l, mu3)
        fc = fresnel_weight(v_dot_h)
        B += np.sum(g * fc * wgt, axis=(1, 2))
        A += np.sum(g * (1.0 - fc) * wgt, axis=(1, 2))
    return A, B


def ggx_lobe_integrals(mu, r, model="gltf", n=64, weight=None):
    """(A, B) of the GGX lobe at 1-D arrays mu, r (alpha >= 1e-4) with the integrand times
    weight(n_dot_l, mu) (arrays broadcast over the quadrature), chunked as dfg_integrate."""
    _check_model(model)
    mu = np.clip(np.asarray(mu, np.float64), MIN_N_DOT_V, 1.0)
    r = np.asarray(r, np.float64)
    A, B = np.empty_like(mu), np.empty_like(mu)
    chunk = max(1, 2_000_000 // (n * n))
    for s in range(0, mu.size, chunk):
        sl = slice(s, s + chunk)
        A[sl], B[sl] = _dfg_spec_flat(mu[sl], r[sl], model, n, weight)
    return A, B


def _dfg_c_flat(mu, n):
    """C = int (1 - (0.04 + 0.96 Fc(VdotH))) NdotL / pi dl over cosine-weighted l.

    Parametrised by theta_l (not sin^2) so the integrand has no sqrt kink at the horizon.
    """
    x, w = gauss_legendre01(n)
    mu3 = mu[:, None, None]
    sv3 = np.sqrt(np.maximum(1.0 - mu3 * mu3, 0.0))
    th = 0.5 * np.pi * x[None, :, None]
    phi = np.pi * x[None, None, :]
    v_dot_l = sv3 * np.sin(th) * np.cos(phi) + mu3 * np.cos(th)
    v_dot_h = np.sqrt(np.clip(0.5 * (1.0 + v_dot_l), 0.0, 1.0))
    one_minus_fd = 1.0 - (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * fresnel_weight(v_dot_h))
    # Measure: dxi dphi / (2 pi), xi = sin^2, dxi = 2 sin cos dtheta; phi doubled.
    wgt = (0.5 * np.pi * w[None, :, None]) * 2.0 * np.sin(th) * np.cos(th) \
        * (np.pi * w[None, None, :]) * 2.0 / (2.0 * np.pi)
    return np.sum(one_minus_fd * wgt, axis=(1, 2))


def dfg_integrate(n_dot_v, perceptual_roughness, model="gltf", n=64):
    """Split-sum terms (A, B, C) at (n_dot_v, r), broadcast over the inputs.

    A = int (1 - Fc) f_spec cos, B = int Fc f_spec cos (F = 1, f_spec = D Vis; model "gltf":
    height-correlated Smith, "schlick-ggx": k = alpha/2); E = A + B. C is the Lambert weight
    of the glTF dielectric coupling under uniform light (independent of roughness).
    n is the Gauss-Legendre order per dimension of each of the three theta pieces (the
    splitting makes every piece smooth: against n = 512, n = 32 is off by up to 6.8e-7 (at
    n_dot_v 1e-4, r 0.045), n = 48 by 5.7e-9, the default 64 by 9e-11). n_dot_v is clamped
    to >= 1e-4; alpha < 1e-4 uses the delta-lobe limit A = 1 - Fc(mu), B = Fc(mu).
    """
    _check_model(model)
    mu, r = np.broadcast_arrays(np.asarray(n_dot_v, dtype=np.float64),
                                np.asarray(perceptual_roughness, dtype=np.float64))
    shape = mu.shape
    mu = np.clip(mu.ravel(), MIN_N_DOT_V, 1.0)
    r = np.abs(r.ravel())
    A = np.empty_like(mu)
    B = np.empty_like(mu)
    C = np.empty_like(mu)

    delta = r * r < _ALPHA_DELTA
    fc_mu = fresnel_weight(mu)
    A[delta] = 1.0 - fc_mu[delta]
    B[delta] = fc_mu[delta]

    # Chunk so the (m, n, n) temporaries stay around a few million elements.
    chunk = max(1, 2_000_000 // (n * n))
    idx = np.nonzero(~delta)[0]
    for s in range(0, idx.size, chunk):
        sl = idx[s:s + chunk]
        A[sl], B[sl] = _dfg_spec_flat(mu[sl], r[sl], model, n)
    # C depends on mu only: integrate each distinct mu once.
    mu_u, inv = np.unique(mu, return_inverse=True)
    c_u = np.empty_like(mu_u)
    for s in range(0, mu_u.size, chunk):
        c_u[s:s + chunk] = _dfg_c_flat(mu_u[s:s + chunk], n)
    C[:] = c_u[inv.ravel()]
    return A.reshape(shape), B.reshape(shape), C.reshape(shape)


def e_avg(perceptual_roughness, model="gltf", n=64):
    """Hemispherical average Eavg(r) = 2 int_0^1 E(mu) mu dmu."""
    r = np.asarray(perceptual_roughness, dtype=np.float64)
    x, w = gauss_legendre01(n)
    A, B, _ = dfg_integrate(x, r[..., None], model=model, n=n)
    return 2.0 * np.sum((A + B) * x * w, axis=-1)


def dfg_table(size, model="gltf", n=64):
    """LUT (size, size, 3) of (A, B, C); [j, i] at n_dot_v = (i+.5)/size, r = (j+.5)/size."""
    t = (np.arange(size, dtype=np.float64) + 0.5) / size
    A, B, C = dfg_integrate(t[None, :], t[:, None], model=model, n=n)
    return np.stack([A, B, C], axis=-1)


# ---------------------------------------------------------------------------
# Full material (glTF 2.0 Appendix B)
# ---------------------------------------------------------------------------

def _dot(a, b):
    return np.sum(a * b, axis=-1)


def energy_compensation(f0, e):
    # Filament's Kulla-Conty simplification; f0 (..., 3), e (...).
    return 1.0 + f0 * (1.0 / e[..., None] - 1.0)


def single_scatter_albedo(n_dot_v, r, model):
    """E = A + B at (n_dot_v, r), integrating each distinct pair once."""
    nv, rr = np.broadcast_arrays(n_dot_v, r)
    pairs = np.stack([nv.ravel(), rr.ravel()], axis=-1)
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    A, B, _ = dfg_integrate(uniq[:, 0], uniq[:, 1], model=model)
    return (A + B)[inv.ravel()].reshape(nv.shape)


DISC_MIN_COS = 0.5   # ggx.glsl: a wide disc's slope image far off the normal is no circle


def d_ggx_disc(n_dot_h, alpha, w, dtype=np.float64):
    """D seen through a disc light (as ggx.glsl's d_ggx_disc): the GGX lobe averaged over a disc
    of half vectors of solid angle pi w^2 centred on the half vector whose NdotH is given. In
    n's slope space GGX is p(s) = a^2 / (pi (|s|^2 + a^2)^2) = laplacian(log(|s|^2 + a^2)) /
    (4 pi), so its integral over a circle of radius r at distance d is, by the divergence
    theorem, I = 1/2 - u / (2 S), u = d^2 + a^2 - r^2, S = sqrt(u^2 + 4 r^2 a^2). The disc's slope
    image at d = tan(theta_h) has the area of a circle of radius r = w / cos^1.5 (the cos no
    lower than DISC_MIN_COS), and D = I / (pi w^2 c_m), c_m the measure's cos where the lobe's
    share within the disc lies: 1 within, cos^4 / c^3 far off (GGX's own value there). w = 0 is
    d_ggx."""
    nh = np.asarray(n_dot_h, dtype=dtype)
    a2 = np.asarray(alpha, dtype=dtype) ** 2
    w2 = np.asarray(w, dtype=dtype) ** 2
    tiny = _tiny(dtype)
    c = np.maximum(nh, DISC_MIN_COS)
    cos2 = nh * nh
    r2_cos2 = w2 * cos2 / c ** 3                             # r^2 cos^2, r^2 = w^2 / c^3
    u = (1.0 - nh) * (1.0 + nh) + a2 * cos2 - r2_cos2        # (d^2 + a^2 - r^2) cos^2
    s = np.sqrt(u * u + 4.0 * a2 * cos2 * r2_cos2)
    inside = np.where(u > 0.0, 2.0 * a2 * cos2 * r2_cos2 / np.maximum(s * (s + u), tiny),
                      (s - u) / (2.0 * np.maximum(s, tiny)))
    measure = cos2 * cos2 / c ** 3 * (1.0 - inside) + inside   # c^3 c_m = cos^4 far off, 1 within
    return inside / (np.pi * np.maximum(w2 * measure, tiny))


def disc_half_radius(angular_radius, v_dot_h):
    """The radius in the half vector's slope space of a disc light of angular radius theta:
    sin(theta) / (2 sqrt(V.H)) (its solid angle over the reflection's Jacobian 4 V.H)."""
    return np.sin(angular_radius) / (2.0 * np.sqrt(np.maximum(v_dot_h, 1e-4)))


def brdf(n, v, l, base_color, metallic, perceptual_roughness, model="gltf",
         multiscatter=False, e_spec=None, dtype=np.float64, min_perceptual_roughness=MIN_PERCEPTUAL_ROUGHNESS,
         disc_angular_radius=0.0):
    """glTF 2.0 metal-rough BRDF value f (..., 3), without the cosine.

    n, v, l unit vectors (..., 3) (v and l point away from the surface); base_color scalar,
    (3,) or (..., 3); metallic, perceptual_roughness scalars or (...). Roughness is clamped to
    MIN_PERCEPTUAL_ROUGHNESS, NdotV to >= 1e-4; f = 0 where NdotL <= 0. Model "schlick-ggx"
    uses k_direct. multiscatter scales each lobe's specular by 1 + f0 (1/E - 1) with its own
    f0 (0.04 dielectric, base_color metal), E from dfg_integrate unless e_spec is given.
    dtype float16 evaluates every step in half precision (E still integrated in float64);
    min_perceptual_roughness is the clamp (MIN_PERCEPTUAL_ROUGHNESS_FP16 is Filament's fp16 one).
    disc_angular_radius > 0 (a scalar, or one per point) makes l the centre of a disc light as
    the chart shades one: D convolved with the disc (d_ggx_disc), the other factors at its centre.
    """
    _check_model(model)
    n = np.asarray(n, dtype=dtype)
    v = np.asarray(v, dtype=dtype)
    l = np.asarray(l, dtype=dtype)
    base = np.asarray(base_color, dtype=dtype)
    if base.ndim == 0 or base.shape[-1] != 3:
        base = base[..., None]
    metal = np.asarray(metallic, dtype=dtype)[..., None]
    r = np.maximum(np.asarray(perceptual_roughness, dtype=dtype), np.asarray(min_perceptual_roughness, dtype))
    alpha = r * r

    n_dot_l_raw = _dot(n, l)
    lit = n_dot_l_raw > 0.0
    n_dot_l = np.clip(n_dot_l_raw, 0.0, 1.0)
    n_dot_v = np.clip(_dot(n, v), MIN_N_DOT_V, 1.0)
    h = normalize(v + l, dtype)
    n_dot_h = np.clip(_dot(n, h), 0.0, 1.0)
    v_dot_h = np.abs(_dot(v, h))
    disc = np.asarray(disc_angular_radius, np.float64)
    d = d_ggx(n_dot_h, alpha, dtype)
    if np.any(disc > 0):   # per point where given per point (shaded_light_angle)
        with np.errstate(divide="ignore", invalid="ignore"):
            d_disc = d_ggx_disc(n_dot_h, alpha, disc_half_radius(disc, v_dot_h), dtype)
        d = np.where(disc > 0, d_disc, d)
    f_spec = (d * visibility(model, n_dot_l, n_dot_v, r, alpha, False, dtype))[..., None]
    fc = fresnel_weight(v_dot_h)[..., None]
    fd = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * fc
    spec_d = f_spec * fd
    spec_m = f_spec * (base + (1.0 - base) * fc)
    if multiscatter:
        e = single_scatter_albedo(n_dot_v.astype(np.float64), r.astype(np.float64), model) if e_spec is None else e_spec
        e = np.maximum(np.asarray(e, dtype=dtype), _tiny(dtype))
        spec_d = spec_d * energy_compensation(np.asarray(DIELECTRIC_F0, dtype), e)
        spec_m = spec_m * energy_compensation(base, e)
    dielectric = base / np.pi * (1.0 - fd) + spec_d
    f = (1.0 - metal) * dielectric + metal * spec_m
    f = np.where(lit[..., None], f, 0.0)
    # A scalar base colour still yields RGB.
    return np.broadcast_to(f, np.broadcast_shapes(f.shape, (3,))).copy()


def furnace_expected(n_dot_v, base_color, metallic, perceptual_roughness, model="gltf",
                     multiscatter=True):
    """Pixel value under a uniform environment of radiance 1 with split-sum shading.

    Per lobe specular (f0 A + B) comp(f0), diffuse (1 - metallic) base C, mixed by metallic.
    Roughness and NdotV are clamped as in brdf. Returns (..., 3).
    """
    r = np.maximum(np.asarray(perceptual_roughness, dtype=np.float64), MIN_PERCEPTUAL_ROUGHNESS)
    A, B, C = dfg_integrate(n_dot_v, r, model=model)
    return furnace_from_dfg(A, B, C, base_color, metallic, multiscatter)


def furnace_from_dfg(A, B, C, base_color, metallic, multiscatter=True):
    """furnace_expected from its split-sum terms (A, B, C at each pixel's NdotV and roughness),
    for callers that tabulate dfg_integrate once and interpolate it over many pixels."""
    A, B, C = (np.asarray(t, dtype=np.float64) for t in (A, B, C))
    base = np.asarray(base_color, dtype=np.float64)
    if base.ndim == 0 or base.shape[-1] != 3:
        base = base[..., None]
    metal = np.asarray(metallic, dtype=np.float64)[..., None]
    e = A + B
    A, B, C = A[..., None], B[..., None], C[..., None]
    f0d = np.float64(DIELECTRIC_F0)
    spec_d = f0d * A + B
    spec_m = base * A + B
    if multiscatter:
        spec_d = spec_d * energy_compensation(f0d, e)
        spec_m = spec_m * energy_compensation(base, e)
    dielectric = base * C + spec_d
    out = (1.0 - metal) * dielectric + metal * spec_m
    return np.broadcast_to(out, np.broadcast_shapes(out.shape, (3,))).copy()


# ---------------------------------------------------------------------------
# Tone mapping and encoding (order: exposure -> tone map -> OETF)
# ---------------------------------------------------------------------------
# Helpers for tests
# ---------------------------------------------------------------------------

def normalize(v, dtype=np.float64):
    """v / |v| along the last axis (0 stays 0)."""
    v = np.asarray(v, dtype=dtype)
    norm = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    return v / np.maximum(norm, _tiny(dtype))


def reflect(v, n):
    """GLSL reflect: v - 2 dot(n, v) n (v is the incident direction; use reflect(-V, N))."""
    v = np.asarray(v, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    return v - 2.0 * np.sum(n * v, axis=-1, keepdims=True) * n


def sample_sphere_cosine(rng, n):
    """n cosine-weighted directions (n, 3) on the +z hemisphere (pdf = cos(theta) / pi)."""
    u1 = rng.random(n)
    u2 = rng.random(n)
    s = np.sqrt(u1)
    phi = 2.0 * np.pi * u2
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], axis=-1)


def shaded_light_angle(angular_radius, pixel_size, sphere_radius):
    """The angular radius a light of ``angular_radius`` is shaded with on a sphere point whose
    pixel is ``pixel_size`` wide in world units (shade.glsl): the light's disc and the pixel's
    sweep of reflected directions added in quadrature."""
    glint = GLINT_SPREAD * np.asarray(pixel_size, np.float64) / sphere_radius
    return np.hypot(np.asarray(angular_radius, np.float64), glint)
