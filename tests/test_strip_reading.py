"""Reading a flight line strip by strip for the detectors: sampled pixels read line by line
equal the strips' values, co-registered strips equal the whole image co-registered at once
(edges included), and the shift neither modifies its input nor spreads an invalid value."""

import os

import numpy as np
import pytest

from geoboresight import io
from geoboresight.errors import InputError
from geoboresight.io import write_envi
from geoboresight.io.cube import open_cube
from geoboresight.operations.anomaly import _Coregistered
from geoboresight.sensor.coregister import coregister_stack, tap_lines


def _cube_file(tmp_path, name, k, interleave, nodata=None, dtype=np.uint16, seed=0):
    rng = np.random.default_rng(seed)
    cube = rng.integers(100, 4000, (k, 41, 23)).astype(dtype)
    if nodata is not None:
        cube[:, 7, 3:6] = nodata
    path = str(tmp_path / f"{name}_{interleave}.img")
    write_envi(path, cube, np.linspace(400, 900, k), interleave=interleave, nodata=nodata)
    return path, cube


@pytest.mark.parametrize("interleave", ["bil", "bip"])
@pytest.mark.parametrize("dtype", ["float64", None])
def test_sampled_pixels_equal_the_strips(tmp_path, interleave, dtype):
    path, cube = _cube_file(tmp_path, "c", 9, interleave, nodata=0)
    bands = np.array([0, 1, 2, 5, 6, 8])  # two runs of consecutive bands
    rng = np.random.default_rng(1)
    pos = np.sort(rng.choice(41 * 23, 150, replace=False))
    pos = np.union1d(pos, 7 * 23 + np.arange(3, 6))  # the nodata pixels too
    with open_cube(path) as c:
        read = c.reader(bands, dtype)
        assert hasattr(read, "pixels")  # the direct path is taken
        values, ok = io.read_pixels(read, pos, height=c.height, width=c.width)
        whole, whole_ok = c.read(0, c.height, bands, dtype)
        del read.pixels
        generic, generic_ok = io.read_pixels(read, pos, height=c.height, width=c.width)
    r, col = np.divmod(pos, 23)
    np.testing.assert_array_equal(values, whole[:, r, col])
    np.testing.assert_array_equal(ok, whole_ok[r, col])
    np.testing.assert_array_equal(values, generic)
    np.testing.assert_array_equal(ok, generic_ok)
    assert values.dtype == generic.dtype and (~ok).sum() == 3


def test_band_sequential_files_are_sampled_through_strips(tmp_path):
    path, _ = _cube_file(tmp_path, "c", 4, "bsq")
    with open_cube(path) as c:
        assert c.pixels([3, 40]) is None
        assert not hasattr(c.reader(None, None), "pixels")


def test_a_sample_read_through_gdal_reads_bounded_strips(tmp_path, monkeypatch):
    """A cube read through GDAL (here a GeoTIFF) is sampled in strips of at most
    SAMPLE_STRIP_BYTES, each worker thread keeps one open dataset per file, and close()
    closes them: the same values as a whole read."""
    import rasterio

    from geoboresight.io import windows

    rng = np.random.default_rng(2)
    cube = rng.integers(100, 4000, (6, 57, 19)).astype(np.int16)
    path = str(tmp_path / "c.tif")
    with (
        io.quiet_georef(),
        rasterio.open(
            path, "w", driver="GTiff", width=19, height=57, count=6, dtype="int16"
        ) as dst,
    ):
        dst.write(cube)
    pos = np.sort(rng.choice(57 * 19, 400, replace=False))  # nearly every line
    line_bytes = 6 * 19 * 8
    monkeypatch.setattr(windows, "SAMPLE_STRIP_BYTES", 5 * line_bytes)
    with open_cube(path) as c:
        read = c.reader(None, "float64")
        assert not hasattr(read, "pixels") and read.line_bytes == line_bytes
        strips = []

        def counted(row0, row1):
            strips.append(row1 - row0)
            return read(row0, row1)

        counted.line_bytes = read.line_bytes
        values, ok = io.read_pixels(counted, pos, height=c.height, width=c.width)
        assert max(strips) == 5 and sum(strips) <= 57
        datasets = list(c._datasets)
        assert 1 <= len(datasets) <= io.windows.default_workers()
    assert all(d.closed for d in datasets) and not c._datasets
    r, col = np.divmod(pos, 19)
    np.testing.assert_array_equal(values, cube[:, r, col].astype(np.float64))
    assert ok.all()


