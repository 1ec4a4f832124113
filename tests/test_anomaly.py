"""Anomaly kernels (paper §3.3) against independent references: Spectral Python's RX,
scikit-learn's OneClassSVM and ROC functions, SciPy's NNLS."""

import warnings

import numpy as np
import pytest
import spectral
from scipy.optimize import nnls
from scipy.spatial.distance import pdist
from scipy.stats import median_abs_deviation
from sklearn.metrics import roc_auc_score
from sklearn.metrics import roc_curve as sk_roc_curve
from sklearn.svm import OneClassSVM

from geoboresight import io
from geoboresight.anomaly import indicator, polygons, roc, svdd, unmix
from geoboresight.anomaly import rx as rxmod
from geoboresight.anomaly.bands import select_bands
from geoboresight.errors import InputError, ParameterError
from geoboresight.io.anomaly import label_polygons, pixel_points
from geoboresight.io.spectra import read_spectral_library
from geoboresight.io.vector import count_features, write_vector


def _cube(k=16, rows=40, cols=30, seed=1, dtype=np.int16):
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(k, 4)) @ rng.normal(size=(4, rows * cols))
    cube = 1000 + 60 * base + rng.normal(0, 4, (k, rows * cols))
    return cube.reshape(k, rows, cols).astype(dtype)


def test_global_rx_equals_spectral_python():
    cube = _cube()
    ref = spectral.rx(cube.transpose(1, 2, 0))
    ours = rxmod.rx(cube)
    assert np.max(np.abs(ours - ref) / ref) <= 1e-6


def test_streaming_statistics_equal_one_pass_and_spectral():
    cube = _cube(rows=50)
    acc = rxmod.CovarianceAccumulator(cube.shape[0])
    for a in range(0, 50, 7):  # uneven strips
        acc.add_cube(cube[:, a : a + 7].astype(np.float64))
    stats = acc.stats()
    ref = spectral.calc_stats(cube.transpose(1, 2, 0))
    np.testing.assert_allclose(stats.mean, ref.mean, rtol=1e-12)
    np.testing.assert_allclose(stats.cov, ref.cov, rtol=1e-9, atol=1e-9 * np.abs(ref.cov).max())
    det = rxmod.RXDetector(stats)
    ref_rx = spectral.rx(cube.transpose(1, 2, 0))
    ours = det.score_cube(cube.astype(np.float64))
    assert np.max(np.abs(ours - ref_rx) / ref_rx) <= 1e-6
    fast = det.score_cube(cube.astype(np.float32), precision="float32")
    assert np.max(np.abs(fast - ref_rx) / ref_rx) <= 1e-3


def test_rx_background_statistics_do_not_depend_on_the_threads():
    """RX's first pass adds the strips' products in strip order: the same covariance, bit for
    bit, with one worker thread or four (per-thread sums grouped the strips by which thread
    took them, and the float64 sums differed in the last digits from run to run)."""
    from geoboresight.operations.anomaly import _rx_statistics

    rng = np.random.default_rng(3)
    cube = (rng.normal(1000, 80, (24, 300, 40)) * rng.uniform(0.5, 2, (24, 1, 1))).astype(
        np.float32
    )
    valid = np.ones(cube.shape[1:], bool)

    def read(row0, row1):
        return cube[:, row0:row1], valid[row0:row1]

    def stats(workers):
        strips = {"height": 300, "width": 40, "block_rows": 7, "workers": workers}
        return _rx_statistics(read, 24, strips, None)

    one = stats(1)
    for _ in range(3):
        many = stats(4)
        assert np.array_equal(many.cov, one.cov) and np.array_equal(many.mean, one.mean)


