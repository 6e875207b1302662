"""Error metrics against closed forms, the FLIP guard, heat-map layout."""
import numpy as np
import pytest

from sdfpbr.image import metrics as M
from sdfpbr.errors import SpecError

rng = np.random.default_rng(7)


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    """Measured FLIPs are stored in the cache: each test starts from an empty one, so that what
    it measures is measured here, not read from an earlier run."""
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))


def _ref(h=24, w=32):
    return (0.2 + rng.random((h, w, 3))).astype(np.float32)


# --- relative RMSE -----------------------------------------------------------------------------

def test_rel_rmse_identical_is_zero():
    r = _ref()
    assert M.rel_rmse(r, r) == 0.0


@pytest.mark.parametrize("k", [0.01, 0.1, -0.3])
def test_rel_rmse_of_a_uniform_relative_error_is_that_error(k):
    r = _ref()
    # With eps -> 0 the per-pixel relative error is exactly |k| everywhere.
    assert M.rel_rmse(r * (1 + k), r, eps=1e-12) == pytest.approx(abs(k), rel=1e-5)


def test_rel_rmse_closed_form_with_eps():
    c, d, eps = 0.5, 0.2, 0.01
    r = np.full((8, 8, 3), c, np.float32)
    expected = np.sqrt(d * d / (c * c + eps))
    assert M.rel_rmse(r + d, r, eps=eps) == pytest.approx(expected, rel=1e-5)


def test_rel_rmse_mask_and_aov_dict():
    r = _ref(10, 10)
    t = r.copy()
    row = np.full((10, 10), -1, np.int32)
    col = np.full((10, 10), -1, np.int32)
    row[:, :5] = 0
    col[:, :5] = 0
    t[:, 5:] *= 3.0                        # error only outside the spheres
    aov = {"row": row, "col": col}
    assert M.rel_rmse(t, r, mask=aov) == 0.0
    assert M.rel_rmse(t, r) > 0.5
    t[:, :5] *= 1.2                        # now 20% inside as well
    assert M.rel_rmse(t, r, mask=row >= 0, eps=1e-12) == pytest.approx(0.2, rel=1e-5)
    # Half the pixels at 0.2 and half at 2.0: the RMS over all of them.
    assert M.rel_rmse(t, r, eps=1e-12) == pytest.approx(np.sqrt((0.2 ** 2 + 2.0 ** 2) / 2), rel=1e-5)


def test_per_cell_rel_rmse_matches_each_cells_perturbation():
    rows, cols = 2, 3
    H, W = 12, 18
    r = _ref(H, W)
    row = np.repeat(np.arange(rows), H // rows)[:, None].repeat(W, axis=1)
    col = np.repeat(np.arange(cols), W // cols)[None, :].repeat(H, axis=0)
    k = np.array([[0.0, 0.1, 0.2], [0.3, 0.4, 0.5]])
    t = r * (1 + k[row, col])[..., None]
    col = col.copy()
    col[row == 1] = np.where(col[row == 1] == 2, -1, col[row == 1])   # cell (1, 2) not visible
    cells = M.per_cell_rel_rmse(t, r, row, col, rows, cols, eps=1e-12)
    assert cells.shape == (rows, cols)
    assert np.isnan(cells[1, 2])
    np.testing.assert_allclose(cells[~np.isnan(cells)], k[~np.isnan(cells)], rtol=1e-5, atol=1e-7)


def test_per_cell_mean_of_a_synthetic_map():
    row = np.array([[0, 0, 1, 1], [0, 0, 1, -1]])
    col = np.array([[0, 1, 0, 1], [0, 1, 0, 1]])
    e = np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 100.0]])
    m = M.per_cell_mean(e, row, col, 2, 2)
    np.testing.assert_allclose(m, [[3.0, 4.0], [5.0, 4.0]])
    m3 = M.per_cell_mean(e[..., None], row, col, 3, 2)      # (H, W, 1) maps as FLIP returns them
    assert np.isnan(m3[2]).all()


# --- FLIP ----------------------------------------------------------------------------------------

def _ldr(h=48, w=64):
    return (rng.random((h, w, 3)) * 255).astype(np.uint8)


