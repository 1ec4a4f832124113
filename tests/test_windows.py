"""The one windowed map (io.windows) against whole-array results, as xarray-spatial tests its
NumPy kernels against their Dask versions."""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio
from scipy import ndimage

from geoboresight import io
from geoboresight.errors import Cancelled, InputError
from geoboresight.progress import Progress


def _array_reader(*arrays):
    def read(r0, r1):
        return tuple(a[..., r0:r1, :] for a in arrays)

    return read


@pytest.fixture(scope="module")
def image():
    rng = np.random.default_rng(7)
    return rng.normal(size=(3, 97, 41)).astype("float32"), rng.random((97, 41)) > 0.1


@pytest.mark.parametrize("block_rows", [1, 7, 16, 96, 97, 500])
@pytest.mark.parametrize("workers", [1, 3])
def test_pointwise_map_equals_whole_array(image, block_rows, workers):
    data, valid = image

    def kernel(x, ok):
        return np.where(ok, x[0] / (np.abs(x[1]) + 1), np.nan)

    whole = kernel(data, valid)
    got = np.full_like(whole, -1)
    order = []
    for win, part in io.map_windows(
        _array_reader(data, valid),
        kernel,
        height=97,
        width=41,
        block_rows=block_rows,
        workers=workers,
    ):
        got[win.row_off : win.row_off + win.height] = part
        order.append(win.row_off)
    assert order == sorted(order)  # results come back in order, threads or not
    np.testing.assert_array_equal(got, whole)


@pytest.mark.parametrize("block_rows", [1, 5, 13, 40, 97])
@pytest.mark.parametrize("size", [3, 7, 11])
def test_neighbourhood_map_with_halo_equals_whole_array(image, block_rows, size):
    """A uniform filter (reflecting at the image's edges) needs size//2 lines of halo; strips
    with that halo reproduce the whole-array filter exactly."""
    band = image[0][0].astype("float64")
    whole = ndimage.uniform_filter(band, size, mode="reflect")
    h = size // 2
    got = np.empty_like(whole)
    for win, part in io.map_windows(
        _array_reader(band),
        lambda x: ndimage.uniform_filter(x, size, mode="reflect"),
        height=97,
        width=41,
        block_rows=block_rows,
        halo=(h, h),
    ):
        assert part.shape == (win.height, 41)
        got[win.row_off : win.row_off + win.height] = part
    # Inside the image the halo gives every strip the lines the filter reads.
    np.testing.assert_allclose(got, whole, rtol=1e-12, atol=1e-12)


def test_halo_too_small_is_visible(image):
    """The comparison above can fail: with no halo the strips' edges differ from the whole."""
    band = image[0][0].astype("float64")
    whole = ndimage.uniform_filter(band, 7, mode="reflect")
    got = np.vstack(
        [
            p
            for _, p in io.map_windows(
                _array_reader(band),
                lambda x: ndimage.uniform_filter(x, 7, mode="reflect"),
                height=97,
                width=41,
                block_rows=10,
            )
        ]
    )
    assert not np.allclose(got, whole)


def test_pass_block_gives_image_coordinates(image):
    band = image[0][0]
    seen = []

    def kernel(x, block):
        seen.append((block.row0, block.rows, block.inner))
        return x[block.inner] * 2

    got = np.vstack(
        [
            p
            for _, p in io.map_windows(
                _array_reader(band),
                kernel,
                height=97,
                width=41,
                block_rows=30,
                halo=(2, 3),
                pass_block=True,
            )
        ]
    )
    np.testing.assert_array_equal(got, band * 2)
    assert seen[0] == (0, (0, 30), slice(0, 30))
    assert seen[1] == (28, (30, 60), slice(2, 32))
    assert seen[-1] == (88, (90, 97), slice(2, 9))


@pytest.mark.parametrize("block_rows", [1, 9, 50, 200])
def test_reduce_windows_merges_exactly(image, block_rows):
    data, valid = image
    total = io.reduce_windows(
        _array_reader(data[0], valid),
        lambda x, ok: np.array([ok.sum(), x[ok].astype("float64").sum()]),
        np.add,
        np.zeros(2),
        height=97,
        width=41,
        block_rows=block_rows,
    )
    assert total[0] == valid.sum()
    assert total[1] == pytest.approx(data[0][valid].astype("float64").sum(), rel=1e-12)


def _counting_passes(image, keep_bytes):
    data, valid = image
    reads = []

    def read(r0, r1):
        reads.append((r0, r1))
        return data[0, r0:r1], valid[r0:r1]

    blocks = io.windows.value_passes(
        read,
        lambda x, ok: x[ok],
        height=97,
        width=41,
        block_rows=10,
        keep_bytes=keep_bytes,
    )
    return blocks, reads


