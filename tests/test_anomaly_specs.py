"""Anomaly operations end to end on small ENVI files: georeference and nodata carried, results
equal to the kernels' references, bad input stops with a clear error and leaves no output."""

import os

import numpy as np
import pytest
import rasterio
import spectral
from rasterio.crs import CRS
from rasterio.transform import from_origin
from sklearn.svm import OneClassSVM

from geoboresight.algorithms.anomaly import ALGORITHMS as CUBE_ALGORITHMS
from geoboresight.algorithms.roc import ALGORITHMS as MAP_ALGORITHMS
from geoboresight.anomaly.indicator import Eq3Reference
from geoboresight.errors import InputError
from geoboresight.io import write_envi
from geoboresight.io.cube import open_cube

ALGORITHMS = CUBE_ALGORITHMS + MAP_ALGORITHMS
#: The anomaly specs (the same objects as ``geoboresight.algorithms.get(name)``).
get = {alg.name: alg for alg in ALGORITHMS}.__getitem__

TR = from_origin(700000, 3600000, 1.5, 1.5)
WL = np.linspace(400, 2450, 24)


def _scene(tmp_path, interleave="bil", nodata=None):
    rng = np.random.default_rng(0)
    k, rows, cols = WL.size, 48, 36
    base = rng.normal(size=(k, 5)) @ rng.normal(size=(5, rows * cols))
    cube = (3000 + 150 * base + rng.normal(0, 8, (k, rows * cols))).reshape(k, rows, cols)
    cube[:, 10, 12] += 3000 * np.linspace(-1, 1, k)  # a spectral anomaly
    cube = cube.astype(np.int16)
    if nodata is not None:
        cube[:, 0, :3] = nodata
    path = str(tmp_path / f"cube_{interleave}.img")
    write_envi(
        path,
        cube,
        WL,
        np.full(k, 12.0),
        interleave=interleave,
        crs=CRS.from_epsg(32636),
        transform=TR,
        nodata=nodata,
    )
    return path, cube


@pytest.mark.parametrize("interleave", ["bil", "bsq", "bip"])
def test_cube_reader_fast_path_equals_rasterio(tmp_path, interleave):
    path, cube = _scene(tmp_path, interleave)
    with open_cube(path) as c:
        assert c.raw_parts() is not None  # the raw ENVI path is used
        assert c.raw_parts()[0].layout.interleave == interleave
        data, valid = c.read(7, 30, np.array([0, 5, 23]), "float64")
    with rasterio.open(path) as src:
        ref = src.read([1, 6, 24], window=((7, 30), (0, 36)))
    np.testing.assert_array_equal(data, ref)
    assert valid.all()


@pytest.mark.parametrize("interleave", ["bil", "bsq"])
def test_cube_strips_come_in_order_from_threads(tmp_path, interleave):
    """The cube's reader in map_windows' worker threads: every strip, in order, in the file's
    own type, with its validity; an error in one strip reaches the caller."""
    from geoboresight.io import map_windows

    def strips(c, func, workers):
        return map_windows(
            c.reader(None, None),
            func,
            height=c.height,
            width=c.width,
            block_rows=5,
            workers=workers,
        )

    path, cube = _scene(tmp_path, interleave, nodata=-1)
    with open_cube(path) as c:
        got = list(strips(c, lambda d, v: (d.copy(), v.copy()), 3))
        whole, whole_valid = c.read(0, c.height, None, None)
    assert [w.row_off for w, _ in got] == list(range(0, 48, 5))
    assert got[0][1][0].dtype == np.int16  # the file's own type: no float copy
    np.testing.assert_array_equal(np.concatenate([d for _, (d, _) in got], axis=1), cube)
    np.testing.assert_array_equal(np.vstack([v for _, (_, v) in got]), whole_valid)
    assert not whole_valid[0, :3].any() and whole_valid.sum() == 48 * 36 - 3

    def fail_on_strip_3(d, v):
        if d.shape[1] == 5 and np.array_equal(d, cube[:, 15:20]):
            raise ValueError("strip 3")
        return None

    with open_cube(path) as c, pytest.raises(ValueError, match="strip 3"):
        list(strips(c, fail_on_strip_3, 2))