def test_flip_ldr_identical_is_zero_and_alpha_is_ignored():
    a = _ldr()
    rgba = np.concatenate([a, np.zeros(a.shape[:2] + (1,), np.uint8)], axis=2)
    mean, emap = M.flip_ldr(rgba, a)
    assert mean == 0.0
    assert emap.shape == a.shape[:2] and emap.dtype == np.float32


def test_flip_ldr_black_vs_white_is_large_and_grows_with_the_difference():
    black = np.zeros((32, 32, 3), np.uint8)
    white = np.full((32, 32, 3), 255, np.uint8)
    big, emap = M.flip_ldr(white, black)
    assert big > 0.7
    gray = np.full((32, 32, 3), 40, np.uint8)
    small, _ = M.flip_ldr(gray, black)
    assert 0.0 < small < big
    assert emap.min() >= 0.0 and emap.max() <= 1.0


def test_flip_mask_mean_is_the_mean_of_the_map_over_the_mask():
    a, b = _ldr(), _ldr()
    mask = np.zeros(a.shape[:2], bool)
    mask[10:20, 5:40] = True
    mean, emap = M.flip_ldr(a, b, mask=mask)
    assert mean == pytest.approx(float(emap[mask].mean()), rel=1e-6)
    whole, _ = M.flip_ldr(a, b)
    assert whole == pytest.approx(float(emap.mean()), rel=1e-4)


def test_flip_hdr_identical_zero_different_positive_black_reference_survives():
    r = _ref() * 4.0
    assert M.flip_hdr(r, r)[0] == 0.0
    assert M.flip_hdr(r * 3.0, r)[0] > 0.05
    black = np.zeros_like(r)
    # The library aborts the process on a black reference; the guard compares at one exposure.
    mean, emap = M.flip_hdr(r, black)
    assert mean > 0.5 and np.isfinite(emap).all()
    assert M.flip_hdr(black, black)[0] == 0.0


@pytest.mark.parametrize("test, ref, match", [
    (np.zeros((8, 8), np.uint8), np.zeros((8, 8), np.uint8), "shape"),
    (np.zeros((8, 8, 2), np.uint8), np.zeros((8, 8, 2), np.uint8), "shape"),
    (np.zeros((0, 8, 3), np.uint8), np.zeros((0, 8, 3), np.uint8), "empty"),
    (np.zeros((8, 8, 3), np.uint8), np.zeros((8, 9, 3), np.uint8), "must match"),
    (np.zeros((8, 8, 3), np.int32), np.zeros((8, 8, 3), np.int32), "dtype"),
    (np.full((8, 8, 3), np.nan, np.float32), np.zeros((8, 8, 3), np.float32), "NaN"),
    (np.full((8, 8, 3), 2.0, np.float32), np.zeros((8, 8, 3), np.float32), "outside"),
    ("image.png", np.zeros((8, 8, 3), np.uint8), "shape"),
])
def test_flip_ldr_guard_raises_one_clear_line(test, ref, match):
    with pytest.raises(SpecError, match=match) as info:
        M.flip_ldr(test, ref)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("test, ref, kwargs, match", [
    (-np.ones((8, 8, 3), np.float32), np.ones((8, 8, 3), np.float32), {}, "negative"),
    (np.ones((8, 8, 3), np.float32), np.full((8, 8, 3), np.inf, np.float32), {}, "infinite"),
    (np.ones((8, 8, 3), np.float32), np.ones((8, 8, 3), np.float32), {"pixels_per_degree": 0}, "pixels_per_degree"),
    (np.ones((8, 8, 3), np.float32), np.ones((8, 8, 3), np.float32), {"mask": np.zeros((8, 8), bool)}, "no pixels"),
    (np.ones((8, 8, 3), np.float32), np.ones((8, 8, 3), np.float32), {"mask": np.ones((4, 4), bool)}, "mask has shape"),
])
def test_flip_hdr_guard(test, ref, kwargs, match):
    with pytest.raises(SpecError, match=match):
        M.flip_hdr(test, ref, **kwargs)


