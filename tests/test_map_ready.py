"""Map-ready rasters: every GeoTIFF output can be a Cloud-Optimised GeoTIFF with
overviews and rio's ``--co NAME=VALUE`` creation options, set once for every operation."""

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin
from synth import SWIR_WL, VNIR_WL, cube, write_envi

import geoboresight as gb
from geoboresight.cli import main
from geoboresight.errors import InputError, ParameterError
from geoboresight.io import Grid, write_raster
from geoboresight.io.raster import create_class_raster, writer_options


def _pair(tmp_path, rows=600, cols=300):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL), rows, cols, seed=1), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL), rows, cols, seed=2), SWIR_WL)
    return v, s


def test_cli_cog_and_creation_options_keep_the_pixels(tmp_path):
    v, s = _pair(tmp_path)
    plain, cog = tmp_path / "plain.tif", tmp_path / "cog.tif"
    base = ["ratio", "--vnir", v, "--swir", s, "-q"]
    assert CliRunner().invoke(main, [*base, "-o", str(plain)]).exit_code == 0
    r = CliRunner().invoke(main, [*base, "-o", str(cog), "--cog", "--co", "COMPRESS=LZW"])
    assert r.exit_code == 0, r.output
    with rasterio.open(plain) as a, rasterio.open(cog) as b:
        # GDAL's own report of the layout and the compression asked for.
        assert b.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert b.compression.name == "lzw"
        assert "LAYOUT" not in a.tags(ns="IMAGE_STRUCTURE")
        np.testing.assert_array_equal(a.read(1), b.read(1))
        assert a.overviews(1) == b.overviews(1) == [2, 4]  # until a level fits a tile
        assert b.tags() == a.tags() and b.descriptions == a.descriptions
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_float_overviews_are_nodata_aware_2x2_means(tmp_path):
    rng = np.random.default_rng(0)
    a = rng.random((600, 520)).astype("float32")
    a[:7, :9] = -9999.0
    grid = Grid(520, 600, "EPSG:32636", from_origin(700000, 3600000, 2.0, 2.0))
    write_raster(str(tmp_path / "f.tif"), np.ma.masked_equal(a, -9999.0), grid)
    with rasterio.open(tmp_path / "f.tif") as src:
        assert src.overviews(1) == [2, 4]
        ov = src.read(1, out_shape=(300, 260))
    blocks = np.ma.masked_equal(a, -9999.0).reshape(300, 2, 260, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(ov[4:, 5:], blocks[4:, 5:].filled(), rtol=1e-6)
    assert ov[0, 0] == -9999.0  # a block of nodata only stays nodata


def test_blocks_compressed_in_gdals_threads_keep_every_pixel(tmp_path, monkeypatch):
    """A raster of many tiles written with GDAL's threads (the default) holds the same pixels,
    overviews and tags as one written in a single thread (a user's GDAL_NUM_THREADS wins)."""
    rng = np.random.default_rng(4)
    a = rng.random((1024, 768)).astype("float32")
    grid = Grid(768, 1024, "EPSG:32636", from_origin(700000, 3600000, 2.0, 2.0))
    monkeypatch.delenv("GDAL_NUM_THREADS", raising=False)
    write_raster(str(tmp_path / "threads.tif"), a, grid)
    monkeypatch.setenv("GDAL_NUM_THREADS", "1")
    write_raster(str(tmp_path / "one.tif"), a, grid)
    with rasterio.open(tmp_path / "threads.tif") as t, rasterio.open(tmp_path / "one.tif") as o:
        np.testing.assert_array_equal(t.read(1), a)
        np.testing.assert_array_equal(t.read(1), o.read(1))
        assert t.overviews(1) == o.overviews(1) != []
        shape = (1024 // 4, 768 // 4)
        np.testing.assert_array_equal(t.read(1, out_shape=shape), o.read(1, out_shape=shape))
        assert t.tags() == o.tags() and t.profile == o.profile


def test_class_overviews_never_invent_a_class(tmp_path):
    rng = np.random.default_rng(1)
    classes = rng.choice([0, 3, 7], size=(700, 700)).astype("uint8")
    with writer_options(cog=True):
        with create_class_raster(
            str(tmp_path / "c.tif"),
            Grid(700, 700),
            tags={},
            band_name="class",
            colormap={0: (0, 0, 0, 255), 3: (255, 0, 0, 255), 7: (0, 0, 255, 255)},
            category_names={0: "a", 3: "b", 7: "c"},
        ) as dst:
            dst.write(classes, 1)
    with rasterio.open(tmp_path / "c.tif") as src:
        assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert src.overviews(1) == [2, 4]
        np.testing.assert_array_equal(src.read(1), classes)
        for level in (2, 4):
            ov = src.read(1, out_shape=(700 // level, 700 // level))
            assert set(np.unique(ov)) <= {0, 3, 7}
        assert src.colormap(1)[3][:3] == (255, 0, 0)
        assert src.crs is None  # raw geometry stays raw


def test_python_operation_takes_cog_and_co(tmp_path):
    v, s = _pair(tmp_path, rows=40, cols=30)
    out = tmp_path / "r.tif"
    with gb.writer_options(cog=True, co="COMPRESS=ZSTD,LEVEL=9"):
        gb.ratio_file(v, s, output=str(out))
    with rasterio.open(out) as src:
        assert src.compression.name == "zstd"
        assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert src.overviews(1) == []  # one tile: nothing to decimate


@pytest.mark.parametrize(
    "co, words",
    [("FOO=1", "FOO"), ("COMPRESS=NOPE", "NOPE"), ("junk", "NAME=VALUE")],
)
def test_bad_creation_option_is_one_line_and_leaves_nothing(tmp_path, co, words):
    v, s = _pair(tmp_path, rows=40, cols=30)
    out = tmp_path / "r.tif"
    r = CliRunner().invoke(
        main, ["ratio", "--vnir", v, "--swir", s, "-o", str(out), "--co", co, "-q"]
    )
    assert r.exit_code != 0
    line = r.output.strip()
    assert "\n" not in line and "'co'" in line and words in line
    assert not out.exists()
    with pytest.raises(ParameterError, match="COG driver refuses TILED"):
        with gb.writer_options(cog=True, co={"TILED": "YES"}):
            gb.ratio_file(v, s, output=str(out))
    assert not out.exists()


def _with_bbl(path, flags):
    hdr = str(path)[:-4] + ".hdr"
    with open(hdr, "a") as f:
        f.write("bbl = {" + ", ".join(str(int(x)) for x in flags) + "}\n")
    return path


def test_envi_bad_band_list_is_never_picked_nor_used(tmp_path):
    vn, sw = cube(len(VNIR_WL), seed=3), cube(len(SWIR_WL), seed=4)
    v = _with_bbl(write_envi(tmp_path / "v.img", vn, VNIR_WL), [1] * 11 + [0])
    s = _with_bbl(write_envi(tmp_path / "s.img", sw, SWIR_WL), [0] + [1] * 49)
    dual = gb.open_dual(v, s)
    assert 12 not in dual.vnir.bands and 1 not in dual.swir.bands
    rb = dual.ratio_bands(gb.BandChoice(band_mode="edges"))  # last good VNIR over first good SWIR
    assert (rb.vnir_band, rb.swir_band) == (11, 2)
    assert rb.vnir_nm == pytest.approx(VNIR_WL[10]) and rb.swir_nm == pytest.approx(SWIR_WL[1])
    out = tmp_path / "r.tif"
    gb.ratio_file(v, s, output=str(out), bands=gb.BandChoice(band_mode="edges"))
    with rasterio.open(out) as src:
        r = src.read(1, masked=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        want = sw[1].astype("float64") / vn[10].astype("float64")
    np.testing.assert_allclose(r.compressed(), want[~r.mask].astype("float32"), rtol=1e-6)
    # The anomaly detectors' band selection drops them too.
    rx = tmp_path / "rx.tif"
    gb.rx_file(v, s, output=str(rx), spectral=gb.BandSelection(exclude_nm=""))
    with rasterio.open(rx) as src:
        used = [int(b) for b in src.tags()["BANDS_USED"].split(",")]
    assert 12 not in used and 13 not in used and len(used) == 11 + 49


def test_bad_band_list_with_every_band_bad_or_wrong_length_is_refused(tmp_path):
    v = _with_bbl(write_envi(tmp_path / "v.img", cube(len(VNIR_WL)), VNIR_WL), [0] * 12)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL)), SWIR_WL)
    with pytest.raises(InputError, match=r"bbl.*every band bad"):
        gb.open_dual(v, s)
    w = _with_bbl(write_envi(tmp_path / "w.img", cube(len(VNIR_WL)), VNIR_WL), [1, 0])
    with pytest.raises(InputError, match=r"'bbl'.*12 in all; it has 2"):
        gb.open_dual(w, s)


def test_cube_outputs_carry_wavelengths_in_gdal_imagery_domain(tmp_path):
    wl = [480.0, 560.0, 660.0, 860.0]
    write_raster(
        str(tmp_path / "c.tif"),
        np.ones((4, 20, 30), "float32"),
        Grid(30, 20),
        band_tags=[{"wavelength": f"{w}", "wavelength_units": "nm", "fwhm": "10"} for w in wl],
    )
    with rasterio.open(tmp_path / "c.tif") as src:
        got = [float(src.tags(b, ns="IMAGERY")["CENTRAL_WAVELENGTH_UM"]) for b in (1, 2, 3, 4)]
        assert src.tags(1, ns="IMAGERY")["FWHM_UM"] == "0.010000"
    np.testing.assert_allclose(got, np.array(wl) / 1000)
    # ENVI cubes: GDAL (≥ 3.10) reports the header's wavelengths in the IMAGERY domain itself.
    e = write_envi(tmp_path / "e.img", cube(3, seed=5), [500.0, 600.0, 700.0])
    with rasterio.open(e) as src:
        assert float(src.tags(3, ns="IMAGERY")["CENTRAL_WAVELENGTH_UM"]) == pytest.approx(0.7)


def test_raw_gsd_writes_a_local_metric_crs_only_on_raw_outputs(tmp_path):
    v, s = _pair(tmp_path, rows=40, cols=30)
    out = tmp_path / "r.tif"
    r = CliRunner().invoke(
        main, ["ratio", "--vnir", v, "--swir", s, "-o", str(out), "--raw-gsd", "1.5", "-q"]
    )
    assert r.exit_code == 0, r.output
    with rasterio.open(out) as src:
        assert src.crs.to_wkt().startswith("LOCAL_CS[") and not src.crs.is_geographic
        assert src.crs.to_epsg() is None  # no Earth position
        assert tuple(src.transform)[:6] == (1.5, 0.0, 0.0, 0.0, -1.5, 0.0)
        assert src.tags()["RAW_GEOMETRY_GSD_M"] == "1.5"
    # A georeferenced output keeps its own CRS and grid.
    grid = Grid(20, 10, "EPSG:32636", from_origin(700000, 3600000, 2.0, 2.0))
    with writer_options(raw_gsd=1.5):
        write_raster(str(tmp_path / "g.tif"), np.ones((10, 20), "float32"), grid)
    with rasterio.open(tmp_path / "g.tif") as src:
        assert src.crs.to_epsg() == 32636 and src.transform.a == 2.0
    for bad in ("0", "-2", "nan"):
        r = CliRunner().invoke(
            main,
            ["ratio", "--vnir", v, "--swir", s, "-o", str(tmp_path / "b.tif"), "--raw-gsd", bad],
        )
        assert r.exit_code != 0 and "raw_gsd" in r.output and not (tmp_path / "b.tif").exists()


def test_a_raw_gsd_product_is_still_raw_geometry_when_read(tmp_path):
    from geoboresight.io import open_raster

    v, s = _pair(tmp_path, rows=40, cols=30)
    out = tmp_path / "r.tif"
    with gb.writer_options(raw_gsd=2.0):
        gb.ratio_file(v, s, output=str(out))
    with open_raster(out) as src:
        assert not Grid.of(src).georeferenced  # metres from the GSD, no Earth position
    ref = tmp_path / "ref.tif"
    write_raster(
        str(ref),
        np.ones((10, 10), "float32"),
        Grid(10, 10, "EPSG:32636", from_origin(700000, 3600000, 2.0, 2.0)),
    )
    with pytest.raises(InputError, match="raw sensor geometry"):
        gb.reproject_to_file(str(out), reference=str(ref), output=str(tmp_path / "p.tif"))
    assert not (tmp_path / "p.tif").exists()