@pytest.mark.parametrize("stop_after", [2, 12])  # in pass 1, in pass 2
def test_cancelling_threaded_rx_leaves_no_output_and_restores_blas(tmp_path, stop_after):
    from threadpoolctl import threadpool_info

    from geoboresight.errors import Cancelled
    from geoboresight.progress import Progress

    threads = [i["num_threads"] for i in threadpool_info()]
    path, _ = _scene(tmp_path)
    out = str(tmp_path / "rx.tif")
    calls = []
    progress = Progress(
        callback=lambda f, m: calls.append(f), is_cancelled=lambda: len(calls) >= stop_after
    )
    with pytest.raises(Cancelled):
        get("rx")(vnir=path, exclude_nm="", block_rows=4, output=out, progress=progress)
    left = {f for f in os.listdir(tmp_path) if not f.startswith("cube_bil.")}
    assert not os.path.exists(out) and not left  # no output, no temporary file
    assert [i["num_threads"] for i in threadpool_info()] == threads


def test_rx_spec_equals_spectral_and_carries_georeference(tmp_path):
    path, cube = _scene(tmp_path, nodata=-1)
    out = str(tmp_path / "rx.tif")
    get("rx")(vnir=path, exclude_nm="", block_rows=7, output=out)
    with rasterio.open(out) as src:
        assert src.crs == CRS.from_epsg(32636) and src.transform == TR
        score = src.read(1, masked=True)
    assert score.mask[0, :3].all() and not score.mask[1:].any()
    valid = np.ones(cube.shape[1:], bool)
    valid[0, :3] = False
    ref = spectral.rx(cube.transpose(1, 2, 0)[valid].astype(float))
    np.testing.assert_allclose(score.data[valid], ref, rtol=2e-6)  # float32 GeoTIFF
    assert np.unravel_index(np.argmax(score), score.shape) == (10, 12)


def test_local_rx_and_svdd_specs(tmp_path):
    path, cube = _scene(tmp_path)
    out = str(tmp_path / "lrx.tif")
    get("rx")(vnir=path, exclude_nm="", mode="local", inner=3, outer=9, block_rows=10, output=out)
    with rasterio.open(out) as src:
        lrx = src.read(1)
    X = cube.transpose(1, 2, 0).astype(float)
    C = spectral.calc_stats(X).cov
    np.testing.assert_allclose(lrx, spectral.rx(X, window=(3, 9), cov=C), rtol=2e-6)
    out = str(tmp_path / "svdd.tif")
    res = get("svdd")(vnir=path, exclude_nm="", sample_size=400, nu=0.05, block_rows=9, output=out)
    with rasterio.open(out) as src:
        s = src.read(1)
        assert src.tags()["SIGMA"] and src.crs == CRS.from_epsg(32636)
    assert np.unravel_index(np.argmax(s), s.shape) == (10, 12)
    assert res["support_vectors"] > 0


def test_unmix_spec_with_csv_library(tmp_path):
    rng = np.random.default_rng(4)
    wl_lib = np.arange(380.0, 2500.0, 2.0)
    soil = 0.2 + 0.1 * np.sin(wl_lib / 300.0)
    bag = 0.35 + 0.02 * np.cos(wl_lib / 150.0)
    veg = 0.05 + 0.4 / (1 + np.exp(-(wl_lib - 720) / 15)) * np.exp(-(((wl_lib - 1400) / 900) ** 2))
    lib = str(tmp_path / "lib.csv")
    np.savetxt(
        lib,
        np.column_stack([wl_lib, soil, bag, veg]),
        delimiter=",",
        header="wavelength_nm,soil,bag,veg",
        comments="",
    )
    from geoboresight.anomaly.unmix import resample

    E = resample(wl_lib, np.vstack([soil, bag, veg]), WL, np.full(WL.size, 12.0))
    F = rng.dirichlet(np.ones(3), 20 * 16).T
    cube = ((E.T @ F) * 10000).reshape(WL.size, 20, 16).astype(np.int16)
    img = str(tmp_path / "refl.img")
    write_envi(img, cube, WL, np.full(WL.size, 12.0))
    out = str(tmp_path / "ab.tif")
    get("unmix")(vnir=img, endmembers=lib, exclude_nm="", image_scale=1e-4, output=out)
    with rasterio.open(out) as src:
        assert src.count == 4 and src.crs is None  # raw geometry stays raw
        ab = src.read()
    np.testing.assert_allclose(ab[:3].reshape(3, -1), F, atol=2e-3)  # int16 quantisation
    # Library not covering the image: clear error, no output.
    short = str(tmp_path / "short.csv")
    keep = wl_lib < 1000
    np.savetxt(
        short,
        np.column_stack([wl_lib[keep], soil[keep], bag[keep]]),
        delimiter=",",
        header="wl,soil,bag",
        comments="",
    )
    out2 = str(tmp_path / "ab2.tif")
    with pytest.raises(InputError, match="not covered"):
        get("unmix")(vnir=img, endmembers=short, exclude_nm="", output=out2)
    assert not os.path.exists(out2)