def test_rel_rmse_guard():
    r = _ref()
    with pytest.raises(SpecError, match="must match"):
        M.rel_rmse(r[:5], r)
    with pytest.raises(SpecError, match="NaN"):
        M.rel_rmse(np.where(r > 0.5, np.nan, r), r)
    with pytest.raises(SpecError, match="eps"):
        M.rel_rmse(r, r, eps=0)
    with pytest.raises(SpecError, match="no pixels"):
        M.rel_rmse(r, r, mask=np.zeros(r.shape[:2], bool))


# --- heat maps -----------------------------------------------------------------------------------

def _find(canvas: np.ndarray, block: np.ndarray) -> tuple[int, int] | None:
    h, w = block.shape[:2]
    for y in range(canvas.shape[0] - h + 1):
        for x in range(canvas.shape[1] - w + 1):
            if np.array_equal(canvas[y:y + h, x:x + w, :3], block):
                return y, x
    return None


@pytest.mark.parametrize("colormap", M.COLORMAPS)
def test_a_colormap_is_the_linear_interpolation_of_its_samples(colormap):
    """The lookup table holds each of the map's samples exactly and the colours between them
    within 1 of 255 of float64 linear interpolation (rounded); out of range clamps, NaN is gray."""
    table = np.asarray(M._COLORMAPS[colormap], np.float64)
    knots = np.arange(len(table)) / (len(table) - 1)
    np.testing.assert_array_equal(M.apply_colormap(knots, colormap), table.astype(np.uint8))
    v = np.concatenate([rng.random(20000), np.linspace(0, 1, 4099)])
    want = np.stack([np.interp(v * (len(table) - 1), np.arange(len(table)), table[:, k]) for k in range(3)], -1)
    got = M.apply_colormap(v, colormap).astype(float)
    assert np.abs(got - np.rint(want)).max() <= 1
    edge = M.apply_colormap(np.array([-0.5, 1.5, np.nan, np.inf]), colormap)
    assert tuple(edge[0]) == tuple(table[0]) and tuple(edge[1]) == tuple(table[-1])
    assert tuple(edge[2]) == tuple(edge[3]) == M._NAN_COLOR


def test_heatmap_holds_the_mapped_errors_and_a_bar_dark_at_the_bottom():
    e = rng.random((40, 60))
    e[3, 4] = np.nan
    img = M.heatmap_image(e, vmin=0.0, vmax=1.0)
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 4
    assert img.shape[0] >= 40 and img.shape[1] > 60 + 10
    where = _find(img, M.apply_colormap(e, "magma"))
    assert where is not None
    y0, x0 = where
    assert tuple(img[y0 + 3, x0 + 4, :3]) == M._NAN_COLOR
    # The colour bar lies right of the map: its darkest magma entry sits below its brightest.
    right = img[:, x0 + 60:, :3].astype(int)
    lum = right.sum(axis=2)
    darkest = np.argwhere((right == (0, 0, 4)).all(axis=2))
    brightest = np.argwhere((right == (252, 253, 191)).all(axis=2))
    assert len(darkest) and len(brightest)
    assert darkest[:, 0].mean() > brightest[:, 0].mean()
    assert lum.max() > 600


def test_heatmap_title_and_range_and_colormap_checks():
    e = np.linspace(0, 0.1, 200).reshape(10, 20)
    plain = M.heatmap_image(e, vmax=0.1)
    titled = M.heatmap_image(e, title="LDR FLIP", vmax=0.1)
    assert titled.shape[0] > plain.shape[0]
    # vmax maps to the top of the colour scale.
    assert _find(plain, M.apply_colormap(e / 0.1)) is not None
    with pytest.raises(SpecError, match="vmax"):
        M.heatmap_image(e, vmin=1.0, vmax=1.0)
    with pytest.raises(SpecError, match="colormap"):
        M.heatmap_image(e, colormap="jet")
    with pytest.raises(SpecError, match="shape"):
        M.heatmap_image(np.zeros((3, 3, 3)))


def test_apply_colormap_ends_and_monotone_luminance():
    c = M.apply_colormap(np.linspace(0, 1, 64), "magma").astype(float)
    assert tuple(c[0]) == (0, 0, 4) and tuple(c[-1]) == (252, 253, 191)
    lum = c @ [0.2126, 0.7152, 0.0722]
    assert np.all(np.diff(lum) >= -1.0)