def test_covariance_from_threads_on_integer_strips_equals_spectral():
    from concurrent.futures import ThreadPoolExecutor

    cube = _cube(rows=60)  # int16 DN around 1000
    valid = np.ones(cube.shape[1:], bool)
    valid[7:11, 2:9] = False
    shift = rxmod.CovarianceAccumulator.strip_shift(cube[:, :6], valid[:6])
    assert np.array_equal(shift, np.round(shift))  # integer shift: exact products
    acc = rxmod.CovarianceAccumulator(cube.shape[0], shift=shift)
    strips = [(cube[:, a : a + 6], valid[a : a + 6]) for a in range(0, 60, 6)]
    with ThreadPoolExecutor(3) as pool:
        list(pool.map(lambda s: acc.add_cube(*s), strips))
    stats = acc.stats()
    X = cube.transpose(1, 2, 0)[valid]
    ref = spectral.calc_stats(X[:, None, :])
    assert stats.n == valid.sum()
    np.testing.assert_allclose(stats.mean, ref.mean, rtol=1e-13)
    np.testing.assert_allclose(stats.cov, ref.cov, rtol=1e-11, atol=1e-11 * np.abs(ref.cov).max())
    det = rxmod.RXDetector(stats)
    for precision, tol in (("float64", 1e-6), ("float32", 1e-3)):
        ours = det.score_cube(cube, valid, precision)  # int16 strip, converted once
        assert np.isnan(ours[~valid]).all()
        ref_rx = spectral.rx(X.astype(float))
        assert np.max(np.abs(ours[valid] - ref_rx) / ref_rx) <= tol


def test_rx_ignores_invalid_pixels():
    cube = _cube()
    valid = np.ones(cube.shape[1:], bool)
    valid[5:9, 3:7] = False
    ours = rxmod.rx(cube, valid)
    assert np.isnan(ours[~valid]).all()
    X = cube.transpose(1, 2, 0)[valid].astype(float)  # (n, k)
    ref = spectral.rx(X)
    np.testing.assert_allclose(ours[valid], ref, rtol=1e-6)


def test_local_rx_equals_spectral_windowed_rx():
    cube = _cube(k=10, rows=30, cols=24)
    det = rxmod.RXDetector(rxmod.background_stats([(cube, None)], 10))
    ref = spectral.rx(cube.transpose(1, 2, 0).astype(float), window=(3, 9), cov=det.stats.cov)
    whole = rxmod.local_rx(cube, det, 3, 9)
    np.testing.assert_allclose(whole, ref, rtol=1e-6)  # SPy returns float32
    # Strip-wise with a margin of outer // 2 lines gives the same scores.
    strips = [
        rxmod.local_rx(
            cube[:, max(0, a - 4) : b + 4],
            det,
            3,
            9,
            first_row=max(0, a - 4),
            height=30,
            rows=(a, min(b, 30)),
        )
        for a, b in ((0, 11), (11, 22), (22, 30))
    ]
    np.testing.assert_allclose(np.vstack(strips), whole, rtol=1e-12)


def test_singular_covariance_names_constant_and_dependent_bands():
    cube = _cube(k=8).astype(np.float64)
    cube[2] = 500.0
    stats = rxmod.background_stats([(cube, None)], 8)
    with pytest.raises(InputError, match=r"constant.*band 3 \(420\.0 nm\)"):
        rxmod.RXDetector(stats, wavelengths=np.arange(400, 480, 10.0))
    cube = _cube(k=8).astype(np.float64)
    cube[5] = 2 * cube[1] - cube[0]
    stats = rxmod.background_stats([(cube, None)], 8)
    with pytest.raises(InputError, match="linear combinations") as err:
        rxmod.RXDetector(stats)
    assert "regularize" in str(err.value)
    det = rxmod.RXDetector(stats, regularize=1e-6)  # only when asked
    assert np.isfinite(det.score_cube(cube)).all()


def test_band_selection_by_wavelength():
    wl = np.linspace(400, 2450, 198)
    idx = select_bands(wl, 198)
    assert not np.any((wl[idx] > 1340) & (wl[idx] < 1460))
    assert not np.any((wl[idx] > 1790) & (wl[idx] < 1980))
    vnir = select_bands(wl, 198, include="400-970", exclude="")
    assert wl[vnir].max() <= 970 and wl[vnir].min() == 400
    with pytest.raises(ParameterError, match="exclude"):
        select_bands(wl, 198, include="1400-1420")


