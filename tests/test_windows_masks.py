"""The strip readers' validity against rasterio's own masked read: a GeoTIFF with an internal
per-dataset mask, with an alpha band, with a nodata value, with NaN as nodata and with
neither give the values and valid pixels of ``read(masked=True)`` (non-finite values invalid
too), strip by strip, and look the file's mask flags up once per dataset, not once per read."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio
from rasterio.enums import MaskFlags
from rasterio.transform import from_origin

from geoboresight import io
from geoboresight.io.bands import masked_bands_reader

LINES, COLS, STRIP = 70, 33, 16  # five strips, the last one short


def _values(dtype, bands, seed):
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        data = rng.normal(500.0, 100.0, (bands, LINES, COLS)).astype(dtype)
        data[0, 3, 4], data[-1, 50, 7], data[1 % bands, 66, 30] = np.nan, np.inf, -np.inf
        return data
    return rng.integers(1, 250, (bands, LINES, COLS)).astype(dtype)


def _write(path, data, *, nodata=None, mask=None, **options):
    profile = dict(driver="GTiff", width=COLS, height=LINES, count=len(data), dtype=data.dtype)
    profile.update(crs="EPSG:32636", transform=from_origin(700000, 3500000, 2, 2), **options)
    with rasterio.Env(GDAL_TIFF_INTERNAL_MASK=True):
        with rasterio.open(path, "w", nodata=nodata, **profile) as dst:
            dst.write(data)
            if mask is not None:
                dst.write_mask(np.where(mask, 255, 0).astype("uint8"))
    return str(path)


def _per_dataset_mask(tmp_path, dtype):
    mask = np.ones((LINES, COLS), bool)
    mask[10:14, 5:20] = False
    mask[40:60, 0] = False
    return _write(tmp_path / f"mask_{dtype}.tif", _values(dtype, 3, 1), mask=mask)


def _alpha(tmp_path, dtype):
    # RGB and alpha: bands 1–3 masked by the alpha band, the alpha band itself all valid.
    data = _values("uint8", 4, 2)
    data[3] = 255
    data[3, 20:30, 10:12] = 0
    data[3, 0, :] = 0
    return _write(tmp_path / "alpha.tif", data, photometric="RGB", alpha="YES")


def _nodata(tmp_path, dtype):
    data = _values(dtype, 3, 3)
    nodata = -9999 if np.dtype(dtype).kind == "f" else 0
    data[:, 20:24, 3:9] = nodata
    data[2, 61, :] = nodata
    return _write(tmp_path / f"nodata_{dtype}.tif", data, nodata=nodata)


def _nan_nodata(tmp_path, dtype):
    data = _values("float32", 3, 4)
    data[:, 30:33, 12:20] = np.nan
    return _write(tmp_path / "nan.tif", data, nodata=float("nan"))


def _neither(tmp_path, dtype):
    return _write(tmp_path / f"neither_{dtype}.tif", _values(dtype, 3, 5))


CASES = [
    (_per_dataset_mask, "float32"),
    (_per_dataset_mask, "uint16"),
    (_alpha, "uint8"),
    (_nodata, "float32"),
    (_nodata, "uint16"),
    (_nan_nodata, "float32"),
    (_neither, "float32"),
    (_neither, "int16"),
]
IDS = [f"{make.__name__.strip('_')}-{dtype}" for make, dtype in CASES]


def _truth(src):
    """(values (n, lines, cols) float32, valid per band) from rasterio's masked read."""
    masked = src.read(masked=True)
    values = masked.data.astype("float32")
    return values, ~np.ma.getmaskarray(masked) & np.isfinite(values)


def _strips(read, *, workers=1):
    parts = [
        p
        for _, p in io.map_windows(
            read, lambda *a: a, height=LINES, width=COLS, block_rows=STRIP, workers=workers
        )
    ]
    return tuple(np.concatenate(x, axis=-2) for x in zip(*parts, strict=True))