def test_a_repeated_flip_is_the_kept_result_and_a_new_pair_is_measured():
    """A pair measured again (a gallery's per-bug page and its catalog card) is not evaluated
    again: the same figure and map; writing into a returned map changes no later result; another
    test image, or a mask, is another measurement."""
    rng = np.random.default_rng(7)
    ref = rng.integers(0, 256, (48, 64, 3), np.uint8)
    test = np.clip(ref.astype(int) + rng.integers(-40, 40, ref.shape), 0, 255).astype(np.uint8)
    other = 255 - test
    M._kept_flips.clear()
    mean, first = M.flip_ldr(test, ref)
    assert len(M._kept_flips) == 1
    first[:] = 5.0
    again_mean, again = M.flip_ldr(test.copy(), ref.copy())            # equal content: kept
    assert len(M._kept_flips) == 1 and again_mean == mean and again.max() <= 1.0
    other_mean, _ = M.flip_ldr(other, ref)
    assert len(M._kept_flips) == 2 and other_mean > mean
    M._kept_flips.clear()
    fresh_mean, fresh = M.flip_ldr(test, ref)                          # from the store: the same
    assert fresh_mean == mean
    np.testing.assert_array_equal(fresh, again)
    mask = np.zeros(ref.shape[:2], bool)
    mask[:, :32] = True
    assert M.flip_ldr(test, ref, mask=mask)[0] == pytest.approx(fresh[mask].mean(), rel=1e-6)


def test_read_only_pairs_are_known_by_identity_and_writeable_ones_by_content():
    """A pair of read-only arrays (the sheets' kept renders) is looked up by the arrays
    themselves the second time; a writeable array may change between calls, so it is hashed
    each time: the same object with new content is measured anew."""
    rng_ = np.random.default_rng(3)
    ref = rng_.integers(0, 256, (24, 32, 3), np.uint8)
    test = np.clip(ref.astype(int) + 40, 0, 255).astype(np.uint8)
    ref.setflags(write=False)
    test.setflags(write=False)
    M._kept_flips.clear()
    first = M.flip_ldr(test, ref)
    assert M._known_key(test, ref, M.DEFAULT_PPD) is not None
    again = M.flip_ldr(test, ref)
    assert again[0] == first[0] > 0 and np.array_equal(again[1], first[1])
    M._kept_flips.clear()                                              # the result gone, the key still known
    assert M.flip_ldr(test, ref)[0] == first[0]
    changing = test.copy()
    before = M.flip_ldr(changing, ref)[0]
    assert M._known_key(changing, ref, M.DEFAULT_PPD) is None
    changing[...] = ref
    assert before == first[0] and M.flip_ldr(changing, ref)[0] == 0.0
    import weakref
    held = weakref.ref(test)
    del test, again, first
    assert held() is None                                              # the arrays are not kept alive


def test_a_flip_batch_measures_each_pair_as_flip_ldr_does():
    """Pairs submitted to a batch are measured (in worker processes where there is more than
    one core) and kept: flip_ldr of a pair still in flight takes its worker's result, and
    flip_ldr of each afterwards takes the kept result without measuring again, and it is the
    very map image.flip gives for that pair in this process."""
    from sdfpbr.image.flip import ldr_flip
    from sdfpbr.workers import HELPERS_FROM, HELPERS_MAX, cores
    rng = np.random.default_rng(11)
    refs = [rng.integers(0, 256, (40, 56, 3), np.uint8) for _ in range(HELPERS_FROM)]
    tests = [np.clip(r.astype(int) + rng.integers(-60, 60, r.shape), 0, 255).astype(np.uint8) for r in refs]
    M._kept_flips.clear()
    with M.FlipBatch(len(refs)) as batch:
        for t, r in zip(tests, refs):
            batch.submit(t, r)
        batch.submit(tests[0], refs[0])                                # a repeat is measured once
        assert len(M._in_flight) == (len(refs) if batch.workers else 0)
        early_mean, early_map = M.flip_ldr(tests[1], refs[1])          # in the block: the worker's result
        assert len(M._in_flight) == (len(refs) - 1 if batch.workers else 0) and len(M._kept_flips) >= 1
    assert not M._in_flight
    workers = min(cores(), len(refs), HELPERS_MAX)
    assert batch.workers == (workers if workers > 1 else 0)
    assert len(M._kept_flips) == len(refs)
    assert M.flip_ldr(tests[1], refs[1])[0] == early_mean
    for t, r in zip(tests, refs):
        want_map = ldr_flip(r, t, M.DEFAULT_PPD)
        mean, error_map = M.flip_ldr(t, r)
        np.testing.assert_array_equal(error_map, want_map)
        assert mean == want_map.mean(dtype=np.float64)
    assert len(M._kept_flips) == len(refs)                             # nothing measured again