def test_indicator_roc_polygons_chain(tmp_path):
    rng = np.random.default_rng(6)
    ratio = rng.normal(1.05, 0.01, (40, 30)).astype(np.float32)
    truth = np.zeros((40, 30), np.float32)
    for r, c in [(5, 5), (15, 20), (30, 8)]:
        truth[r, c] = 0.1
        ratio[r, c] += 0.08
    ratio[0, 0] = -9999
    kw = dict(crs=CRS.from_epsg(32636), transform=TR)
    from geoboresight.io import write_raster

    rp, tp = str(tmp_path / "ratio.tif"), str(tmp_path / "truth.tif")
    write_raster(rp, ratio, **kw)
    write_raster(tp, truth, **kw)
    sp, mp = str(tmp_path / "ind.tif"), str(tmp_path / "mask.tif")
    res = get("boresight-indicator")(ratio=rp, output=sp, anomalies=mp)
    assert res["count"] >= 3
    with rasterio.open(mp) as src:
        m = src.read(1)
        assert src.nodata == 255 and m[0, 0] == 255 and src.transform == TR
    png, csv = str(tmp_path / "roc.png"), str(tmp_path / "roc.csv")
    r = get("roc")(scores=sp, names="boresight", truth=tp, output=png, csv=csv)
    assert r["auc_boresight"] > 0.99 and os.path.getsize(png) > 10000
    assert open(csv).readline().strip() == "detector,pfa,pd,threshold"
    gp = str(tmp_path / "anom.gpkg")
    assert (
        get("anomaly-polygons")(score=sp, threshold=5.0, geometry="point", output=gp)["features"]
        >= 3
    )
    # All-zero truth: clear error, no figure left behind.
    zp = str(tmp_path / "zero.tif")
    write_raster(zp, np.zeros_like(truth), **kw)
    png2 = str(tmp_path / "roc2.png")
    with pytest.raises(InputError, match="no target pixels"):
        get("roc")(scores=sp, truth=zp, output=png2)
    assert not os.path.exists(png2)


def test_singular_covariance_spec_error_leaves_no_output(tmp_path):
    path, cube = _scene(tmp_path)
    cube[3] = 1234
    write_envi(str(tmp_path / "flat.img"), cube, WL)
    out = str(tmp_path / "rx.tif")
    with pytest.raises(InputError, match=rf"constant.*band 4 \({WL[3]:.1f} nm\)"):
        get("rx")(vnir=str(tmp_path / "flat.img"), exclude_nm="", output=out)
    assert not os.path.exists(out)
    get("rx")(vnir=str(tmp_path / "flat.img"), exclude_nm="", regularize=1e-6, output=out)
    assert os.path.exists(out)


def test_svdd_sample_is_what_sklearn_scores(tmp_path):
    # The spec's scores are the blockwise BLAS scores; check one strip against sklearn directly.
    from geoboresight.anomaly.svdd import fit_svdd

    path, cube = _scene(tmp_path)
    X = cube.reshape(cube.shape[0], -1).astype(float)
    model = fit_svdd(X[:, ::3].T, nu=0.02)
    ref = OneClassSVM(kernel="rbf", gamma=model.gamma, nu=0.02, tol=1e-4).fit(X[:, ::3].T)
    np.testing.assert_allclose(model.decision(X), ref.decision_function(X.T), rtol=1e-9, atol=1e-12)


def test_operations_are_the_specs_and_the_former_image_name_still_works(tmp_path):
    from geoboresight import rx_file
    from geoboresight.anomaly.bands import BandSelection

    path, cube = _scene(tmp_path)
    a, b, c = (str(tmp_path / f"{n}.tif") for n in "abc")
    assert get("rx").operation is rx_file
    rx_file(path, output=a, spectral=BandSelection(exclude_nm=""), block_rows=5)
    get("rx")(image=path, exclude_nm="", output=b)  # the former parameter name
    get("rx")(vnir=path, exclude_nm="", output=c, block_rows=48)
    with rasterio.open(a) as ra, rasterio.open(b) as rb, rasterio.open(c) as rc:
        np.testing.assert_array_equal(ra.read(), rb.read())
        np.testing.assert_allclose(ra.read(), rc.read(), rtol=1e-6)
    with pytest.raises(Exception, match="former name"):
        get("rx")(vnir=path, image=path, output=str(tmp_path / "d.tif"))