def test_gdals_block_cache_holds_an_open_tiled_cubes_rows_of_tiles(tmp_path, monkeypatch):
    """A tiled, compressed cube read 16 lines at a time decodes each 256-line row of tiles
    once only if GDAL's block cache holds it for every worker thread: the cube keeps that
    much while it is open, in bytes (what rasterio hands GDALSetCacheMax64), and gives it
    back when closed. An uncompressed ENVI cube, read without GDAL, keeps nothing."""
    import rasterio
    from rasterio.env import get_gdal_config

    from geoboresight.io import raster

    monkeypatch.delenv("GDAL_CACHEMAX", raising=False)
    default = raster.gdal_cache()["GDAL_CACHEMAX"]
    assert default == raster.GDAL_CACHE_MB * 2**20
    k, height, width = 20, 300, 520
    data = np.arange(k * height * width, dtype=np.int16).reshape(k, height, width) % 977
    path = str(tmp_path / "tiled.tif")
    profile = dict(driver="GTiff", width=width, height=height, count=k, dtype="int16")
    with (
        io.quiet_georef(),
        rasterio.open(
            path, "w", **profile, tiled=True, blockxsize=256, blockysize=256, compress="deflate"
        ) as dst,
    ):
        dst.write(data)
    row_of_tiles = 3 * 256 * 256 * k * 2  # three tiles across, 20 int16 bands each
    need = (io.windows.default_workers() + 1) * row_of_tiles
    assert need > default
    with open_cube(path) as c:
        with rasterio.Env(**raster.gdal_cache()):
            assert int(get_gdal_config("GDAL_CACHEMAX")) == need
        strip, _ = c.read(250, 266, dtype=None)
        np.testing.assert_array_equal(strip, data[:, 250:266])
    assert raster.gdal_cache()["GDAL_CACHEMAX"] == default
    write_envi(str(tmp_path / "plain.img"), data, np.linspace(400, 900, k))
    with open_cube(str(tmp_path / "plain.hdr")):
        assert raster.gdal_cache()["GDAL_CACHEMAX"] == default
    monkeypatch.setenv("GDAL_CACHEMAX", "512")  # the user's own setting wins
    assert raster.gdal_cache() == {}


@pytest.mark.parametrize("along", [2.37, -1.6, 0.5, 3.0])
def test_coregistered_strips_equal_the_whole_image(tmp_path, along):
    """Every strip of the detectors' reader, the first and last ones included, holds what
    co-registering the whole SWIR at once gives, and one validity."""
    across = -0.45
    v, vnir = _cube_file(tmp_path, "v", 4, "bil", seed=2)
    s, swir = _cube_file(tmp_path, "s", 5, "bil", nodata=0, seed=3)
    is_swir = np.arange(9) >= 4
    with open_cube([v, s]) as c:
        read = _Coregistered(c, np.arange(9), is_swir, along, across).reader()
        strips = list(
            io.map_windows(
                read,
                lambda d, ok: (d.copy(), ok.copy()),
                height=c.height,
                width=c.width,
                block_rows=6,
            )
        )
    data = np.concatenate([d for _, (d, _) in strips], axis=1)
    valid = np.vstack([ok for _, (_, ok) in strips])
    ref, ref_ok = coregister_stack(swir, along, across, swir[0] != 0)
    np.testing.assert_array_equal(valid, ref_ok)
    np.testing.assert_array_equal(data[:4], vnir)
    # The same taps on the same values; the strips' products sum in another order, so a
    # value may differ by float32 rounding of the taps' terms (a few ulps of the largest).
    atol = 8 * np.finfo(np.float32).eps * float(np.abs(swir).max())
    np.testing.assert_allclose(data[4:][:, valid], ref[:, valid], rtol=2e-6, atol=atol)
    # Lines whose taps leave the image are invalid; the others are valid away from nodata.
    first, stop = tap_lines(along)
    line = np.arange(41)
    outside = (line + first < 0) | (line + stop - 1 > 40)
    assert outside.any() and not valid[outside].any()
    assert valid[~outside].mean() > 0.5


