"""The split sum's lobe table (shaders/ibl_lobe_table.glsl), fitted in float64.

The chart reads a rough lobe's prefiltered radiance as a core (the moment-fitted direction and
width of ibl.glsl's specular_lookup, the width scaled by ``core``) read twice, ``delta`` either
side of its direction in the plane of N and R, plus a share ``tail`` of the widest level read
along N. Per node of a grid over perceptual roughness and N.V this module picks the (delta,
core, tail) whose radiance is nearest, in mean relative error, to the exact lobe average
(oracle.ibl_integral's S_A + S_B over the DFG's A + B: the split sum's own definition) under
random skies of three lobes over a gradient, with every prefiltered read taken from
oracle.ibl_integral.prefiltered (the bake's definition) rather than a baked chain. Held-out
skies then compare the table with the one-read ramps it replaces.

    python -m sdfpbr.oracle.lobe_fit [--jobs N]   # ~25 CPU-minutes; rewrites the table

The fitted direction and width polynomials (LOBE_T, LOBE_DR) and CORE_SCALE are read from
ibl.glsl, where they are defined.
"""
from __future__ import annotations

import re
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from . import shading_model
from .ibl_integral import specular_terms, prefiltered

R_NODES = (0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
MU_NODES = (0.1, 0.3, 0.5, 0.7, 0.9)
DELTAS = (0.0, 0.1, 0.2, 0.3, 0.4)
CORES = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
TAILS = tuple(np.linspace(0.0, 0.6, 25))
TRAIN_SKIES, HELD_SKIES, POINTS = 8, 4, 20
ORDER = 64           # prefilter quadrature per axis (the levels' test uses 64 too)


def _shader_text() -> str:
    from ..shading.compose import shader_dir
    return (shader_dir() / "ibl.glsl").read_text()


def _glsl_mat4(text: str, name: str) -> np.ndarray:
    body = re.search(rf"const mat4 {name} = mat4\(([^)]*)\)", text).group(1)
    return np.array([float(x) for x in body.replace("\n", " ").split(",")]).reshape(4, 4)


def _glsl_define(text: str, name: str) -> float:
    return float(re.search(rf"#define {name} ([0-9.]+)", text).group(1))


class Sky:
    """L(d) = a + b max(d.y, 0) + sum of three lobes c_i max(d . s_i, 0)^k_i, RGB."""

    def __init__(self, seed: int):
        rng = np.random.default_rng(seed)
        self.a = rng.uniform(0.02, 0.3, 3)
        self.b = rng.uniform(0.0, 1.0, 3)
        self.axes = shading_model.normalize(rng.normal(size=(3, 3)))
        self.k = np.exp(rng.uniform(np.log(4), np.log(256), 3))
        self.c = rng.uniform(0.5, 8.0, (3, 3))

    def radiance(self, d: np.ndarray) -> np.ndarray:
        d = np.asarray(d, np.float64)
        out = self.a + self.b * np.maximum(d[..., 1], 0.0)[..., None]
        for axis, k, c in zip(self.axes, self.k, self.c):
            out = out + c * (np.maximum(d @ axis, 0.0)[..., None] ** k)
        return out


def _poly3x3(c: np.ndarray, mu: np.ndarray, a: np.ndarray) -> np.ndarray:
    """ibl.glsl's poly3x3: GLSL's mat4 columns c[i] are the coefficients of mu^i."""
    inner = np.stack([a ** 0, a, a ** 2, a ** 3], -1) @ c.T
    return np.sum(inner * np.stack([mu ** 0, mu, mu ** 2, mu ** 3], -1), -1)


def lookup(n, v, r, lobe_t, lobe_dr):
    """ibl.glsl's specular_lookup (IBL_DOMINANT_DIR moments): direction and roughness."""
    mu = np.clip(np.sum(n * v, -1), 1e-4, 1.0)
    reflected = 2.0 * mu[:, None] * n - v
    mu_c, a_c = np.clip(mu, 0.1, 1.0), np.clip(np.full_like(mu, r * r), 0.01, 1.0)
    t = np.clip(_poly3x3(lobe_t, mu_c, a_c), 0.0, 1.0)
    d = shading_model.normalize(n + (reflected - n) * t[:, None])
    return d, r + _poly3x3(lobe_dr, mu_c, a_c) * (r >= 0.1)


def exact_radiance(n, v, r, sky):
    """The lobe's mean radiance as the split sum defines it: (S_A + S_B) / (A + B)."""
    m = len(n)
    sa, sb = specular_terms(n, v, np.full(m, r), sky, 48, 96)
    mu = np.clip(np.sum(n * v, -1), shading_model.MIN_N_DOT_V, 1.0)
    a, b, _ = shading_model.dfg_integrate(mu, np.full(m, r))
    return (sa + sb) / (a + b)[:, None]


def _points(seed: int, mu: float, count: int):
    rng = np.random.default_rng(seed)
    n = shading_model.normalize(rng.normal(size=(count, 3)))
    t = rng.normal(size=(count, 3))
    t = shading_model.normalize(t - np.sum(t * n, -1, keepdims=True) * n)
    return n, mu * n + np.sqrt(1.0 - mu * mu) * t


def _reads(n, v, r, sky, lobe_t, lobe_dr, fade, pairs):
    """Per (delta, core) of ``pairs``: the core's radiance; and the tail's (the r = 1 level
    along N)."""
    d, r_look = lookup(n, v, r, lobe_t, lobe_dr)
    across = n - d * np.sum(n * d, -1, keepdims=True)   # ibl.glsl's shade_ibl, LOBE_TAP_FADE
    across = across / np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), fade)
    cores = {}
    for delta, core in pairs:
        width = float(np.clip(r_look[0] * core, 0.0, 1.0))   # r_look depends on N.V only
        if delta == 0.0:
            cores[delta, core] = prefiltered(d, width, sky, ORDER, ORDER, kernel="brdf")
        else:
            cores[delta, core] = 0.5 * sum(prefiltered(shading_model.normalize(d + s * delta * across), width, sky,
                                                       ORDER, ORDER, kernel="brdf") for s in (1.0, -1.0))
    return cores, prefiltered(n, 1.0, sky, ORDER, ORDER, kernel="brdf")