def test_svdd_blockwise_scores_equal_oneclasssvm():
    rng = np.random.default_rng(3)
    base = rng.normal(size=(3000, 5)) @ rng.normal(size=(5, 40))
    X = 800 + 40 * base + rng.normal(0, 3, (3000, 40))
    X[:20] += 300  # anomalies
    train = X[rng.choice(3000, 600, replace=False)]
    model = svdd.fit_svdd(train, nu=0.05)
    assert model.sigma == pytest.approx(np.median(pdist(train)))
    ref = OneClassSVM(kernel="rbf", gamma=1 / (2 * model.sigma**2), nu=0.05, tol=1e-4).fit(train)
    expected = ref.decision_function(X)
    got = model.decision(X.T, chunk=257)  # chunks not dividing n
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    score = model.score(X.T)
    np.testing.assert_allclose(score, -2 * expected / ref.dual_coef_.sum(), rtol=1e-8, atol=1e-12)
    assert np.median(score[:20]) > np.percentile(score[20:], 99)


def test_svdd_scores_valid_pixels_whatever_the_others_hold():
    rng = np.random.default_rng(5)
    cube = 800 + 40 * rng.normal(size=(12, 9, 14))
    model = svdd.fit_svdd(cube.reshape(12, -1).T, nu=0.05)
    valid = rng.random((9, 14)) > 0.2
    valid[:, 0] = False  # a column left out, as co-registration leaves the image's edges
    junk = cube.copy()
    bad = np.flatnonzero(~valid.ravel())
    for i, value in enumerate((np.nan, np.inf, -np.inf, 1e300, -9999.0)):
        junk.reshape(12, -1)[:, bad[i::5]] = value
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow or invalid-value warning from the junk
        got = model.score_cube(junk, valid)
    assert np.isnan(got[~valid]).all()
    expected = model.score(cube.reshape(12, -1)[:, valid.ravel()])
    np.testing.assert_allclose(got[valid], expected, rtol=1e-12)


def _mixtures(N=4, k=40, n=400, seed=0):
    rng = np.random.default_rng(seed)
    E = rng.uniform(0.05, 0.8, (N, k))
    F = rng.dirichlet(np.full(N, 0.4), n).T
    X = E.T @ F + rng.normal(0, 0.01, (k, n))  # noise puts some optima on the boundary
    return E, X


def test_fcls_matches_nnls_with_sum_to_one_row():
    E, X = _mixtures()
    A, res = unmix.unmix(X, E, "fcls", chunk=97)
    delta = 1e4  # Heinz & Chang (2001): a heavily weighted row of ones
    M = np.vstack([E.T, delta * np.ones(E.shape[0])])
    ref = np.array([nnls(M, np.r_[X[:, i], delta], maxiter=1000)[0] for i in range(X.shape[1])]).T
    assert np.abs(A - ref).max() <= 1e-6
    assert np.allclose(A.sum(axis=0), 1.0, atol=1e-12) and A.min() >= 0
    assert (A == 0).any()  # some pixels have inactive constraints: the test covers both cases
    r = X - E.T @ A
    np.testing.assert_allclose(res, np.sqrt((r**2).mean(axis=0)), rtol=1e-10)


def test_nnls_and_unconstrained_variants():
    E, X = _mixtures(seed=1)
    A, _ = unmix.unmix(X, E, "nnls")
    ref = np.array([nnls(E.T, X[:, i])[0] for i in range(X.shape[1])]).T
    assert np.abs(A - ref).max() <= 1e-9
    U, _ = unmix.unmix(X, E, "ucls")
    np.testing.assert_allclose(U, np.linalg.lstsq(E.T, X, rcond=None)[0], atol=1e-10)


