"""White-furnace energy report: the renderer follows the float64 model cell by cell, and the
model's own gains and losses are reported as such (docs/model.md, the white furnace)."""
import io
import json
import math
from contextlib import redirect_stdout

import numpy as np
import pytest

from sdfpbr.oracle import shading_model
from helpers import FurnaceBudget
from sdfpbr.cli.main import main
from sdfpbr.devtools.energy import GRAZING_N_DOT_V, cell_energy, furnace_spec, model_summary
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.spec.material import MIN_PERCEPTUAL_ROUGHNESS


@pytest.fixture(scope="module")
def report(session):
    spec = furnace_spec(make_spec(width=150, height=150, rows=3, cols=3))
    res = session.render(spec)
    return spec, res, cell_energy(res, spec)


def test_every_cell_follows_the_float64_model(session, report):
    """Every sphere pixel, grazing silhouettes included (NdotV down to 0.005 here), is the model
    within what the chart's DFG table allows it (test_chart.FurnaceBudget); the report's own
    figure per cell (against FurnaceTable, within 1e-5 of the model from NdotV 0.05) agrees."""
    spec, res, cells = report
    assert len(cells) == 9 and all(c.pixels > 100 for c in cells)
    budget = FurnaceBudget(session, spec, res, res.aov["row"] >= 0)
    budget.check()
    allowed = (budget.interpolation + budget.spread + budget.filter).max(-1)
    for c in cells:
        m = (res.aov["row"][res.aov["row"] >= 0] == c.row) & (res.aov["col"][res.aov["row"] >= 0] == c.col)
        assert c.min_n_dot_v < GRAZING_N_DOT_V and c.max_err <= allowed[m].max() + 1e-5, c


def test_compensated_white_metal_row_is_exactly_white(report):
    _, _, cells = report
    for c in (c for c in cells if c.metallic == 1.0):
        assert abs(c.exp_min - 1) < 1e-9 and abs(c.exp_max - 1) < 1e-9
        # The chart reads A + B and E = A + B from one texel fetch: (A + B) / E is 1 in float32.
        assert abs(c.rendered_min - 1) < 1e-5 and abs(c.rendered_max - 1) < 1e-5


def test_mixed_metallic_row_is_the_mix_of_its_lobes(session, report):
    """Metallic 0.5 mixes the two lobes, each compensated on its own f0 (docs/model.md, the white furnace:
    engines that compensate on a blended f0 lose energy there): every pixel is the average of
    the float64 dielectric and metal expectations within what the chart's DFG table allows it
    (test_chart.FurnaceBudget)."""
    spec, res, cells = report
    m = res.aov["metallic"] == 0.5
    budget = FurnaceBudget(session, spec, res, m)
    n_dot_v = res.aov["ndotv"][m].astype(float)
    rough = np.maximum(res.aov["roughness"][m].astype(float), MIN_PERCEPTUAL_ROUGHNESS)
    half = 0.5 * (shading_model.furnace_expected(n_dot_v, np.ones(3), 0.0, rough)
                  + shading_model.furnace_expected(n_dot_v, np.ones(3), 1.0, rough))
    assert (np.abs(budget.got - half) <= budget.interpolation + budget.spread + budget.filter).all()
    assert m.sum() > 100