def _error(core_radiance, tail_radiance, tail, exact) -> float:
    return float(np.abs(((1.0 - tail) * core_radiance + tail * tail_radiance) / exact - 1.0).mean())


def fit_node(args) -> dict:
    """(delta, core, tail) for one (r, N.V) node, and its held-out errors against the ramps."""
    i, j, r, mu = args
    text = _shader_text()
    lobe_t, lobe_dr, core_scale = (_glsl_mat4(text, "LOBE_T"), _glsl_mat4(text, "LOBE_DR"),
                                   _glsl_define(text, "CORE_SCALE"))
    fade = _glsl_define(text, "LOBE_TAP_FADE")
    err = np.zeros((len(DELTAS), len(CORES), len(TAILS)))
    for s in range(TRAIN_SKIES):
        sky = Sky(100 + s)
        n, v = _points(10_000 * i + 100 * j + s, mu, POINTS)
        exact = exact_radiance(n, v, r, sky)
        cores, tail_radiance = _reads(n, v, r, sky, lobe_t, lobe_dr, fade,
                                      [(delta, core) for delta in DELTAS for core in CORES])
        for a, delta in enumerate(DELTAS):
            for b, core in enumerate(CORES):
                for c, tail in enumerate(TAILS):
                    err[a, b, c] += _error(cores[delta, core], tail_radiance, tail, exact) / TRAIN_SKIES
    a, b, c = np.unravel_index(err.argmin(), err.shape)
    fit = dict(delta=DELTAS[a], core=CORES[b], tail=float(TAILS[c]))
    # The one-read ramps the table replaces (ibl.glsl before it), on skies the fit never saw.
    # Its lobe_fit's IBL_TWO_LOBE branch (the ramps' constants read from ibl.glsl): the core
    # scale's smoothstep to 1 over r CORE_FULL_FROM .. 1, the tail's ramp.
    full_from = _glsl_define(text, "CORE_FULL_FROM")
    x = min(max((r - full_from) / (1.0 - full_from), 0.0), 1.0)
    ramp_core = core_scale + (1.0 - core_scale) * x * x * (3.0 - 2.0 * x)
    ramp_tail = min(max(_glsl_define(text, "TAIL_SLOPE") * (r - _glsl_define(text, "TAIL_FROM")), 0.0),
                    _glsl_define(text, "TAIL_MAX"))
    held = {"table": 0.0, "ramps": 0.0}
    for s in range(HELD_SKIES):
        sky = Sky(900 + s)
        n, v = _points(20_000 * i + 100 * j + s, mu, POINTS)
        exact = exact_radiance(n, v, r, sky)
        table, ramps = (fit["delta"], fit["core"]), (0.0, ramp_core)
        cores, tail_radiance = _reads(n, v, r, sky, lobe_t, lobe_dr, fade, [table, ramps])
        held["table"] += _error(cores[table], tail_radiance, fit["tail"], exact) / HELD_SKIES
        held["ramps"] += _error(cores[ramps], tail_radiance, ramp_tail, exact) / HELD_SKIES
    return dict(r=r, mu=mu, **fit, train=float(err.min()), **held)


