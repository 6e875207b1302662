"""Float64 model of the KHR layers (shaders/lobes.glsl, brdf.glsl; docs/lobes.md): the full
layered BRDF of a Material, and its directional albedo by quadrature (the furnace value).

Conventions, as the shaders: roughnesses clamped to MIN_PERCEPTUAL_ROUGHNESS, alpha = r^2;
KHR_materials_specular/ior: f0 = min(((ior-1)/(ior+1))^2 specular_color, 1), dielectric
Fresnel w (f0 + (1 - f0) Fc(V.H)), diffuse weighted by 1 - w max3(that); sheen: Charlie D and
visibility, base scaled by min(1 - max3(c) E_s(N.V), 1 - max3(c) E_s(N.L)); clearcoat: mix(f_base,
D V of the coat, clearcoat (0.04 + 0.96 Fc(N.V))), no multiple-scattering compensation on the coat.
"""
from __future__ import annotations

import numpy as np

from . import shading_model
from ..spec.material import dielectric_f0
from .shading_model import DIELECTRIC_F0, MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS, fresnel_weight

__all__ = ["dielectric_f0", "d_charlie", "v_sheen", "sheen_albedo", "layered_brdf", "layered_albedo"]


def d_charlie(n_dot_h, alpha):
    """Charlie NDF (2 + 1/alpha) sin^(1/alpha)(theta_h) / (2 pi)."""
    nh = np.asarray(n_dot_h, np.float64)
    inv = 1.0 / np.asarray(alpha, np.float64)
    sin2 = np.maximum(1.0 - nh * nh, 0.0)
    return (2.0 + inv) * sin2 ** (0.5 * inv) / (2.0 * np.pi)


def _lambda_fit(x, alpha):
    t = (1.0 - alpha) ** 2
    a = 21.5473 + (25.3245 - 21.5473) * t
    b = 3.82987 + (3.32435 - 3.82987) * t
    c = 0.19823 + (0.16801 - 0.19823) * t
    d = -1.97760 + (-1.27393 + 1.97760) * t
    e = -4.32054 + (-4.85967 + 4.32054) * t
    return a / (1.0 + b * np.power(x, c)) + d * x + e


def _lambda(cos_theta, alpha):
    c = np.asarray(cos_theta, np.float64)
    return np.where(np.abs(c) < 0.5, np.exp(_lambda_fit(np.abs(c), alpha)),
                    np.exp(2.0 * _lambda_fit(0.5, alpha) - _lambda_fit(1.0 - c, alpha)))


def v_sheen(n_dot_l, n_dot_v, alpha):
    """Charlie visibility 1 / ((1 + L(v) + L(l)) 4 N.V N.L), clamped to [0, 1] as the viewer does."""
    nl = np.asarray(n_dot_l, np.float64)
    nv = np.asarray(n_dot_v, np.float64)
    with np.errstate(divide="ignore"):
        v = 1.0 / ((1.0 + _lambda(nv, alpha) + _lambda(nl, alpha)) * 4.0 * nv * nl)
    return np.clip(np.nan_to_num(v, posinf=1.0), 0.0, 1.0)


def _hemisphere_grid(mu, n):
    """l over the hemisphere on a Gauss-Legendre grid in (theta_l, phi in [0, pi]), doubled by
    symmetry: returns (N.L, V.L, weight) with weights integrating dl, shapes (m, n, n)."""
    x, w = shading_model.gauss_legendre01(n)
    mu3 = np.asarray(mu, np.float64)[:, None, None]
    sv3 = np.sqrt(np.maximum(1.0 - mu3 * mu3, 0.0))
    th = 0.5 * np.pi * x[None, :, None]
    phi = np.pi * x[None, None, :]
    n_dot_l = np.cos(th)
    v_dot_l = sv3 * np.sin(th) * np.cos(phi) + mu3 * n_dot_l
    wgt = (0.5 * np.pi * w[None, :, None]) * np.sin(th) * (np.pi * w[None, None, :]) * 2.0
    return n_dot_l, v_dot_l, wgt


def _half(mu, n_dot_l, v_dot_l):
    """N.H and V.H of the half vector of v (N.V = mu) and l."""
    mu3 = np.asarray(mu, np.float64)[:, None, None]
    length = np.sqrt(np.maximum(2.0 + 2.0 * v_dot_l, 1e-300))
    return (mu3 + n_dot_l) / length, np.sqrt(np.clip(0.5 * (1.0 + v_dot_l), 0.0, 1.0))


