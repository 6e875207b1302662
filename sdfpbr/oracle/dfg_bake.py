"""The DFG bake's own quadrature rule (shaders/dfg_main.glsl) in float64.

shading_model.dfg_integrate is the integral; this is the rule the GPU evaluates, sample for sample:
the table the GPU bakes differs from it by float32 alone, and it differs from the integral by
the rule's bias, which is a property of the rule and its sample count, computed here rather
than measured on one driver."""
import numpy as np

from . import lobes, shading_model

# The float32 unit roundoff (round to nearest).
FLOAT32_UNIT_ROUNDOFF = 2.0 ** -24
# Operations between a sample's index and its weighted term in dfg_main.glsl, with the driver's
# sqrt, sin, cos and pow taken as a few ulps each: each term's relative error where its inputs
# do not cancel (v.h, n.l and 1 - sin^2 can, near the horizon, and a GPU's sin and cos err
# absolutely, not relatively).
TERM_OPERATIONS = 64


def radical_inverse(i):
    """hammersley.glsl's radical_inverse: the 32 bits of i reversed, the top 24 kept."""
    i = np.asarray(i, np.uint64)
    reversed_bits = np.zeros_like(i)
    for bit in range(32):
        reversed_bits |= ((i >> np.uint64(bit)) & np.uint64(1)) << np.uint64(31 - bit)
    return (reversed_bits >> np.uint64(8)).astype(np.float64) * 2.0 ** -24


def float32_bound(samples):
    """Higham's gamma_n for a term of TERM_OPERATIONS roundings summed in order with
    samples - 1 more: |fl(sum) - sum| <= gamma * sum |terms|. The bake's terms are
    non-negative, so sum |terms| / samples is the rule's own value (per channel) -- for A and B
    the whole specular weight A + B, since each splits one weight by 1 - Fc and Fc. A worst
    case for the sum (rounding errors that all add up, N u, where they mostly cancel, ~sqrt(N)
    u): it is that slack, not the per-term count, that also covers the few terms whose inputs
    cancel; the tests read the two as one allowance, not as a proof for every driver."""
    n = samples + TERM_OPERATIONS
    return n * FLOAT32_UNIT_ROUNDOFF / (1.0 - n * FLOAT32_UNIT_ROUNDOFF)


def dfg_rule(n_dot_v, perceptual_roughness, samples, model="gltf", sheen=False):
    """(A, B, C, E_s) of dfg_main.glsl's rule at the given points (1-D arrays of equal length,
    n_dot_v already as the bake clamps it), in float64. E_s is the sheen's albedo (0 unless
    sheen)."""
    mu = np.asarray(n_dot_v, np.float64)[:, None]
    r = np.asarray(perceptual_roughness, np.float64)[:, None]
    i = np.arange(samples)
    inv = 1.0 / samples
    # Specular: t = sqrt(1 - u) on cell midpoints, phi the radical inverse on cell midpoints.
    t = ((samples - i) - 0.5) * inv
    phi = 2.0 * np.pi * (radical_inverse(i) + 0.5 * inv)
    alpha = r * r
    a2 = alpha * alpha
    one_minus_t2 = (1.0 - t) * (1.0 + t)
    q = t * t + a2 * one_minus_t2
    cos_h, sin_h = np.sqrt(t * t / q), np.sqrt(a2 * one_minus_t2 / q)
    sin_v = np.sqrt(1.0 - mu * mu)
    h_x = sin_h * np.cos(phi)
    v_dot_h = sin_v * h_x + mu * cos_h
    n_dot_l = 2.0 * v_dot_h * cos_h - mu
    ok = (n_dot_l > 0.0) & (v_dot_h > 0.0)
    safe_l = np.where(ok, n_dot_l, 1.0)
    vis = shading_model.visibility(model, safe_l, mu, r, alpha, ibl=True)
    w = np.where(ok, vis * 4.0 * v_dot_h * safe_l / cos_h * (2.0 * t), 0.0)
    fc = shading_model.fresnel_weight(np.clip(v_dot_h, 0.0, 1.0))
    a = ((1.0 - fc) * w).sum(1) * inv
    b = (fc * w).sum(1) * inv
    # Lambert weight of the dielectric mix: cosine-weighted Hammersley directions.
    u_x, u_y = i * inv, radical_inverse(i)
    cos_d, sin_d, phi_d = np.sqrt(1.0 - u_x), np.sqrt(u_x), 2.0 * np.pi * u_y
    v_dot_ld = sin_v * sin_d * np.cos(phi_d) + mu * cos_d
    v_dot_hd = np.abs((1.0 + v_dot_ld) / np.sqrt(np.maximum(2.0 + 2.0 * v_dot_ld, 1e-300)))
    c = (1.0 - (shading_model.DIELECTRIC_F0
                + (1.0 - shading_model.DIELECTRIC_F0) * shading_model.fresnel_weight(v_dot_hd))).sum(1) * inv
    e_s = np.zeros_like(a)
    if sheen:
        alpha_s = np.maximum(r, shading_model.MIN_PERCEPTUAL_ROUGHNESS) ** 2
        sin_s = (u_x + 0.5 * inv) ** (alpha_s / (2.0 * alpha_s + 1.0))
        cos_s = np.sqrt(np.maximum(1.0 - sin_s * sin_s, 0.0))
        v_dot_hs = sin_v * sin_s * np.cos(phi_d) + mu * cos_s
        l_z = 2.0 * v_dot_hs * cos_s - mu
        ok_s = (l_z > 0.0) & (v_dot_hs > 0.0) & (cos_s > 0.0)
        safe = np.where(ok_s, l_z, 1.0)
        term = lobes.v_sheen(safe, mu, alpha_s) * safe * 4.0 * v_dot_hs / np.where(ok_s, cos_s, 1.0)
        e_s = np.where(ok_s, term, 0.0).sum(1) * inv
    return a, b, c, e_s