@pytest.mark.parametrize(("make", "dtype"), CASES, ids=IDS)
def test_readers_give_rasterio_masked_read(tmp_path, make, dtype):
    path = make(tmp_path, dtype)
    with rasterio.open(path) as src:
        values, valid = _truth(src)
        assert not valid.all() or make is _neither and dtype == "int16"
        if make in (_per_dataset_mask, _alpha):  # the mask band is what rasterio read
            assert MaskFlags.per_dataset in src.mask_flag_enums[0]
        for b in range(1, src.count + 1):
            v, ok = _strips(io.band_reader(src, b))
            np.testing.assert_array_equal(v[valid[b - 1]], values[b - 1][valid[b - 1]])
            np.testing.assert_array_equal(ok, valid[b - 1])
            # The flags looked up at the call, as for any other caller of read_masked.
            v1, ok1 = io.read_masked(src, b)
            np.testing.assert_array_equal(ok1, valid[b - 1])
            np.testing.assert_array_equal(v1, v)
        bands = list(range(1, src.count + 1))
        v, ok = _strips(io.bands_reader([(src, b) for b in bands]), workers=2)
        np.testing.assert_array_equal(ok, valid.all(axis=0))
        np.testing.assert_array_equal(v[:, ok], values[:, ok])
        v, ok = _strips(masked_bands_reader(src, bands))
        np.testing.assert_array_equal(ok, valid)
        np.testing.assert_array_equal(v[ok], values[valid])


def test_two_files_read_together(tmp_path):
    # One reader over bands of a masked and a nodata file: valid where both are.
    with (
        rasterio.open(_per_dataset_mask(tmp_path, "float32")) as a,
        rasterio.open(_nodata(tmp_path, "uint16")) as b,
    ):
        (va, oka), (vb, okb) = _truth(a), _truth(b)
        v, ok = _strips(io.bands_reader([(a, 2), (b, 1), (a, 3), (b, 3)]), workers=2)
    np.testing.assert_array_equal(ok, oka[1] & okb[0] & oka[2] & okb[2])
    np.testing.assert_array_equal(v[:, ok], np.stack([va[1], vb[0], va[2], vb[2]])[:, ok])


class _Counting:
    """A dataset counting the look-ups of its mask flags (GDAL asks every band each time)."""

    def __init__(self, src):
        self._src, self.lookups = src, 0

    @property
    def mask_flag_enums(self):
        self.lookups += 1
        return self._src.mask_flag_enums

    def __getattr__(self, name):
        return getattr(self._src, name)


def test_mask_flags_are_looked_up_once_per_dataset(tmp_path):
    path = _per_dataset_mask(tmp_path, "float32")
    with rasterio.open(path) as src, rasterio.open(path) as other:
        values, valid = _truth(src)
        one, two = _Counting(src), _Counting(other)
        v, ok = _strips(io.bands_reader([(one, 1), (two, 2), (one, 3), (two, 1)]))
        assert (one.lookups, two.lookups) == (1, 1)  # 10 each when looked up at every read
        np.testing.assert_array_equal(ok, valid[0] & valid[1] & valid[2])
        np.testing.assert_array_equal(v[0, ok], values[0, ok])
        single = _Counting(src)
        _strips(io.band_reader(single, 2))
        _strips(masked_bands_reader(single, [1, 2, 3]))
        assert single.lookups == 2


def test_a_missing_band_fails_as_it_did(tmp_path):
    with (
        rasterio.open(_nodata(tmp_path, "uint16")) as a,
        rasterio.open(_neither(tmp_path, "float32")) as b,
    ):
        for src in (a, b):
            for band in (0, 4):
                with pytest.raises(IndexError) as before:
                    io.read_masked(src, band, rasterio.windows.Window(0, 0, COLS, STRIP))
                with pytest.raises(IndexError) as now:
                    io.band_reader(src, band)(0, STRIP)
                assert str(now.value) == str(before.value)