def table_glsl(nodes: list[dict]) -> str:
    def array(name, key):
        rows = [", ".join(f"{n[key]:.3f}" for n in nodes if n["r"] == r) for r in R_NODES]
        return f"const float {name}[{len(nodes)}] = float[](\n    " + ",\n    ".join(rows) + ");\n"
    held = [(n["table"], n["ramps"]) for n in nodes]
    return (
        "// The split sum's lobe table, written by `python -m sdfpbr.oracle.lobe_fit` (do not edit):\n"
        "// per perceptual roughness (rows, r = 0.2 .. 1 step 0.1) and N.V (columns, 0.1 .. 0.9 step\n"
        "// 0.2), the core's two reads' offset, its width scale and the tail's share, fitted to the\n"
        "// float64 lobe average under random three-lobe skies. On held-out skies the mean relative\n"
        f"// error is {100 * np.mean([t for t, _ in held]):.2f} % over the nodes (the one-read ramps: "
        f"{100 * np.mean([r for _, r in held]):.2f} %).\n"
        + array("LOBE_TABLE_DELTA", "delta") + array("LOBE_TABLE_CORE", "core") + array("LOBE_TABLE_TAIL", "tail")
        + f"""
// Bilinear over the grid, clamped to its edges.
LobeFit lobe_table(float perceptual_roughness, float n_dot_v) {{
    float x = clamp((perceptual_roughness - {R_NODES[0]:.1f}) / 0.1, 0.0, {len(R_NODES) - 1:.1f});
    float y = clamp((n_dot_v - {MU_NODES[0]:.1f}) / 0.2, 0.0, {len(MU_NODES) - 1:.1f});
    int i = min(int(x), {len(R_NODES) - 2}), j = min(int(y), {len(MU_NODES) - 2});
    float fx = x - float(i), fy = y - float(j);
    int k = i * {len(MU_NODES)} + j;
    vec4 w = vec4((1.0 - fx) * (1.0 - fy), (1.0 - fx) * fy, fx * (1.0 - fy), fx * fy);
    ivec4 at = ivec4(k, k + 1, k + {len(MU_NODES)}, k + {len(MU_NODES) + 1});
    return LobeFit(dot(w, vec4(LOBE_TABLE_TAIL[at.x], LOBE_TABLE_TAIL[at.y], LOBE_TABLE_TAIL[at.z], LOBE_TABLE_TAIL[at.w])),
                   dot(w, vec4(LOBE_TABLE_CORE[at.x], LOBE_TABLE_CORE[at.y], LOBE_TABLE_CORE[at.z], LOBE_TABLE_CORE[at.w])),
                   dot(w, vec4(LOBE_TABLE_DELTA[at.x], LOBE_TABLE_DELTA[at.y], LOBE_TABLE_DELTA[at.z], LOBE_TABLE_DELTA[at.w])));
}}
""")  # noqa: E501 -- generated GLSL, kept as written


def main(argv: list[str]) -> int:
    jobs = int(argv[argv.index("--jobs") + 1]) if "--jobs" in argv else 2
    grid = [(i, j, r, mu) for i, r in enumerate(R_NODES) for j, mu in enumerate(MU_NODES)]
    with ProcessPoolExecutor(jobs) as pool:
        nodes = []
        for node in pool.map(fit_node, grid):
            print(" ".join(f"{k} {v:.4g}" for k, v in node.items()), flush=True)
            nodes.append(node)
    from ..shading.compose import shader_dir
    (shader_dir() / "ibl_lobe_table.glsl").write_text(table_glsl(nodes))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