def test_local_rx_spec_on_a_height_that_leaves_a_one_line_strip(tmp_path):
    # 33 lines in strips of 16: the last strip is one line, whose shifted window reaches
    # outer - 1 lines above it.
    rng = np.random.default_rng(2)
    k = 8
    cube = (1000 + rng.normal(0, 30, (k, 33, 20))).astype(np.int16)
    path = str(tmp_path / "c33.img")
    write_envi(path, cube, np.linspace(400, 900, k))
    out = str(tmp_path / "lrx.tif")
    get("rx")(vnir=path, exclude_nm="", mode="local", inner=3, outer=17, output=out)
    with rasterio.open(out) as src:
        lrx = src.read(1)
    X = cube.transpose(1, 2, 0).astype(float)
    ref = spectral.rx(X, window=(3, 17), cov=spectral.calc_stats(X).cov)
    np.testing.assert_allclose(lrx, ref, rtol=2e-6)


@pytest.mark.parametrize(("window", "tail"), [(0, "both"), (5, "high")])
def test_indicator_operation_by_strips_equals_the_kernel(tmp_path, window, tail):
    from geoboresight import boresight_indicator_file
    from geoboresight.anomaly.indicator import boresight_indicator
    from geoboresight.io import write_raster

    rng = np.random.default_rng(6)
    ratio = (
        np.where(np.arange(30)[None, :] < 15, 1.0, 1.2) + rng.normal(0, 0.01, (45, 30))
    ).astype(np.float32)
    ratio[20, 4] += 0.05
    ratio[0, :3] = -9999
    rp = str(tmp_path / "ratio.tif")
    write_raster(rp, ratio, crs=CRS.from_epsg(32636), transform=TR)
    valid = ratio != -9999
    whole = boresight_indicator(ratio, valid, threshold=2.5, tail=tail, window=window)
    sp, mp = str(tmp_path / "s.tif"), str(tmp_path / "m.tif")
    res = boresight_indicator_file(
        rp,
        output=sp,
        anomalies=mp,
        threshold=2.5,
        reference=Eq3Reference(tail=tail, window=window),
        block_rows=4,
    )
    assert res["count"] == whole.count and res["median"] == pytest.approx(whole.median)
    assert res["robust_sigma"] == pytest.approx(whole.sigma, rel=1e-12)
    with rasterio.open(sp) as s, rasterio.open(mp) as m:
        score = s.read(1)
        mask = m.read(1)
        assert s.transform == TR and float(s.tags()["THRESHOLD"]) == 2.5
    np.testing.assert_allclose(score[valid], whole.score[valid], rtol=1e-6)
    assert (score[~valid] == -9999).all() and (mask[~valid] == 255).all()
    np.testing.assert_array_equal(mask[valid], whole.anomalies[valid])


def test_roc_scores_separated_by_commas_on_the_command_line(tmp_path):
    from click.testing import CliRunner

    from geoboresight.cli import main
    from geoboresight.io import write_raster

    rng = np.random.default_rng(1)
    truth = np.zeros((30, 20), np.float32)
    truth[[3, 12, 25], [4, 10, 15]] = 0.2
    a = (rng.normal(size=truth.shape) + 40 * truth).astype(np.float32)
    b = rng.normal(size=truth.shape).astype(np.float32)
    paths = [str(tmp_path / n) for n in ("truth.tif", "good.tif", "noise.tif")]
    for p, x in zip(paths, (truth, a, b), strict=True):
        write_raster(p, x)
    png, csv = str(tmp_path / "roc.png"), str(tmp_path / "roc.csv")
    args = ["roc", "--truth", paths[0], "-o", png, "--csv", csv, "--json"]
    one = CliRunner().invoke(main, [*args, "--scores", f"{paths[1]},{paths[2]}"])
    assert one.exit_code == 0, one.output
    import json

    result = json.loads(one.output[one.output.index("{") :])
    assert set(result) >= {"auc_good", "auc_noise"}
    assert result["auc_good"] > 0.99 > result["auc_noise"]
    two = CliRunner().invoke(
        main, [*args, "--overwrite", "--scores", paths[1], "--scores", paths[2]]
    )
    assert two.exit_code == 0, two.output
    assert json.loads(two.output[two.output.index("{") :]) == result