def test_a_measured_pair_is_stored_on_disk_and_read_back_exactly(tmp_path):
    """A pair measured once is stored by its content key: a process that has not kept it reads
    the stored figure and map (bit for bit a fresh measurement's), a batch of stored pairs
    starts no workers, and a damaged entry is measured anew."""
    from sdfpbr.cache import ArrayCache
    from sdfpbr.image.flip import ldr_flip
    from sdfpbr.workers import HELPERS_FROM
    rng_ = np.random.default_rng(23)
    refs = [rng_.integers(0, 256, (32, 40, 3), np.uint8) for _ in range(HELPERS_FROM)]
    tests = [np.clip(r.astype(int) + rng_.integers(-50, 50, r.shape), 0, 255).astype(np.uint8) for r in refs]
    M._kept_flips.clear()
    measured = [M.flip_ldr(t, r) for t, r in zip(tests, refs)]
    stored = sorted((tmp_path / "cache" / M.FLIP_CACHE_KIND).glob("*.npz"))
    assert len(stored) == len(refs)
    M._kept_flips.clear()
    for (mean, error_map), t, r in zip(measured, tests, refs):
        again_mean, again = M.flip_ldr(t, r)
        assert again_mean == mean
        np.testing.assert_array_equal(again, error_map)
        np.testing.assert_array_equal(again, ldr_flip(r, t, M.DEFAULT_PPD))

    M._kept_flips.clear()
    with M.FlipBatch(len(refs)) as batch:                              # all stored: nothing to measure
        for t, r in zip(tests, refs):
            batch.submit(t, r)
        assert not M._in_flight and batch._pool is None
    assert len(M._kept_flips) == len(refs)

    key = M._flip_key(refs[0], tests[0], "LDR", {"ppd": M.DEFAULT_PPD})
    planted = np.full(refs[0].shape[:2], 0.25, np.float32)
    ArrayCache().put(M.FLIP_CACHE_KIND, M._stored_key(key), {"mean": np.float64(0.25), "map": planted})
    M._kept_flips.clear()
    assert M.flip_ldr(tests[0], refs[0])[0] == 0.25                    # read, not measured
    for path in (tmp_path / "cache" / M.FLIP_CACHE_KIND).glob("*.npz"):
        path.write_bytes(path.read_bytes()[:100])                      # damaged: measured anew
    M._kept_flips.clear()
    assert M.flip_ldr(tests[0], refs[0])[0] == measured[0][0]


def test_cached_results_stay_within_their_byte_budget():
    """The least recently used go first once the sizes pass the budget; a value put again under
    its key counts once; the newest stays whatever its size; clear starts from nothing."""
    from sdfpbr.result_cache import ResultCache
    kept = ResultCache(10, len)
    kept.put("a", "xxxx")
    kept.put("b", "xxxx")
    assert kept.get("a") == "xxxx"                                     # a is now the most recent
    kept.put("b", "xx")                                                # b again: 4 + 2 bytes
    kept.put("c", "xxxx")                                              # 10: all three fit
    assert len(kept) == 3
    kept.put("d", "x")                                                 # 11: the oldest (a) goes
    assert "a" not in kept and len(kept) == 3
    kept.put("e", "x" * 50)                                            # over budget alone: kept, the rest go
    assert len(kept) == 1 and kept.get("e")
    kept.clear()
    kept.put("f", "x" * 10)
    kept.put("g", "x" * 0)
    assert len(kept) == 2