def test_smooth_dielectric_gains_energy_at_grazing_angles(session, report):
    """The model's Lambert body, checked with an independent seeded Monte Carlo: at NdotV = 0.05
    the coat reflects what its GGX lobe at the roughness floor does (0.781; a mirror's F(mu) =
    0.04 + 0.96 (1 - mu)^5 is 0.783) and the body, weighted by 1 - F(VdotH) over cosine-
    distributed light, adds its own share -- 1.72 in all, more than it receives."""
    mu = 0.05
    rng = np.random.default_rng(7)
    n = 400_000
    l = shading_model.sample_sphere_cosine(rng, n)
    v = np.array([math.sqrt(1 - mu * mu), 0.0, mu])
    h = l + v
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    v_dot_h = np.clip(h @ v, 0, 1)
    body = 1 - (0.04 + 0.96 * (1 - v_dot_h) ** 5)
    lambert, lambert_stderr = np.mean(body), np.std(body) / math.sqrt(n)
    a, b, _ = shading_model.dfg_integrate(mu, MIN_PERCEPTUAL_ROUGHNESS)
    f0 = np.float64(shading_model.DIELECTRIC_F0)
    coat = (f0 * a + b) * shading_model.energy_compensation(f0, np.asarray(a + b))
    model = shading_model.furnace_expected(mu, 1.0, 0.0, 0.0)[0]
    assert model == pytest.approx(coat + lambert, abs=5 * lambert_stderr)
    assert model == pytest.approx(1.72, abs=5e-3)
    spec, res, cells = report
    smooth_dielectric = next(c for c in cells if c.metallic == 0 and c.roughness == 0)
    assert smooth_dielectric.exp_max > 1.4 and smooth_dielectric.rendered_max > 1.4   # shown, not clipped
    # The report's grazing peak is the rendered one, and that is the model's own peak within what
    # the DFG table allows its pixels (|max a - max b| <= max |a - b|).
    aov = res.aov
    cell = (aov["row"] == smooth_dielectric.row) & (aov["col"] == smooth_dielectric.col)
    grazing = cell & (aov["ndotv"] < GRAZING_N_DOT_V)
    budget = FurnaceBudget(session, spec, res, grazing)
    allowed = (budget.interpolation + budget.spread + budget.filter).max()
    rendered_peak, model_peak = budget.got.mean(-1).max(), budget.model.mean(-1).max()
    assert smooth_dielectric.grazing_rendered_max == pytest.approx(rendered_peak, rel=1e-6)
    assert abs(rendered_peak - model_peak) <= allowed
    # The report's expected peak is the model's, within its FurnaceTable's interpolation there.
    from sdfpbr.oracle.furnace import FurnaceTable
    n_dot_v = aov["ndotv"][grazing].astype(float)
    tabulated = FurnaceTable().expected(n_dot_v, np.zeros_like(n_dot_v), np.ones(3), np.zeros_like(n_dot_v))
    assert abs(smooth_dielectric.grazing_exp_max - model_peak) <= np.abs(tabulated - budget.model).max() + 1e-12


def test_single_scatter_metal_loses_what_the_albedo_says(session):
    spec = furnace_spec(make_spec(width=120, height=60, rows=1, cols=3, metallic=(1, 1), multiscatter=False))
    res = session.render(spec)
    cells = cell_energy(res, spec)
    rough = next(c for c in cells if c.roughness == 1.0)
    # docs/model.md's test vectors: E(mu = 1, r = 1) = 1 - ln 2 exactly; the cell's darkest pixel faces the camera.
    assert rough.exp_min == pytest.approx(1 - math.log(2), abs=2e-3)
    FurnaceBudget(session, spec, res, res.aov["row"] >= 0).check()   # every pixel is what the model loses
    assert any("loses energy" in line and "multiple scattering is off" in line for line in model_summary(cells, True))


def test_cli_energy_json(tmp_path):
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["energy", "--size", "96x96", "--rows", "2", "--cols", "2", "--json", "-"]) == 0
    data = json.loads(out.getvalue())
    assert len(data["cells"]) == 4 and data["spec"]["env"] == "uniform" and data["spec"]["lights"] == []
    assert any("gains energy" in line for line in data["summary"])
    path = tmp_path / "energy.json"
    with redirect_stdout(io.StringIO()) as table:
        assert main(["energy", "--size", "96x96", "--rows", "2", "--cols", "2", "--json", str(path)]) == 0
    assert "rendered min/mean/max" in table.getvalue()
    assert json.loads(path.read_text())["cells"][0]["pixels"] > 0


def test_cli_energy_says_which_settings_its_furnace_replaces(capsys):
    """A furnace is its own scene: settings of the chart it replaces are named on stderr, not
    dropped silently (an environment file given to it is never read)."""
    assert main(["energy", "--size", "64x64", "--rows", "1", "--cols", "2", "--env", "sky", "--no-shadows"]) == 0
    assert "it replaces the spec's env, shadows" in capsys.readouterr().err
    assert main(["energy", "--size", "64x64", "--rows", "1", "--cols", "2"]) == 0
    assert "replaces" not in capsys.readouterr().err