def sheen_albedo(n_dot_v, sheen_roughness, n=96):
    """E_s(N.V, r) = int D_charlie V_sheen N.L dl (r clamped as the shading clamps it)."""
    mu, r = np.broadcast_arrays(np.clip(np.asarray(n_dot_v, np.float64), MIN_N_DOT_V, 1.0),
                                np.asarray(sheen_roughness, np.float64))
    shape = mu.shape
    mu, r = mu.ravel(), r.ravel()
    alpha = np.maximum(r, MIN_PERCEPTUAL_ROUGHNESS)[:, None, None] ** 2
    out = np.empty_like(mu)
    chunk = max(1, 2_000_000 // (n * n))
    for s in range(0, mu.size, chunk):
        sl = slice(s, s + chunk)
        nl, vl, wgt = _hemisphere_grid(mu[sl], n)
        nh, _ = _half(mu[sl], nl, vl)
        f = d_charlie(nh, alpha[sl]) * v_sheen(nl, mu[sl][:, None, None], alpha[sl]) * nl
        out[sl] = np.sum(f * wgt, axis=(1, 2))
    return out.reshape(shape)


def _params(m):
    r = max(m.roughness, MIN_PERCEPTUAL_ROUGHNESS)
    return r, r * r


def layered_brdf(n, v, l, m, model="gltf", multiscatter=True, e_spec=None):
    """f(v, l) (..., 3) of a Material (sdfpbr.spec.material.Material) with its KHR layers,
    without the cosine; 0 below the horizon. e_spec: the base's E = A + B at N.V (else integrated)."""
    n, v, l = (np.asarray(t, np.float64) for t in (n, v, l))
    base = np.asarray(m.base_color, np.float64)
    r, alpha = _params(m)
    n_dot_l = np.sum(n * l, -1)
    n_dot_v = np.clip(np.sum(n * v, -1), MIN_N_DOT_V, 1.0)
    lit = n_dot_l > 0.0
    nl = np.clip(n_dot_l, 0.0, 1.0)
    h = shading_model.normalize(v + l)
    n_dot_h = np.clip(np.sum(n * h, -1), 0.0, 1.0)
    v_dot_h = np.abs(np.sum(v * h, -1))
    f_spec = (shading_model.d_ggx(n_dot_h, alpha)
              * shading_model.visibility(model, nl, n_dot_v, r, alpha, False))[..., None]
    fc = fresnel_weight(v_dot_h)[..., None]
    f0 = dielectric_f0(m.ior, m.specular_color)
    fd = m.specular * (f0 + (1.0 - f0) * fc)
    spec_d = f_spec * fd
    spec_m = f_spec * (base + (1.0 - base) * fc)
    if multiscatter:
        e = (shading_model.single_scatter_albedo(n_dot_v, np.full(n_dot_v.shape, r), model) if e_spec is None
             else np.asarray(e_spec))
        spec_d = spec_d * shading_model.energy_compensation(f0, e)
        spec_m = spec_m * shading_model.energy_compensation(base, e)
    diffuse = base / np.pi * (1.0 - np.max(fd, axis=-1, keepdims=True))
    f = (1.0 - m.metallic) * (diffuse + spec_d) + m.metallic * spec_m
    sheen = max(m.sheen_color)
    if sheen > 0.0:
        rs = max(m.sheen_roughness, MIN_PERCEPTUAL_ROUGHNESS)
        f_sheen = (np.asarray(m.sheen_color) * (d_charlie(n_dot_h, rs * rs) * v_sheen(nl, n_dot_v, rs * rs))[..., None])
        scaling = np.minimum(1.0 - sheen * sheen_albedo(n_dot_v, rs),
                             1.0 - sheen * sheen_albedo(np.maximum(nl, MIN_N_DOT_V), rs))
        f = f_sheen + f * scaling[..., None]
    if m.clearcoat > 0.0:
        rc = max(m.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS)
        coat = shading_model.d_ggx(n_dot_h, rc * rc) * shading_model.visibility(model, nl, n_dot_v, rc, rc * rc, False)
        w = m.clearcoat * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * fresnel_weight(n_dot_v))
        f = f * (1.0 - w[..., None]) + (coat * w)[..., None]
    return np.where(lit[..., None], f, 0.0)