def test_more_endmembers_than_bands_is_an_error():
    with pytest.raises(InputError, match="5 endmembers.*only 3 bands"):
        unmix.unmix(np.ones((3, 4)), np.random.default_rng(0).random((5, 3)))


def test_resample_gaussian_srf_and_coverage(tmp_path):
    wl = np.arange(350.0, 2500.0, 1.0)
    lib = np.vstack([0.1 + 1e-4 * wl, 0.5 - 5e-5 * wl])  # linear: SRF average = value at centre
    centres = np.array([450.0, 900.0, 1600.0, 2200.0])
    out = unmix.resample(wl, lib, centres, np.full(4, 10.0))
    np.testing.assert_allclose(
        out, np.vstack([0.1 + 1e-4 * centres, 0.5 - 5e-5 * centres]), rtol=1e-6
    )
    with pytest.raises(InputError, match="covers 350.0–2499.0 nm"):
        unmix.resample(wl, lib, np.array([400.0, 2550.0]), np.full(2, 10.0))
    # ENVI spectral library round trip.
    lib.astype("<f4").tofile(tmp_path / "lib.sli")
    wl_list = ", ".join(f"{w / 1000:.4f}" for w in wl)
    (tmp_path / "lib.hdr").write_text(
        f"ENVI\nsamples = {wl.size}\nlines = 2\nbands = 1\nheader offset = 0\n"
        "file type = ENVI Spectral Library\ndata type = 4\ninterleave = bsq\nbyte order = 0\n"
        "wavelength units = Micrometers\nspectra names = {soil, bag}\n"
        f"wavelength = {{{wl_list}}}\n"
    )
    w2, s2, names = read_spectral_library(str(tmp_path / "lib.sli"))
    assert names == ["soil", "bag"]
    np.testing.assert_allclose(w2, wl, atol=1e-6)
    np.testing.assert_allclose(s2, lib, rtol=1e-6)


def test_roc_equals_scikit_learn():
    rng = np.random.default_rng(5)
    truth = np.zeros((60, 50))
    truth[rng.integers(0, 60, 40), rng.integers(0, 50, 40)] = rng.uniform(0.05, 0.3, 40)
    scores = rng.normal(size=truth.shape) + 8 * truth
    scores = np.round(scores, 1)  # ties
    t, b = roc.truth_mask(truth)
    c = roc.roc_curve(scores, t, b)
    fpr, tpr, thr = sk_roc_curve(t.ravel(), scores.ravel(), drop_intermediate=False)
    np.testing.assert_allclose(c.pfa, fpr)
    np.testing.assert_allclose(c.pd, tpr)
    np.testing.assert_allclose(c.thresholds[1:], thr[1:])
    assert c.auc == pytest.approx(roc_auc_score(t.ravel(), scores.ravel()), abs=1e-12)
    assert c.pd_at(0.01) == tpr[fpr <= 0.01].max()
    # Abundance threshold and guard ring.
    t2, b2 = roc.truth_mask(truth, threshold=0.2, guard_px=1)
    assert t2.sum() == (truth >= 0.2).sum()
    assert not b2[t2].any()
    ring = np.zeros_like(t2)
    r, c = np.argwhere(t2)[0]
    ring[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2] = True
    assert not (b2 & ring).any()  # guard ring left out of the background
    with pytest.raises(InputError, match="no target pixels"):
        roc.roc_curve(scores, *roc.truth_mask(np.zeros_like(truth)))


def test_boresight_indicator_robust_zscore():
    rng = np.random.default_rng(2)
    ratio = rng.normal(1.1, 0.02, (50, 40))
    ratio[10, 10] = 1.5
    ratio[20, 5] = 0.7
    res = indicator.boresight_indicator(ratio, threshold=3.0)
    mad = median_abs_deviation(ratio.ravel(), scale="normal")
    np.testing.assert_allclose(res.score, np.abs(ratio - np.median(ratio)) / mad, rtol=1e-5)
    assert res.anomalies[10, 10] and res.anomalies[20, 5]
    high = indicator.boresight_indicator(ratio, tail="high")
    assert high.anomalies[10, 10] and not high.anomalies[20, 5]


