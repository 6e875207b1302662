"""The peer's BSDF: glTF 2.0 Appendix B (metallic-roughness) as a Mitsuba 3 plugin, written
from the glTF specification, not from sdfpbr's shaders.

    f = mix(dielectric, metal, metallic)
    dielectric = (1 - w max(F_d)) base / pi + w F_d D V      (KHR_materials_specular's mix)
    metal      = F_m D V
    F_d = f0_d + (1 - f0_d) (1 - |V.H|)^5,  f0_d = min(((ior - 1) / (ior + 1))^2 specular_color, 1)
    F_m = base + (1 - base) (1 - |V.H|)^5
    D   = GGX, alpha = r^2;  V = height-correlated Smith, G2 / (4 N.L N.V)

with sdfpbr's clamps (sdfpbr.oracle.shading_model): r >= 0.045, N.V >= 1e-4, N.L >= 1e-6 in V.
Multiple-scattering compensation, where the scene has it, scales each specular lobe by
1 + f0 (1 / E - 1) (each lobe with its own f0), E(N.V) the single-scatter albedo of the lobe
for F = 1, tabulated per roughness from the float64 model (the definition both renderers
share; the reference reads its own 128 x 128 float32 table of it).

Sampling (Mitsuba's): GGX visible normals for the specular lobes, cosine for the diffuse one,
mixed by a fixed share; the pdf is the mixture's.
"""
from __future__ import annotations

import functools

import numpy as np

from ...image.colour import REC709_LUMINANCE
from ...oracle import shading_model
from ...spec.material import MIN_PERCEPTUAL_ROUGHNESS, Material, dielectric_f0

PLUGIN = "sdfpbr_gltf"
MIN_N_DOT_V = shading_model.MIN_N_DOT_V
MIN_N_DOT_L = 1e-6             # the visibility's floor on N.L (sdfpbr's brdf.glsl)
# E(N.V) nodes per roughness, at N.V = (i / (nodes - 1))^2 (dense at grazing angles, where E
# changes fastest: 0.990 at N.V = 1e-4, 0.976 at 0.01 for r = 0.045), linear between.
ALBEDO_NODES = 1024
ALBEDO_ORDER = 32              # the model's quadrature order: within 1e-9 of order 512 (its docstring)
# The share of samples the specular lobes get: their reflectance at the view's angle over the
# whole, kept in [0.1, 0.9] so neither lobe goes unsampled. Steers variance only.
MIN_LOBE_SHARE = 0.1


@functools.lru_cache(maxsize=64)
def albedo_table(perceptual_roughness: float, model: str = "gltf") -> np.ndarray:
    """(ALBEDO_NODES,) float32: the single-scatter albedo E of the GGX lobe (F = 1) at
    N.V = (i / (nodes - 1))^2 (no lower than 1e-4), for one roughness (clamped), by the float64
    model's quadrature."""
    r = max(float(perceptual_roughness), MIN_PERCEPTUAL_ROUGHNESS)
    mu = np.maximum((np.arange(ALBEDO_NODES) / (ALBEDO_NODES - 1)) ** 2, MIN_N_DOT_V)
    a, b, _ = shading_model.dfg_integrate(mu, np.full_like(mu, r), model=model, n=ALBEDO_ORDER)
    table = (a + b).astype(np.float32)
    table.flags.writeable = False   # cached: shared by every caller
    return table


def material_values(m: Material) -> dict:
    """A cell's Material as the plugin's parameters (linear RGB, clamped roughness)."""
    f0 = dielectric_f0(m.ior, m.specular_color)
    return {"base_color": tuple(float(c) for c in m.base_color), "metallic": float(m.metallic),
            "roughness": max(float(m.roughness), MIN_PERCEPTUAL_ROUGHNESS),
            "f0": tuple(float(c) for c in f0), "specular": float(m.specular)}


_registered: dict = {}