def layered_albedo(n_dot_v, m, model="gltf", multiscatter=True, n=64, sheen_scaling="exact"):
    """Directional albedo int f cos dl (..., 3) at each N.V: the pixel value of the Material
    under a uniform environment of radiance 1 (the furnace), by quadrature.
    sheen_scaling "view": the base scaled by 1 - max3(c) E_s(N.V) alone, the spec's simplified
    form (which the chart's environment light once used for the base's specular).

    Each GGX lobe (base, coat) is integrated over its half vector with the mirror's split
    quadrature, weighted by the smooth factors the layers put on it; the Lambert and sheen
    lobes on a Gauss-Legendre grid over l."""
    mu = np.clip(np.asarray(n_dot_v, np.float64).ravel(), MIN_N_DOT_V, 1.0)
    base = np.asarray(m.base_color, np.float64)
    r, _ = _params(m)
    f0 = dielectric_f0(m.ior, m.specular_color)
    sheen = max(m.sheen_color)
    rs = max(m.sheen_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    e_v = sheen_albedo(mu, rs) if sheen > 0.0 else np.zeros_like(mu)

    def sheen_scale(n_dot_l, mu3):   # the base's scaling at each l
        if sheen <= 0.0:
            return np.ones_like(n_dot_l)
        if sheen_scaling == "view":
            return np.broadcast_to(1.0 - sheen * sheen_albedo_interpolated(mu3, rs),
                                   np.broadcast_shapes(n_dot_l.shape, mu3.shape))
        return np.minimum(1.0 - sheen * sheen_albedo_interpolated(mu3, rs),
                          1.0 - sheen * sheen_albedo_interpolated(np.maximum(n_dot_l, MIN_N_DOT_V), rs))

    # The base's GGX lobe: F weights (1 - Fc) and Fc for f0 and the rest, times the sheen scaling.
    A, B = _ggx_integrals(mu, r, model, n, sheen_scale if sheen > 0.0 else None)
    e = A + B
    if sheen > 0.0:   # the compensation's E is the lobe's own albedo, without the scaling
        e = sum(_ggx_integrals(mu, r, model, n, None))
    spec_d = m.specular * (f0 * A[:, None] + B[:, None])
    spec_m = base * A[:, None] + B[:, None]
    if multiscatter:
        spec_d = spec_d * shading_model.energy_compensation(f0, e)
        spec_m = spec_m * shading_model.energy_compensation(base, e)
    # Lambert and sheen over l.
    nl, vl, wgt = _hemisphere_grid(mu, n)
    nh, vh = _half(mu, nl, vl)
    fr = m.specular * (np.max(f0) + (1.0 - np.max(f0)) * fresnel_weight(vh))
    lambert = np.sum((1.0 - fr) * nl / np.pi * sheen_scale(nl, mu[:, None, None]) * wgt, axis=(1, 2))
    out = (1.0 - m.metallic) * (base * lambert[:, None] + spec_d) + m.metallic * spec_m
    if sheen > 0.0:
        out = out + np.asarray(m.sheen_color) * e_v[:, None]
    if m.clearcoat > 0.0:
        rc = max(m.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS)
        a_c, b_c = _ggx_integrals(mu, rc, model, n, None)
        w = m.clearcoat * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * fresnel_weight(mu))
        out = out * (1.0 - w[:, None]) + ((a_c + b_c) * w)[:, None]
    return out.reshape(np.shape(n_dot_v) + (3,))


def sheen_specular_scaling(n_dot_v, m, model="gltf", n=64):
    """The base's specular scaling under light from every direction (..., 3): the spec's
    min(1 - c E_s(N.V), 1 - c E_s(N.L)) averaged over the base's GGX lobe with the weights its
    light takes, f_spec cos F per channel (F = f0_a (1 - Fc) + f0_b Fc, the dielectric and
    metal lobes mixed by metallic); 1 without a sheen. lobes_ibl.glsl's
    sheen_specular_scaling is a rule for it."""
    mu = np.clip(np.asarray(n_dot_v, np.float64).ravel(), MIN_N_DOT_V, 1.0)
    sheen = max(m.sheen_color)
    if sheen <= 0.0:
        return np.ones(np.shape(n_dot_v) + (3,))
    r, _ = _params(m)
    rs = max(m.sheen_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    f0 = dielectric_f0(m.ior, m.specular_color)
    f0_a = (1.0 - m.metallic) * m.specular * f0 + m.metallic * np.asarray(m.base_color, np.float64)
    f0_b = (1.0 - m.metallic) * m.specular + m.metallic

    def scale(n_dot_l, mu3):
        return np.minimum(1.0 - sheen * sheen_albedo_interpolated(mu3, rs),
                          1.0 - sheen * sheen_albedo_interpolated(np.maximum(n_dot_l, MIN_N_DOT_V), rs))
    a_scaled, b_scaled = _ggx_integrals(mu, r, model, n, scale)
    a, b = _ggx_integrals(mu, r, model, n, None)
    out = (f0_a * a_scaled[:, None] + f0_b * b_scaled[:, None]) / (f0_a * a[:, None] + f0_b * b[:, None])
    return out.reshape(np.shape(n_dot_v) + (3,))


_SHEEN_GRID = np.linspace(0.0, 1.0, 513) ** 2   # even in sqrt(N.V): E_s is steep at grazing
_sheen_tables: dict = {}


def sheen_albedo_interpolated(n_dot_l, rs):
    """E_s at many N.L: the float64 quadrature on 513 N.V points even in sqrt(N.V), linearly
    interpolated (within 1e-3 of the quadrature below N.V 0.001, 6e-5 above 0.05, over r
    0.045-1 on 4001 points; an even grid of 257 was 0.036 off in its first step)."""
    if rs not in _sheen_tables:
        _sheen_tables[rs] = sheen_albedo(np.maximum(_SHEEN_GRID, MIN_N_DOT_V), rs)
    return np.interp(n_dot_l, _SHEEN_GRID, _sheen_tables[rs])


def _ggx_integrals(mu, r, model, n, weight):
    """int (1 - Fc) f_spec cos w(l) and int Fc f_spec cos w(l) over l, f_spec = D Vis (F = 1),
    for each mu at one roughness r; weight(N.L) -> factor, None for 1."""
    return shading_model.ggx_lobe_integrals(mu, np.full(mu.shape, max(r, MIN_PERCEPTUAL_ROUGHNESS)), model, n, weight)