def test_anomaly_features_and_gpkg(tmp_path):
    score = np.zeros((30, 30))
    score[3:5, 3:6] = 5.0
    score[20, 20] = 9.0
    score[21, 21] = 4.0  # diagonal neighbour: same group (8-connected)
    from rasterio.transform import from_origin

    tr = from_origin(600000, 3500000, 1.5, 1.5)
    labels, table = polygons.label_anomalies(score, threshold=3.0)
    outlines = label_polygons(labels, tr)
    geoms = [outlines[i] for i in table["id"]]
    assert len(geoms) == 2
    assert sorted(table["n_pixels"]) == [2, 6]
    assert geoms[0].area == pytest.approx(6 * 1.5 * 1.5)
    i = int(np.argmax(table["score_max"]))
    assert (table["row"][i], table["col"][i]) == (20, 20)
    points = pixel_points(table["row"], table["col"], tr)
    assert (points[i].x, points[i].y) == (600000 + 20.5 * 1.5, 3500000 - 20.5 * 1.5)
    # Invalid pixels are never flagged; small groups are dropped.
    valid = np.ones(score.shape, bool)
    valid[20, 20] = False
    _, t2 = polygons.label_anomalies(score, valid, threshold=3.0, min_pixels=2)
    assert list(t2["n_pixels"]) == [6]
    from rasterio.crs import CRS

    path = str(tmp_path / "a.gpkg")
    write_vector(
        path,
        geoms,
        {k: table[k] for k in polygons.FIELDS},
        crs=CRS.from_epsg(32636),
        layer="anomalies",
    )
    assert count_features(path, "anomalies") == 2
    pyogrio = pytest.importorskip("pyogrio")
    info = pyogrio.read_info(path)
    assert info["features"] == 2 and "32636" in info["crs"]
    assert info["geometry_type"] == "MultiPolygon"


def test_boresight_indicator_local_window_against_median_filter():
    from scipy import ndimage

    rng = np.random.default_rng(8)
    ratio = np.where(np.arange(40)[None, :] < 20, 1.0, 1.3) + rng.normal(0, 0.01, (30, 40))
    ratio[12, 5] += 0.06  # small against the two-material spread, large against neighbours
    glob = indicator.boresight_indicator(ratio)
    loc = indicator.boresight_indicator(ratio, window=5)
    resid = ratio - ndimage.median_filter(ratio, size=5, mode="reflect")
    mad = median_abs_deviation(resid.ravel(), scale="normal")
    np.testing.assert_allclose(loc.score, np.abs(resid - np.median(resid)) / mad, rtol=1e-4)
    assert loc.anomalies[12, 5] and not glob.anomalies[12, 5]
    with pytest.raises(ParameterError, match="odd"):
        indicator.boresight_indicator(ratio, window=4)


# --- the streamed kernels, window by window against one whole-array call ----------------


def _reader(*arrays):
    """``read(r0, r1)`` over in-memory arrays, as io.band_reader/Cube.reader read files."""

    def read(r0, r1):
        return tuple(a[..., r0:r1, :] for a in arrays)

    return read


def _valid(shape, seed=3):
    valid = np.random.default_rng(seed).random(shape) > 0.05
    valid[0, :4] = False
    return valid


def _stitch(results, shape, dtype=float):
    out = np.full(shape, np.nan, dtype=dtype)
    for win, part in results:
        out[..., win.row_off : win.row_off + win.height, :] = part
    return out


