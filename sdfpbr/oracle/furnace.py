"""The float64 white-furnace expectation (docs/model.md, the white furnace): the split-sum terms of
``shading_model.dfg_integrate`` tabulated per roughness, so a whole render can be checked pixel by
pixel. The stress sweep and the energy report read it."""
from __future__ import annotations

import numpy as np

from . import shading_model


class FurnaceTable:
    """The float64 split-sum terms (A, B, C) of shading_model.dfg_integrate, tabulated per roughness
    at N_MU values of NdotV and interpolated linearly (the interpolation error, < 1e-5 for
    NdotV >= 0.05, is checked in tests/test_stress.py against direct integration)."""

    N_MU = 1024
    QUADRATURE = 32   # Gauss-Legendre order; shading_model.dfg_integrate says 32 agrees with 512 to 1e-9

    def __init__(self):
        self.mu = np.linspace(shading_model.MIN_N_DOT_V, 1.0, self.N_MU)
        self._terms: dict = {}

    def terms(self, model: str, perceptual_roughness: float):
        r = max(float(perceptual_roughness), shading_model.MIN_PERCEPTUAL_ROUGHNESS)
        key = (model, round(r, 12))
        if key not in self._terms:
            self._terms[key] = shading_model.dfg_integrate(self.mu, r, model=model, n=self.QUADRATURE)
        return self._terms[key]

    def expected(self, n_dot_v, perceptual_roughness, base_color, metallic, model="gltf", multiscatter=True):
        """furnace_expected (radiance 1) at each pixel: (N,) inputs -> (N, 3)."""
        n_dot_v = np.clip(np.asarray(n_dot_v, np.float64), shading_model.MIN_N_DOT_V, 1.0)
        rough = np.asarray(perceptual_roughness, np.float64)
        A, B, C = (np.empty_like(n_dot_v) for _ in range(3))
        for r in np.unique(rough):
            m = rough == r
            tA, tB, tC = self.terms(model, r)
            A[m], B[m], C[m] = (np.interp(n_dot_v[m], self.mu, t) for t in (tA, tB, tC))
        return shading_model.furnace_from_dfg(A, B, C, base_color, metallic, multiscatter)
