"""The random-scene accuracy suite (sdfpbr.devtools.bench.random_suite): its draws are seeded
and cover the documented distribution, its regions are where the camera puts them, and its
figures are what they say."""
from __future__ import annotations

import math

import numpy as np
import pytest

from sdfpbr.devtools.bench import random_suite as R
from sdfpbr.devtools.bench.regions import region_masks


def test_draws_are_seeded_and_a_longer_run_extends_a_shorter():
    a = R.draw_scenes(6, 3)
    b = R.draw_scenes(9, 3)
    c = R.draw_scenes(6, 4)
    for x, y in zip(a, b):
        assert x.fields == y.fields and x.notes == y.notes
        assert (x.env is None) == (y.env is None) and (x.env is None or np.array_equal(x.env, y.env))
    assert [s.fields for s in a] != [s.fields for s in c]


def _share(scenes, test) -> float:
    return sum(1 for s in scenes if test(s)) / len(scenes)


def test_draws_cover_the_documented_distribution():
    """Each documented probability p, over n draws, within 4.5 binomial standard deviations
    (sqrt(p (1 - p) / n)): a draw that ignored a branch would be many deviations off."""
    n = 600
    scenes = R.draw_scenes(n, 11)

    def near(share, p):
        return abs(share - p) <= 4.5 * math.sqrt(p * (1 - p) / n)

    assert near(_share(scenes, lambda s: s.env is not None), 0.6)
    assert near(_share(scenes, lambda s: s.env is not None and "sun" in s.notes[0]), 0.25)
    assert near(_share(scenes, lambda s: s.fields["lights"] == "none"), 0.5)
    assert near(_share(scenes, lambda s: s.fields["roughness"] == 0.0), 0.15)
    assert near(_share(scenes, lambda s: s.fields["metallic"] == 1.0), 0.35)
    assert near(_share(scenes, lambda s: "alpha" in s.fields), 0.1)
    assert near(_share(scenes, lambda s: s.fields["ground_roughness"] <= 0.1), 0.15)
    assert near(_share(scenes, lambda s: min(s.fields["base_color"]) >= 0.85), 0.15)
    assert near(_share(scenes, lambda s: max(s.fields["base_color"]) <= 0.04), 0.1)
    # The hard case is in it: polished white metal (on a white floor in some draws).
    assert any(s.fields["roughness"] == 0.0 and s.fields["metallic"] == 1.0 and min(s.fields["base_color"]) >= 0.85
               for s in scenes)
    for lobe in ("clearcoat", "sheen_color", "ior", "specular"):
        assert near(_share(scenes, lambda s: lobe in s.fields), 0.075)


def test_random_skies_are_smooth_finite_and_carry_their_sun():
    rng = np.random.default_rng(5)
    sky, _ = R.random_sky(rng, sun=False)
    sunny, note = R.random_sky(rng, sun=True)
    assert sky.shape == (*R.ENV_SIZE, 3) and np.isfinite(sky).all() and (sky > 0).all()
    # Smooth: neighbouring texels differ by a few per cent at most away from the horizon's row.
    step = np.abs(np.diff(sky, axis=1)) / sky[:, 1:]
    assert step.max() < 0.05
    # The sun is the brightest texel by the contrast its note states (at least 10x the zenith).
    assert sunny.max() >= 10 * sunny[0].mean() * 0.8 and "sun" in note


def test_needed_noise_is_a_third_of_the_smaller_of_bias_and_target():
    target = R.TARGETS["high"]["bias_p95"]
    assert R.needed_noise([0.001], ["high"]) == pytest.approx(target / 3)
    assert R.needed_noise([0.09], ["high"]) == pytest.approx(0.03)
    assert R.needed_noise([0.09, 0.002], ["high", "high"]) == pytest.approx(target / 3)
    assert R.needed_noise([0.06], ["draft"]) == pytest.approx(0.02)   # no target: its own bias
    assert R.needed_noise([None], ["high"]) is None


def test_region_noise_is_the_relative_two_seed_difference():
    a = {"x": 1.02, "y": None, "z": 0.0}
    b = {"x": 0.98, "y": 1.0, "z": 0.0}
    noise = R.region_noise(a, b)
    assert noise["x"] == pytest.approx(0.04) and noise["y"] is None and noise["z"] is None


@pytest.mark.parametrize("stage", ["cells", "shared"])
def test_regions_match_the_charts_coverage(session, stage):
    """The numpy camera's regions against the GPU's AOVs of the same scene: the sphere's regions
    are the pixels the chart covers fully, the silhouette those it covers in part, the floor's
    those it leaves; and the regions do not overlap."""
    scene = R.draw_scenes(1, 2)[0]
    spec = R.scene_spec(scene, (96, 96), "draft", stage=stage)
    masks = region_masks(spec)
    stack = np.stack(list(masks.values()))
    assert stack.sum(0).max() == 1
    cov = session.render(spec).aov["coverage"]
    sphere = masks["sphere_upper"] | masks["sphere_lower"]
    floor = masks["floor_bulge"] | masks["floor_ring"] | masks["floor_far"]
    assert (cov[sphere] > 0.99).mean() > 0.99
    assert (cov[floor] < 0.01).mean() > 0.99
    edge = masks["silhouette"]
    assert ((cov[edge] > 0.0) & (cov[edge] < 1.0)).mean() > 0.8   # sub-sample grids differ
    for k in ("sphere_upper", "sphere_lower", "floor_bulge", "floor_ring", "floor_far", "silhouette"):
        assert masks[k].sum() >= R.REGION_MIN_PIXELS, k


def test_a_tiny_run_reports_what_it_measured(tmp_path):
    # A preset with targets (default) and one without (draft): high has targets too, but its
    # 512² bakes were most of this test's 23 s and add nothing to what it checks.
    cfg = R.RandomConfig(count=1, seed=1, presets=("draft", "default"), size=(48, 48), ref_samples=16,
                         max_ref_samples=16, heatmaps=str(tmp_path))
    report = R.run_random(cfg)
    row = report["scenes"][0]
    assert row["ref_samples"] == 16
    for p in cfg.presets:
        for k, b in row["presets"][p]["bias"].items():
            assert b is None or np.isfinite(b)
        assert 0.0 <= row["presets"][p]["flip"] <= 1.0
    s = report["summary"]
    assert set(s) == {"draft", "default"} and "targets" in s["default"] and "targets" not in s["draft"]
    text = R.format_random(report)
    assert "95th" in text and "worst" in text
    if s["default"].get("worst_scene"):
        assert any(p.name.startswith("bias_") for p in tmp_path.iterdir())