@pytest.mark.parametrize("block_rows", [1, 7, 16, 40])
def test_rx_by_strips_in_two_workers_equals_whole(block_rows):
    cube = _cube(rows=40)  # int16, as read in the files' own type
    valid = _valid(cube.shape[1:])
    k, rows, cols = cube.shape
    strips = {"height": rows, "width": cols, "block_rows": block_rows, "workers": 2}
    # Pass 1: the covariance accumulated over strips from two threads.
    acc = rxmod.CovarianceAccumulator(
        k, shift=rxmod.CovarianceAccumulator.strip_shift(cube[:, :block_rows], valid[:block_rows])
    )
    for _ in io.map_windows(_reader(cube, valid), acc.add_cube, **strips):
        pass
    stats = acc.stats()
    whole_stats = rxmod.background_stats([(cube, valid)], k)
    assert stats.n == whole_stats.n == valid.sum()
    np.testing.assert_allclose(stats.mean, whole_stats.mean, rtol=1e-13)
    np.testing.assert_allclose(stats.cov, whole_stats.cov, rtol=1e-11)
    # Pass 2: scores by strips from two threads, against one call on the whole cube.
    det = rxmod.RXDetector(stats)
    for precision, rtol in (("float64", 1e-12), ("float32", 1e-5)):
        got = _stitch(
            io.map_windows(
                _reader(cube, valid),
                lambda d, v, precision=precision: det.score_cube(d, v, precision),
                **strips,
            ),
            (rows, cols),
        )
        whole = det.score_cube(cube, valid, precision)
        np.testing.assert_array_equal(np.isnan(got), ~valid)
        np.testing.assert_allclose(got[valid], whole[valid], rtol=rtol)
    np.testing.assert_allclose(
        _stitch(
            io.map_windows(_reader(cube, valid), lambda d, v: det.score_cube(d, v), **strips),
            (rows, cols),
        ),
        rxmod.rx(cube, valid),
        rtol=1e-9,
    )