def test_value_passes_read_the_raster_once_when_its_values_fit(image):
    data, valid = image
    blocks, reads = _counting_passes(image, keep_bytes=data[0].nbytes)
    passes = [list(blocks()) for _ in range(4)]
    assert len(reads) == 10  # the first pass only
    for p in passes:
        np.testing.assert_array_equal(np.concatenate(p), data[0][valid])
    # The kept values are shared by the passes: a consumer may not change them.
    with pytest.raises(ValueError):
        passes[2][0][0] = 0.0


def test_value_passes_stream_every_pass_beyond_the_bound(image):
    data, valid = image
    blocks, reads = _counting_passes(image, keep_bytes=data[0][valid].nbytes // 2)
    passes = [np.concatenate(list(blocks())) for _ in range(3)]
    assert len(reads) == 30
    for p in passes:
        np.testing.assert_array_equal(p, data[0][valid])


def test_value_passes_keep_only_a_complete_pass(image):
    data, valid = image
    blocks, reads = _counting_passes(image, keep_bytes=data[0].nbytes)
    first = blocks()
    next(first)  # a consumer that stops early (an error, a cancellation)
    partial = len(reads)
    np.testing.assert_array_equal(np.concatenate(list(blocks())), data[0][valid])
    assert len(reads) == partial + 10  # the second pass read the raster again ...
    np.testing.assert_array_equal(np.concatenate(list(blocks())), data[0][valid])
    assert len(reads) == partial + 10  # ... and kept it for the third


def test_kept_passes_give_the_statistics_of_streamed_ones(image):
    from geoboresight.stats import describe_blocks

    results = []
    for keep in (0, io.windows.KEEP_BYTES):
        blocks, _ = _counting_passes(image, keep_bytes=keep)
        results.append(describe_blocks(blocks, percentiles=[1, 25, 50, 75, 99]).to_dict())
    assert results[0] == results[1]


def test_cancel_stops_within_one_strip(image):
    data, valid = image
    calls = []

    def cancelled():
        return len(calls) >= 2

    with pytest.raises(Cancelled):
        for _ in io.map_windows(
            _array_reader(data[0]),
            lambda x: calls.append(1) or x,
            height=97,
            width=41,
            block_rows=10,
            progress=Progress(is_cancelled=cancelled),
        ):
            pass
    assert len(calls) == 2


def test_sample_windows_is_uniform_reproducible_and_block_independent(tmp_path):
    rng = np.random.default_rng(3)
    arr = rng.normal(size=(2, 300, 50)).astype("float32")
    path = tmp_path / "a.tif"
    io.write_raster(str(path), arr, nodata=None)
    with rasterio.open(path) as src:
        read = io.bands_reader([(src, 1), (src, 2)])
        a, ok_a = io.sample_windows(read, height=300, width=50, size=3000, seed=5, block_rows=64)
        b, _ = io.sample_windows(read, height=300, width=50, size=3000, seed=5, block_rows=64)
    np.testing.assert_array_equal(a, b)
    assert a.shape[0] == 2 and ok_a.all()
    assert 2700 < a.shape[1] < 3300  # about `size` pixels
    # Drawn uniformly: the sample's mean matches the image's within its standard error.
    assert abs(a[0].mean() - arr[0].mean()) < 4 * arr[0].std() / np.sqrt(a.shape[1])


def test_grid_check_names_both_files(tmp_path):
    io.write_raster(str(tmp_path / "a.tif"), np.zeros((10, 12), "float32"))
    io.write_raster(str(tmp_path / "b.tif"), np.zeros((10, 13), "float32"))
    with io.open_raster(tmp_path / "a.tif") as a, io.open_raster(tmp_path / "b.tif") as b:
        with pytest.raises(InputError) as err:
            io.require_same_grid(a, b, "ratio raster", "mask")
    msg = str(err.value)
    assert "a.tif" in msg and "b.tif" in msg and "12 × 10" in msg and "13 × 10" in msg


def _reusing_reader(cube, valid):
    # Like Cube.reader: every read lands in the same buffer (the previous result is overwritten).
    buf = np.empty_like(cube)
    vbuf = np.empty_like(valid)

    def read(r0, r1):
        n = r1 - r0
        buf[:, :n] = cube[:, r0:r1]
        vbuf[:n] = valid[r0:r1]
        return buf[:, :n], vbuf[:n]

    return read


@pytest.mark.parametrize("block_rows", [1, 4, 16, 100])
@pytest.mark.parametrize("n_positions", [0, 1, 7, 300, 2400])
def test_read_pixels_equals_indexing_the_whole_image(block_rows, n_positions):
    rng = np.random.default_rng(n_positions)
    cube = rng.normal(size=(5, 60, 40)).astype(np.float32)
    valid = rng.random((60, 40)) > 0.1
    positions = np.sort(rng.choice(60 * 40, n_positions, replace=False))
    values, ok = io.read_pixels(
        _reusing_reader(cube, valid), positions, height=60, width=40, block_rows=block_rows
    )
    np.testing.assert_array_equal(values, cube.reshape(5, -1)[:, positions])
    np.testing.assert_array_equal(ok, valid.ravel()[positions])


@pytest.mark.parametrize("block_rows", [3, 64])
def test_sample_windows_draws_as_strip_by_strip(block_rows):
    # The sample is the one drawing one uniform number per pixel strip by strip would give.
    rng = np.random.default_rng(2)
    cube = rng.normal(size=(3, 50, 30))
    valid = rng.random((50, 30)) > 0.2
    values, ok = io.sample_windows(
        _reusing_reader(cube, valid), height=50, width=30, size=200, seed=9, block_rows=block_rows
    )
    draw = np.random.default_rng(9)
    chosen = np.concatenate(
        [(draw.random((min(7, 50 - r), 30)) < 200 / 1500).ravel() for r in range(0, 50, 7)]
    )
    np.testing.assert_array_equal(values, cube.reshape(3, -1)[:, chosen])
    np.testing.assert_array_equal(ok, valid.ravel()[chosen])


@pytest.mark.parametrize("rows", [1, 16, 100, 256, 300, 1000])
@pytest.mark.parametrize("count", [1, 3])
def test_create_raster_strip_writes_equal_one_write_and_do_not_bloat(tmp_path, rows, count):
    # GDAL recompresses and appends a tile each time a write leaves it: strips must reach it
    # as whole tile rows (io.raster.TileRowWriter), giving the same pixels in a file of the
    # same size as one whole write.
    from rasterio.windows import Window

    rng = np.random.default_rng(rows)
    data = rng.normal(size=(count, 1000, 300)).astype("float32")
    grid = io.Grid(300, 1000)
    with io.create_raster(str(tmp_path / "one.tif"), grid, count=count) as dst:
        dst.write(data)
    with io.create_raster(str(tmp_path / "strips.tif"), grid, count=count) as dst:
        for r in range(0, 1000, rows):
            n = min(rows, 1000 - r)
            part = data[:, r : r + n]
            if count == 1:
                dst.write(part[0], 1, window=Window(0, r, 300, n))
            else:
                dst.write(part, window=Window(0, r, 300, n))
    with rasterio.open(tmp_path / "one.tif") as a, rasterio.open(tmp_path / "strips.tif") as b:
        np.testing.assert_array_equal(a.read(), data)
        np.testing.assert_array_equal(b.read(), data)
    one, strips = (os.path.getsize(tmp_path / n) for n in ("one.tif", "strips.tif"))
    assert strips <= one * 1.05


def test_tile_row_writer_passes_other_writes_through(tmp_path):
    # Out-of-order and partial-width writes go straight to GDAL, after what was gathered.
    from rasterio.windows import Window

    data = np.arange(600 * 300, dtype="float32").reshape(600, 300)
    with io.create_raster(str(tmp_path / "x.tif"), io.Grid(300, 600)) as dst:
        dst.write(data[0:10], 1, window=Window(0, 0, 300, 10))  # gathered
        dst.write(data[300:310, :100], 1, window=Window(0, 300, 100, 10))  # partial width
        dst.write(data[300:310, 100:], 1, window=Window(100, 300, 200, 10))
        dst.write(data[10:300], 1, window=Window(0, 10, 300, 290))  # back to gathering
        dst.write(data[310:], 1, window=Window(0, 310, 300, 290))
    with rasterio.open(tmp_path / "x.tif") as src:
        np.testing.assert_array_equal(src.read(1), data)


def test_multi_band_outputs_are_band_interleaved_unless_the_user_says(tmp_path):
    # A cube is written strip by strip and drawn three bands at a time: band-interleaved
    # (benchmarks/cube_write.py); a user's --co INTERLEAVE=PIXEL still wins; one band has
    # nothing to interleave.
    from rasterio.enums import Interleaving

    from geoboresight.io.raster import writer_options

    grid = io.Grid(40, 30)
    data = np.arange(3 * 30 * 40, dtype="float32").reshape(3, 30, 40)
    for name, co, expected in (
        ("band.tif", None, Interleaving.band),
        ("pixel.tif", ["INTERLEAVE=PIXEL"], Interleaving.pixel),
    ):
        with writer_options(co=co), io.create_raster(str(tmp_path / name), grid, count=3) as d:
            d.write(data)
        with rasterio.open(tmp_path / name) as src:
            assert src.interleaving == expected
            assert np.array_equal(src.read(), data)