def plugin_class():
    """The Mitsuba BSDF class (the variant must be set first), registered as PLUGIN."""
    if "class" in _registered:
        return _registered["class"]
    import drjit as dr
    import mitsuba as mi

    def max3(c):
        return dr.maximum(dr.maximum(c[0], c[1]), c[2])

    def luminance(c):
        return REC709_LUMINANCE[0] * c[0] + REC709_LUMINANCE[1] * c[1] + REC709_LUMINANCE[2] * c[2]

    class GltfBSDF(mi.BSDF):
        """Parameters are opaque JIT values: a scene's kernels are compiled once and each
        cell's material only changes their contents (set). Properties: 'multiscatter' (bool)
        and, for a plugin made from a dict (Mitsuba's chi2 test), the Material's base_color
        (a colour), metallic, roughness, ior and specular."""

        def __init__(self, props):
            super().__init__(props)
            reflection = mi.BSDFFlags.FrontSide
            self.m_components = [mi.BSDFFlags.DiffuseReflection | reflection,
                                 mi.BSDFFlags.GlossyReflection | reflection]
            self.m_flags = self.m_components[0] | self.m_components[1]
            self.multiscatter = bool(props.get("multiscatter", False))
            given = {name: float(props[name]) for name in ("metallic", "roughness", "ior", "specular")
                     if name in props}
            if "base_color" in props:
                given["base_color"] = tuple(float(c) for c in props["base_color"])
            self.set(Material(**{"base_color": (0.5, 0.5, 0.5), "roughness": 1.0, **given}))

        def set(self, material: Material, albedo: np.ndarray | None = None) -> None:
            v = material_values(material)
            self.base = dr.opaque(mi.Color3f, v["base_color"])
            self.metallic = dr.opaque(mi.Float, v["metallic"])
            self.alpha = dr.opaque(mi.Float, v["roughness"] ** 2)
            self.f0 = dr.opaque(mi.Color3f, v["f0"])
            self.specular = dr.opaque(mi.Float, v["specular"])
            if self.multiscatter:
                table = albedo_table(v["roughness"]) if albedo is None else albedo
                self.albedo = mi.Float(np.asarray(table, np.float32))   # an array: always a kernel input

        def _compensation(self, f0, n_dot_v):
            if not self.multiscatter:
                return mi.Color3f(1.0)
            x = dr.sqrt(dr.clip(n_dot_v, 0.0, 1.0)) * (ALBEDO_NODES - 1)
            i = mi.UInt32(dr.minimum(dr.floor(x), ALBEDO_NODES - 2))
            # Linear in N.V between the nodes around it.
            lo, hi = dr.square(mi.Float(i) / (ALBEDO_NODES - 1)), dr.square(mi.Float(i + 1) / (ALBEDO_NODES - 1))
            t = dr.clip((dr.clip(n_dot_v, 0.0, 1.0) - lo) / (hi - lo), 0.0, 1.0)
            e = dr.lerp(dr.gather(mi.Float, self.albedo, i), dr.gather(mi.Float, self.albedo, i + 1), t)
            return 1.0 + f0 * (1.0 / dr.maximum(e, 1e-4) - 1.0)

        def _f_cos(self, wi, wo, active):
            """f(wi, wo) N.L and the lobes' parts: glTF Appendix B with sdfpbr's clamps."""
            n_dot_v = dr.maximum(wi.z, MIN_N_DOT_V)
            n_dot_l = wo.z
            active = active & (wi.z > 0.0) & (n_dot_l > 0.0)
            h = dr.normalize(wi + wo)
            v_dot_h = dr.clip(dr.abs(dr.dot(wi, h)), 0.0, 1.0)
            n_dot_h = dr.clip(h.z, 0.0, 1.0)
            # D = alpha^2 / (pi (N.H^2 (alpha^2 - 1) + 1)^2), with 1 - N.H^2 as |N x H|^2 = hx^2 + hy^2
            # (no cancellation at the peak of a smooth lobe in float32).
            sin2 = dr.select(n_dot_h > 0.0, h.x * h.x + h.y * h.y, 1.0)
            k = self.alpha / (sin2 + dr.square(n_dot_h * self.alpha))
            d = k * k * dr.inv_pi
            a2 = dr.square(self.alpha)
            nl = dr.maximum(n_dot_l, MIN_N_DOT_L)
            vis = 0.5 / dr.maximum(nl * dr.sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2)
                                   + n_dot_v * dr.sqrt(nl * nl * (1.0 - a2) + a2), 1e-12)
            fc = dr.power(1.0 - v_dot_h, 5.0)
            f_dielectric = self.specular * (self.f0 + (1.0 - self.f0) * fc)
            f_metal = self.base + (1.0 - self.base) * fc
            diffuse = self.base * dr.inv_pi * (1.0 - max3(f_dielectric))
            spec_dielectric = d * vis * f_dielectric * self._compensation(self.f0, n_dot_v)
            spec_metal = d * vis * f_metal * self._compensation(self.base, n_dot_v)
            f = (1.0 - self.metallic) * (diffuse + spec_dielectric) + self.metallic * spec_metal
            return dr.select(active, f * n_dot_l, 0.0)

        def _specular_share(self, wi):
            n_dot_v = dr.maximum(wi.z, MIN_N_DOT_V)
            fc = dr.power(1.0 - dr.clip(n_dot_v, 0.0, 1.0), 5.0)
            f_dielectric = max3(self.specular * (self.f0 + (1.0 - self.f0) * fc))
            spec = dr.lerp(f_dielectric, luminance(self.base + (1.0 - self.base) * fc), self.metallic)
            diffuse = (1.0 - self.metallic) * luminance(self.base) * (1.0 - f_dielectric)
            share = dr.clip(spec / dr.maximum(spec + diffuse, 1e-12), MIN_LOBE_SHARE, 1.0 - MIN_LOBE_SHARE)
            return dr.select(diffuse > 0.0, share, 1.0)

        def _distribution(self):
            return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)

        def _pdf(self, wi, wo, active):
            share = self._specular_share(wi)
            h = dr.normalize(wi + wo)
            distribution = self._distribution()
            pdf_spec = distribution.pdf(wi, h) / dr.maximum(4.0 * dr.dot(wo, h), 1e-12)
            pdf_spec = dr.select(dr.dot(wo, h) > 0.0, pdf_spec, 0.0)
            pdf_diffuse = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            pdf = share * pdf_spec + (1.0 - share) * pdf_diffuse
            return dr.select(active & (wi.z > 0.0) & (wo.z > 0.0), pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._f_cos(si.wi, wo, active)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si.wi, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._f_cos(si.wi, wo, active), self._pdf(si.wi, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            share = self._specular_share(wi)
            specular = sample1 < share
            m, _ = self._distribution().sample(wi, sample2)
            wo_spec = mi.reflect(wi, m)
            wo_diffuse = mi.warp.square_to_cosine_hemisphere(sample2)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = dr.select(specular, wo_spec, wo_diffuse)
            bs.eta = 1.0
            bs.sampled_component = dr.select(specular, mi.UInt32(1), mi.UInt32(0))
            bs.sampled_type = dr.select(specular, mi.UInt32(int(mi.BSDFFlags.GlossyReflection)),
                                        mi.UInt32(int(mi.BSDFFlags.DiffuseReflection)))
            value, pdf = self._f_cos(wi, bs.wo, active), self._pdf(wi, bs.wo, active)
            bs.pdf = pdf
            ok = active & (wi.z > 0.0) & (bs.wo.z > 0.0) & (pdf > 0.0)
            return bs, dr.select(ok, value / dr.maximum(pdf, 1e-30), 0.0)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"{PLUGIN}[multiscatter={self.multiscatter}]"

    mi.register_bsdf(PLUGIN, lambda props: GltfBSDF(props))
    _registered["class"] = GltfBSDF
    return GltfBSDF
