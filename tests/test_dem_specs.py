"""The Relative DEM specs on files: georeference carried, tags, reports, bad input leaves nothing."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import rasterio
from dem_synth import bump, pair
from rasterio.transform import from_origin
from synth import SWIR_WL, UTM, VNIR_WL, write_envi, write_gtiff

from geoboresight import boresight_offset_file, coregister_file, io, view_3d_file
from geoboresight.algorithms import dem as dem_specs
from geoboresight.algorithms import offset as offset_specs
from geoboresight.errors import InputError, ParameterError
from geoboresight.io.bands import MatchBands, read_matching_pair
from geoboresight.sensor.coregister import coregister, profile_to_lines
from geoboresight.sensor.offset import offset_profile

#: The Relative DEM specs by name (as ``geoboresight.algorithms.get`` gives them).
SPECS = {a.name: a for a in (*dem_specs.ALGORITHMS, *offset_specs.ALGORITHMS)}
get = SPECS.__getitem__

K = 1 / 30  # px per metre


def _cubes(v, s):
    """Every VNIR band = the VNIR texture (scaled), every SWIR band = the SWIR texture."""
    vc = np.stack([v * (0.5 + 0.05 * i) for i in range(len(VNIR_WL))]).astype("float32")
    sc = np.stack([s * (0.9 - 0.01 * i) for i in range(len(SWIR_WL))]).astype("float32")
    return vc, sc


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("dem")
    h = bump(120, 96, relief=30.0)
    v, s, _, _ = pair(120, 96, offset=(0.7, -0.2), dsm=h, k_along=K, noise=3.0)
    vc, sc = _cubes(v, s)
    geo = dict(crs=UTM, transform=from_origin(700000.0, 3500000.0, 1.5, 1.5))
    paths = {
        "vnir": write_envi(d / "vnir.img", vc, VNIR_WL, **geo),
        "swir": write_envi(d / "swir.img", sc, SWIR_WL, **geo),
        "vnir_raw": write_envi(d / "vnir_raw.img", vc, VNIR_WL),
        "swir_raw": write_envi(d / "swir_raw.img", sc, SWIR_WL),
    }
    cloud = np.zeros((1, 120, 96), "uint8")
    cloud[0, 5:20, 5:30] = 1
    paths["cloud"] = write_gtiff(d / "cloud.tif", cloud, **geo)
    paths["cloud_bad"] = write_gtiff(d / "cloud_bad.tif", cloud[:, :-1], **geo)
    return d, paths, h


def test_relative_dem_georeferenced(scene, tmp_path):
    d, p, h = scene
    out, var, rep = tmp_path / "dem.tif", tmp_path / "var.tif", tmp_path / "dem.json"
    disp = tmp_path / "disp.tif"
    res = get("relative-dem")(
        vnir=p["vnir"],
        swir=p["swir"],
        cloud_mask=p["cloud"],
        height_factor=K,
        window=13,
        output=out,
        variance=var,
        report=rep,
        disparity=disp,
    )
    with rasterio.open(out) as src, rasterio.open(p["vnir"]) as ref:
        assert src.crs == ref.crs and src.transform == ref.transform
        dem = src.read(1, masked=True)
        tags = src.tags()
    assert dem.mask[5:20, 5:30].all()  # clouds masked
    ok = ~dem.mask
    assert np.corrcoef(dem.data[ok], h[ok])[0, 1] > 0.95
    for key in ("SIGMA_D_PX", "SIGMA_H_M", "HEIGHT_FACTOR_PX_PER_M", "WINDOW_PX", "VARIOGRAM"):
        assert key in tags
    assert float(tags["SIGMA_H_M"]) == pytest.approx(float(tags["SIGMA_D_PX"]) * 30.0, rel=1e-3)
    report = json.loads(rep.read_text())
    assert report["meaningful"] and report["cross_validation"]["n"] > 0
    assert res["sigma_h_m"] == pytest.approx(report["sigma_h_m"])
    with rasterio.open(var) as src:
        assert src.crs is not None and (src.read(1, masked=True) >= 0).all()
    with rasterio.open(disp) as src:
        assert src.count == 5
        along = src.read(1, masked=True)
        rel = src.read(5, masked=True)
    assert rel.max() == 1
    # The SWIR sees features 0.7 px further along on the lowest ground.
    assert np.ma.median(along[h < 2]) == pytest.approx(0.7, abs=0.1)


def test_view3d_draws_a_masked_area_flat_not_as_a_pit():
    from geoboresight.dem.view3d import fill_holes

    z = np.full((20, 20), 10.0)
    z[:, 10:] = 20.0
    z[5:15, 5:15] = np.nan  # a masked cloud
    filled = fill_holes(z)
    assert np.isfinite(filled).all() and filled.min() == 10.0
    assert (filled[5:15, 5:10] == 10.0).all() and (filled[5:15, 10:15] == 20.0).all()


def test_view3d_png(scene, tmp_path):
    d, p, h = scene
    dem = tmp_path / "dem.tif"
    get("relative-dem")(vnir=p["vnir"], swir=p["swir"], height_factor=K, window=13, output=dem)
    png = tmp_path / "view.png"
    get("view-3d")(
        dem=dem,
        vnir=p["vnir"],
        swir=p["swir"],
        red_nm=660,
        green_nm=555,
        blue_nm=452,
        exaggeration=4.0,
        output=png,
    )
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_raw_geometry_stays_raw(scene, tmp_path):
    d, p, h = scene
    out = tmp_path / "dem.tif"
    get("relative-dem")(
        vnir=p["vnir_raw"],
        swir=p["swir_raw"],
        squint_deg=2.8624,
        flying_height=1500,
        ifov_mrad=1.0,
        window=13,
        output=out,
    )
    with rasterio.open(out) as src:
        assert src.crs is None
        assert src.tags()["GSD_M"].startswith("1.5")
        # k from the geometry: tan(2.8624°) / 1.5 m ≈ 1/30 px per metre.
        assert float(src.tags()["HEIGHT_FACTOR_PX_PER_M"]) == pytest.approx(K, rel=1e-3)


def test_offset_report_and_coregister(scene, tmp_path):
    d, p, h = scene
    rep = tmp_path / "off.json"
    res = get("boresight-offset")(
        vnir=p["vnir"],
        swir=p["swir"],
        ifov_mrad=1.0,
        flying_height=1500,
        profile_rows=60,
        output=rep,
        plot=tmp_path / "off.png",
    )
    data = json.loads(rep.read_text())
    # Global offset = flat offset + parallax of the relief, averaged with the Hann taper the
    # correlation applies (the centre of the image weighs most).
    w = np.outer(np.hanning(122)[1:-1], np.hanning(98)[1:-1])
    expect = 0.7 + K * np.sum(w * h) / np.sum(w)
    assert data["along_px"] == pytest.approx(expect, abs=0.1)
    assert data["across_px"] == pytest.approx(-0.2, abs=0.05)
    assert data["along_mrad"] == pytest.approx(data["along_px"], rel=1e-3)
    assert len(data["profile"]) == 2 and res["output"] == str(rep)
    co = tmp_path / "co.tif"
    get("coregister")(vnir=p["vnir"], swir=p["swir"], along=0.7, across=-0.2, output=co)
    with rasterio.open(co) as src, rasterio.open(p["vnir"]) as ref:
        assert src.count == len(SWIR_WL) and src.crs == ref.crs
        assert src.descriptions[1] == "1010.00 nm"
        band = src.read(2, masked=True)
        vn = ref.read(9)  # 918 nm band
    flat = (h < 1) & ~band.mask
    assert np.corrcoef(band.data[flat], vn[flat])[0, 1] > 0.98


@pytest.mark.parametrize("factor", [0.0, -0.03])
def test_bad_height_factor_leaves_nothing(scene, tmp_path, factor):
    d, p, h = scene
    out = tmp_path / "dem.tif"
    with pytest.raises(ParameterError, match="height_factor"):
        get("relative-dem")(vnir=p["vnir"], swir=p["swir"], height_factor=factor, output=out)
    assert not os.listdir(tmp_path)


def test_mismatched_cloud_mask(scene, tmp_path):
    d, p, h = scene
    out = tmp_path / "dem.tif"
    with pytest.raises(InputError, match="mismatched grids"):
        get("relative-dem")(
            vnir=p["vnir"], swir=p["swir"], cloud_mask=p["cloud_bad"], height_factor=K, output=out
        )
    assert not os.listdir(tmp_path)


def test_no_reliable_matches_says_larger_window(tmp_path):
    rng = np.random.default_rng(0)
    vc = rng.uniform(100, 200, (len(VNIR_WL), 60, 60)).astype("float32")
    sc = rng.uniform(100, 200, (len(SWIR_WL), 60, 60)).astype("float32")
    v = write_envi(tmp_path / "v.img", vc, VNIR_WL)
    s = write_envi(tmp_path / "s.img", sc, SWIR_WL)
    out = tmp_path / "dem.tif"
    with pytest.raises(InputError, match="larger matching window"):
        get("relative-dem")(vnir=v, swir=s, height_factor=K, window=9, output=out)
    assert not out.exists()


def test_small_squint_refused_then_forced(tmp_path):
    h = bump(120, 96, relief=30.0)
    k = 0.0008  # realistic squint: 30 m of relief moves a feature by 0.024 px
    v, s, _, _ = pair(120, 96, offset=(0.7, -0.2), dsm=h, k_along=k, noise=20.0)
    vc, sc = _cubes(v, s)
    vp = write_envi(tmp_path / "v.img", vc, VNIR_WL)
    sp = write_envi(tmp_path / "s.img", sc, SWIR_WL)
    out = tmp_path / "dem.tif"
    with pytest.raises(InputError, match="no meaningful DEM"):
        get("relative-dem")(vnir=vp, swir=sp, height_factor=k, window=13, output=out)
    assert not out.exists()
    res = get("relative-dem")(vnir=vp, swir=sp, height_factor=k, window=13, force=True, output=out)
    assert not res["meaningful"]
    with rasterio.open(out) as src:
        assert src.tags()["MEANINGFUL"].startswith("NO")


def test_band_ranges_average_bands_into_the_matching_images(scene, tmp_path):
    """Averaging bands that carry the same texture (scaled) must not move the offset; the
    report lists the bands averaged; a range ending below its first band is refused."""
    d, p, h = scene
    one = get("boresight-offset")(vnir=p["vnir"], swir=p["swir"], output=tmp_path / "a.json")
    avg = get("boresight-offset")(
        vnir=p["vnir"],
        swir=p["swir"],
        vnir_nm=910.0,  # the range [910, 970] nm holds the 918 and 970 nm bands
        vnir_to_nm=970.0,
        swir_nm=980.0,
        swir_to_nm=1100.0,
        output=tmp_path / "b.json",
    )
    assert avg["vnir_bands_averaged"] == [11, 12]  # 918 and 970 nm
    assert avg["swir_bands_averaged"] == [1, 2, 3, 4, 5]  # 980 ... 1100 nm
    assert "vnir_bands_averaged" not in one
    assert avg["along_px"] == pytest.approx(one["along_px"], abs=0.01)
    assert avg["across_px"] == pytest.approx(one["across_px"], abs=0.01)
    with pytest.raises(ParameterError, match="swir_to_nm"):
        get("boresight-offset")(
            vnir=p["vnir"], swir=p["swir"], swir_to_nm=990.0, output=tmp_path / "c.json"
        )
    assert not (tmp_path / "c.json").exists()


# ------------------------------------------------------------------------------- file level
@pytest.mark.parametrize("block_rows", [7, 50, 119])
def test_matching_pair_by_windows_equals_whole(scene, block_rows):
    """The band-range means and the cloud-free mask read strip by strip are those of one
    strip holding the whole image, and those of the bands read whole and averaged."""
    d, p, h = scene
    dual = io.open_dual(p["vnir"], p["swir"])
    bands = MatchBands(vnir_nm=910.0, vnir_to_nm=970.0, swir_nm=980.0, swir_to_nm=1100.0)
    whole = read_matching_pair(dual, bands, p["cloud"], block_rows=120)
    got = read_matching_pair(dual, bands, p["cloud"], block_rows=block_rows)
    for name in ("vnir", "swir", "valid"):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name), err_msg=name)
    assert got.vnir_bands == [11, 12] and got.swir_bands == [1, 2, 3, 4, 5]
    with rasterio.open(p["vnir"]) as src:
        bands = src.read([11, 12]).astype(np.float64)
    np.testing.assert_array_equal(whole.vnir, (bands[0] + bands[1]) / 2)
    assert not whole.valid[5:20, 5:30].any() and whole.valid.sum() == 120 * 96 - 15 * 25


@pytest.mark.parametrize("interleave", ["bsq", "bil", "bip"])
def test_raw_envi_matching_pair_equals_gdal(tmp_path, interleave):
    """Raw ENVI files are read directly (io.Cube): the same means and validity (nodata in one
    band of each file) as the band-by-band GDAL reads of the same data in GeoTIFFs."""
    h = bump(40, 30)
    v, s, _, _ = pair(40, 30, offset=(0.5, 0.1), dsm=h, k_along=K, noise=3.0)
    vc, sc = (np.round(c * 10).astype("uint16") for c in _cubes(v + 200, s + 200))
    vc[11, 3, 4] = 7
    sc[2, 10, 20] = 7
    paths = {}
    for name, cube, wl in (("vnir", vc, VNIR_WL), ("swir", sc, SWIR_WL)):
        paths[name] = write_envi(
            tmp_path / f"{name}.img", cube, wl, interleave=interleave, nodata=7
        )
        paths[name + "_tif"] = write_gtiff(tmp_path / f"{name}.tif", cube, wl, nodata=7)
    bands = MatchBands(vnir_nm=910.0, vnir_to_nm=970.0, swir_nm=980.0, swir_to_nm=1100.0)
    raw = read_matching_pair(io.open_dual(paths["vnir"], paths["swir"]), bands, block_rows=16)
    gdal = read_matching_pair(
        io.open_dual(paths["vnir_tif"], paths["swir_tif"]), bands, block_rows=16
    )
    for name in ("vnir", "swir", "valid"):
        np.testing.assert_array_equal(getattr(raw, name), getattr(gdal, name), err_msg=name)
    assert not raw.valid[3, 4] and not raw.valid[10, 20] and raw.valid.sum() == 40 * 30 - 2


@pytest.mark.parametrize("drift", [False, True])
@pytest.mark.parametrize("block_rows", [16, 256])
def test_coregister_file_by_strips_equals_whole_band(scene, tmp_path, drift, block_rows):
    """coregister_file resamples strip by strip; every band equals the kernel on the whole
    band (the offset given, or followed per line from the measured profile)."""
    d, p, h = scene
    out = tmp_path / "co.tif"
    if drift:
        res = coregister_file(
            p["vnir"],
            p["swir"],
            output=out,
            follow_drift=True,
            profile_rows=40,
            order="1",
            block_rows=block_rows,
        )
        pair = read_matching_pair(io.open_dual(p["vnir"], p["swir"]), MatchBands(920.0, 1010.0))
        prof = offset_profile(pair.vnir, pair.swir, pair.valid, block_rows=40)
        along = profile_to_lines(prof.rows, prof.along, 120)
        across = profile_to_lines(prof.rows, prof.across, 120)
        order = 1
    else:
        res = coregister_file(
            p["vnir"], p["swir"], output=out, along=0.7, across=-0.2, block_rows=block_rows
        )
        along, across, order = 0.7, -0.2, 3
    assert res["bands"] == len(SWIR_WL)
    assert res["along_px"] == pytest.approx(float(np.mean(along)), abs=1e-4)
    with rasterio.open(out) as dst, rasterio.open(p["swir"]) as src:
        assert dst.tags()["OFFSET_PER_LINE"] == ("yes" if drift else "no")
        assert dst.tags(3)["wavelength"] == f"{SWIR_WL[2]:.3f}"
        for b in (1, 2, 17, len(SWIR_WL)):
            band = src.read(b).astype("float32")
            want, ok = coregister(band, along, across, np.ones(band.shape, bool), order=order)
            got = dst.read(b, masked=True)
            np.testing.assert_array_equal(~got.mask, ok)
            np.testing.assert_allclose(got.data[ok], want[ok], rtol=1e-6)


def test_operations_are_the_specs(scene, tmp_path):
    """A script's call of the file-level operation and the spec's run are the same thing."""
    d, p, h = scene
    a = boresight_offset_file(p["vnir"], p["swir"], p["cloud"], output=tmp_path / "a.json")
    b = get("boresight-offset")(
        vnir=p["vnir"], swir=p["swir"], cloud_mask=p["cloud"], output=tmp_path / "b.json"
    )
    assert {k: v for k, v in a.items() if k != "output"} == {
        k: v for k, v in b.items() if k != "output"
    }
    assert json.loads((tmp_path / "a.json").read_text()) == json.loads(
        (tmp_path / "b.json").read_text()
    )
    for alg in SPECS.values():
        assert alg.run.__name__ == alg.name.replace("-", "_") + "_file"


def test_view3d_refuses_a_dem_on_another_grid(scene, tmp_path):
    d, p, h = scene
    dem = write_gtiff(tmp_path / "dem.tif", np.zeros((1, 119, 96), "float32"))
    with pytest.raises(InputError, match="mismatched grids"):
        view_3d_file(dem, p["vnir"], p["swir"], output=tmp_path / "v.png")
    assert not (tmp_path / "v.png").exists()