def test_the_shift_leaves_its_input_and_keeps_a_nan_to_itself():
    rng = np.random.default_rng(5)
    stack = rng.normal(1000, 50, (6, 40, 30)).astype(np.float32)
    ok = np.ones((40, 30), bool)
    stack[:, 20, 15], ok[20, 15] = np.nan, False
    before = stack.copy()
    out, out_ok = coregister_stack(stack, 1.3, 0.6, ok)
    np.testing.assert_array_equal(stack, before)  # NaN and all
    zeroed = np.where(ok, stack, 0)
    ref, ref_ok = coregister_stack(zeroed, 1.3, 0.6, ok)
    np.testing.assert_array_equal(out_ok, ref_ok)
    assert np.isfinite(out[:, out_ok]).all() and (~out_ok[16:22, 12:18]).sum() == 16
    np.testing.assert_array_equal(out[:, out_ok], ref[:, out_ok])


def test_a_file_cut_short_while_read_is_named(tmp_path):
    path, _ = _cube_file(tmp_path, "c", 3, "bil")
    with open_cube(path) as c:
        os.truncate(path, os.path.getsize(path) // 2)
        with pytest.raises(InputError, match="c_bil.img: the file ends before byte"):
            c.read(30, 41, None, None)


def test_svdd_scores_a_strip_in_any_layout():
    """A strip that is a view (here laid out line by line), and one line of pixels longer than
    a scoring chunk, are scored as their contiguous copies are."""
    from geoboresight.anomaly.svdd import fit_svdd

    rng = np.random.default_rng(3)
    model = fit_svdd(rng.normal(0, 1, (300, 6)))
    strip = rng.normal(0, 1.5, (9, 6, 13)).transpose(1, 0, 2)
    valid = rng.random((9, 13)) > 0.2
    copy = np.ascontiguousarray(strip)
    np.testing.assert_array_equal(model.score_cube(strip, valid), model.score_cube(copy, valid))
    np.testing.assert_array_equal(
        model.score_cube(strip), model.score(copy.reshape(6, -1)).reshape(9, 13)
    )
    line = rng.normal(0, 1.5, (6, 1, 40_000))
    np.testing.assert_array_equal(model.score_cube(line)[0], model.score(line[:, 0]))


@pytest.mark.parametrize("along", [2.37, -1.6, 3.0])
def test_coregistered_pixels_equal_the_strips(tmp_path, along):
    """A sample drawn through the detectors' reader (the pixels' lines and their SWIR taps'
    lines only) holds what the co-registered strips hold there: validity exactly (edges and
    nodata included), values to float32 rounding."""
    v, _ = _cube_file(tmp_path, "v", 4, "bil", seed=2)
    s, _ = _cube_file(tmp_path, "s", 5, "bil", nodata=0, seed=3)
    pos = np.sort(np.random.default_rng(4).choice(41 * 23, 300, replace=False))
    pos = np.union1d(pos, [0, 22, 40 * 23, 41 * 23 - 1, 6 * 23 + 4, 8 * 23 + 5])
    with open_cube([v, s]) as c:
        read = _Coregistered(c, np.arange(9), np.arange(9) >= 4, along, -0.45).reader()
        assert hasattr(read, "pixels")
        values, ok = io.read_pixels(read, pos, height=c.height, width=c.width)
        whole, whole_ok = read(0, c.height)
    r, col = np.divmod(pos, 23)
    np.testing.assert_array_equal(ok, whole_ok[r, col])
    assert 0 < ok.sum() < len(pos)
    np.testing.assert_array_equal(values[:4], whole[:4, r, col])
    np.testing.assert_allclose(values[4:, ok], whole[4:, r, col][:, ok], rtol=2e-6)