@pytest.mark.parametrize("block_rows", [1, 4, 11, 30])
@pytest.mark.parametrize(("inner", "outer"), [(3, 9), (1, 5), (5, 11)])
def test_local_rx_by_strips_with_halo_equals_whole(block_rows, inner, outer):
    """Windows are shifted to stay inside the image (as SPy's), so the first and last lines
    reach outer - 1 lines away: that is the halo (outer // 2 is not enough there)."""
    cube = _cube(k=10, rows=30, cols=24).astype(np.float64)
    valid = _valid(cube.shape[1:])
    det = rxmod.RXDetector(rxmod.background_stats([(cube, valid)], 10))
    whole = rxmod.local_rx(cube, det, inner, outer, valid)

    def score(data, ok, block):
        return rxmod.local_rx(
            data, det, inner, outer, ok, first_row=block.row0, height=block.height, rows=block.rows
        )

    got = _stitch(
        io.map_windows(
            _reader(cube, valid),
            score,
            height=30,
            width=24,
            block_rows=block_rows,
            halo=(outer - 1, outer - 1),
            pass_block=True,
            workers=2,
        ),
        (30, 24),
    )
    np.testing.assert_array_equal(np.isnan(got), np.isnan(whole))
    np.testing.assert_allclose(got, whole, rtol=1e-12)
    if block_rows <= outer // 2:
        with pytest.raises(ParameterError, match="margin"):
            list(
                io.map_windows(
                    _reader(cube, valid),
                    score,
                    height=30,
                    width=24,
                    block_rows=block_rows,
                    halo=(outer // 2, outer // 2),
                    pass_block=True,
                )
            )


@pytest.mark.parametrize("block_rows", [1, 6, 17, 50])
@pytest.mark.parametrize(("window", "tail"), [(0, "both"), (5, "high"), (3, "low"), (7, "both")])
def test_indicator_by_strips_equals_whole(block_rows, window, tail):
    """The operation's passes: the valid values by strips, the local residual with
    window // 2 lines of halo and the scene's median as fill, then the score by strips."""
    rng = np.random.default_rng(9)
    ratio = (
        np.where(np.arange(40)[None, :] < 20, 1.0, 1.3) + rng.normal(0, 0.01, (50, 40))
    ).astype(np.float32)
    ratio[12, 5] += 0.06
    valid = _valid(ratio.shape)
    whole = indicator.boresight_indicator(ratio, valid, threshold=3.0, tail=tail, window=window)
    strips = {"height": 50, "width": 40, "block_rows": block_rows}
    read = _reader(ratio, valid)
    values = np.concatenate([v for _, v in io.map_windows(read, indicator.valid_values, **strips)])
    fill, halo = None, (0, 0)
    if window:
        fill, halo = float(np.median(values)), (window // 2, window // 2)

        def residual(r, ok):
            return indicator.local_residual(r, ok, window=window, fill=fill)

        values = np.concatenate(
            [
                indicator.valid_values(x)
                for _, x in io.map_windows(read, residual, **strips, halo=halo)
            ]
        )
    median, sigma = indicator.robust_location(values)
    assert (median, sigma) == pytest.approx((whole.median, whole.sigma), rel=1e-12, abs=1e-15)

    def score(r, ok):
        x = indicator.local_residual(r, ok, window=window, fill=fill) if window else r
        return indicator.indicator_score(x, ok, median=median, sigma=sigma, tail=tail)

    got = _stitch(io.map_windows(read, score, **strips, halo=halo), (50, 40), np.float32)
    np.testing.assert_allclose(got, whole.score, rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(whole.score))


@pytest.mark.parametrize("block_rows", [1, 9, 40])
def test_svdd_sample_and_scores_by_strips_equal_whole(block_rows):
    cube = _cube(k=12, rows=40, cols=30)
    valid = _valid(cube.shape[1:])
    rng = np.random.default_rng(0)
    positions = svdd.sample_positions(40 * 30, 200, rng)
    assert positions.size == 310 and np.all(np.diff(positions) > 0)
    strips = {"height": 40, "width": 30, "block_rows": block_rows}

    # Only the lines holding positions are read; the same pixels as indexing the whole cube.
    values, ok = io.read_pixels(_reader(cube, valid), positions, **strips)
    picked = values[:, ok].T
    keep = valid.ravel()[positions]
    np.testing.assert_array_equal(ok, keep)
    np.testing.assert_array_equal(picked, cube.reshape(12, -1)[:, positions[keep]].T)
    sample = svdd.keep_at_most(picked, 200, rng)
    assert sample.shape == (200, 12)
    model = svdd.fit_svdd(sample, nu=0.05)
    got = _stitch(
        io.map_windows(_reader(cube, valid), model.score_cube, **strips, workers=2), (40, 30)
    )
    np.testing.assert_allclose(got, model.score_cube(cube, valid), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("block_rows", [1, 7, 20])
def test_unmix_by_strips_equals_whole(block_rows):
    E, X = _mixtures(N=3, k=20, n=20 * 16)
    cube = X.reshape(20, 20, 16)
    valid = _valid((20, 16))
    whole = unmix.unmix_cube(cube, valid, endmembers=E, method="fcls", scale=2.0)
    assert whole.shape == (4, 20, 16)
    A, res = unmix.unmix(X[:, valid.ravel()] * 2.0, E, "fcls")
    np.testing.assert_array_equal(whole[:3][:, valid], A)
    np.testing.assert_array_equal(whole[3][valid], res)
    assert np.isnan(whole[:, ~valid]).all()
    got = _stitch(
        io.map_windows(
            _reader(cube, valid),
            lambda d, v: unmix.unmix_cube(d, v, endmembers=E, method="fcls", scale=2.0),
            height=20,
            width=16,
            block_rows=block_rows,
            workers=2,
        ),
        (4, 20, 16),
    )
    np.testing.assert_allclose(got, whole, rtol=1e-12, atol=1e-14)


def test_endmember_csv_and_selection(tmp_path):
    path = tmp_path / "lib.csv"
    path.write_text(
        "wavelength_um,fwhm_um,soil,grass\n0.50,0.0065,0.2,0.05\n0.40,0.0065,0.1,0.04\n"
        "0.60,0.0065,0.3,0.1\n"
    )
    wl, spectra, names = read_spectral_library(path)
    assert names == ["soil", "grass"]  # the band-width column is not a material
    np.testing.assert_allclose(wl, [400.0, 500.0, 600.0])  # µm → nm, sorted
    np.testing.assert_allclose(spectra, [[0.1, 0.2, 0.3], [0.04, 0.05, 0.1]])
    picked, chosen = unmix.select_endmembers(spectra, names, ["grass"])
    assert chosen == ["grass"] and np.array_equal(picked, spectra[[1]])
    assert unmix.select_endmembers(spectra, names, ["", ""])[1] == names
    with pytest.raises(InputError, match=r"tree not in the library \(it has: soil, grass\)"):
        unmix.select_endmembers(spectra, names, ["soil", "tree"])
    with pytest.raises(InputError, match="does not exist"):
        read_spectral_library(tmp_path / "missing.csv")


@pytest.mark.parametrize(
    "text, message",
    [
        # A unit in the header that the values contradict: refused, not silently rescaled.
        ("wavelength_nm,soil\n0.5,0.2\n0.6,0.3\n", r"says 'wavelength_nm'.*0\.5–0\.6"),
        # No unit and values that could be either: refused (band numbers?).
        ("wavelength,soil\n5,0.2\n60,0.3\n", r"could be nanometres or micrometres"),
        ("band,soil\n500,0.2\n600,0.3\n", r"first column is 'band'"),
        ("wavelength_nm,soil,soil\n500,0.2,0.1\n600,0.3,0.2\n", r"distinct, non-empty names"),
        ("wavelength_nm,soil\n500,nan\n600,0.3\n", r"NaN or infinite"),
        ("wavelength_nm,soil,grass\n500,0.2\n600,0.3,0.1\n", r"line 2: 2 value\(s\) for 3"),
    ],
)
def test_endmember_csv_schema_refuses_what_it_cannot_read_for_sure(tmp_path, text, message):
    path = tmp_path / "lib.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        read_spectral_library(path)
    assert "lib.csv" in str(err.value)


def test_endmember_csv_units_from_header_or_unambiguous_values(tmp_path):
    for header, values, expected in [
        ("wavelength (nm)", (500, 600), [500, 600]),
        ("wavelength_um", (0.5, 0.6), [500, 600]),
        ("Wavelength", (0.5, 0.6), [500, 600]),  # only µm fits 0.5–0.6
        ("Wavelength", (500, 600), [500, 600]),
    ]:
        path = tmp_path / "lib.csv"
        path.write_text(f"{header},soil\n{values[0]},0.2\n{values[1]},0.3\n")
        np.testing.assert_allclose(read_spectral_library(path)[0], expected)


@pytest.mark.parametrize("n_blocks", [1, 3, 17])
def test_robust_location_blocks_equals_numpy_and_scipy(n_blocks):
    # Independent truth: np.median and scipy's median_abs_deviation on all the values at once.
    from scipy.stats import median_abs_deviation

    rng = np.random.default_rng(4)
    x = np.concatenate([rng.normal(2.1, 0.05, 30_000), rng.normal(9.0, 3.0, 40), [1e9]])
    rng.shuffle(x)
    med, sigma = indicator.robust_location_blocks(lambda: iter(np.array_split(x, n_blocks)))
    assert med == np.median(x)
    assert sigma == pytest.approx(median_abs_deviation(x, scale="normal"), rel=1e-14)
    # Half the values tied: MAD 0, so σ is the standard deviation.
    t = np.concatenate([np.full(600, 1.5), rng.normal(1.5, 0.2, 400)])
    med, sigma = indicator.robust_location_blocks(lambda: iter(np.array_split(t, n_blocks)))
    assert (med, sigma) == (1.5, pytest.approx(t.std(), rel=1e-12))
