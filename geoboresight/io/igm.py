"""Writing an IGM (the map position of every raw pixel) line block by line block: float64
easting, northing and height, nodata where a ray misses, as GeoTIFF or as ENVI BIL in APL's
layout (three bands X, Y, Z; the CRS in the header; raw geometry, no map info)."""

from __future__ import annotations

import contextlib
import functools
import os

import numpy as np

from .grid import FLOAT_NODATA, Grid
from .raster import create_raster, gdal_cache, quiet_georef
from .write import atomic_output

IGM_BANDS = ["x (easting)", "y (northing)", "height (ellipsoidal, m)"]
ANGLE_BANDS = ["view zenith (degrees)", "view azimuth (degrees, clockwise from north)"]


@functools.lru_cache(maxsize=1)
def fast_compression() -> dict:
    """Lossless creation options for a float64 IGM: ZSTD at its fastest level with the
    floating-point predictor where this GDAL has ZSTD (about half deflate's time, the same
    size), else the profile's deflate."""
    from rasterio.io import MemoryFile

    options = {"compress": "zstd", "zstd_level": 1, "predictor": 3}
    try:
        with MemoryFile() as mem, quiet_georef():
            with mem.open(driver="GTiff", width=1, height=1, count=1, dtype="float64",
                          **options) as dst:  # fmt: skip
                dst.write(np.zeros((1, 1, 1)))
            with mem.open() as src:
                ok = src.compression is not None and src.compression.name == "zstd"
    except Exception:  # noqa: BLE001 - a GDAL without ZSTD: deflate
        ok = False
    return options if ok else {}


def is_envi(path) -> bool:
    """True for an output path written as ENVI (``.bil``, ``.img``)."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    return ext in (".bil", ".img")


@contextlib.contextmanager
def block_writer(path, width, height, crs, *, bands, tags):
    """Yield ``write(row0, arrays)``: ``arrays`` (count, rows, width) float64 with NaN for
    nodata, written at line ``row0``; the file appears complete or not at all."""
    path = os.fspath(path)
    count = len(bands)
    if not is_envi(path):
        grid = Grid(width, height, crs, None)
        with create_raster(path, grid, count=count, dtype="float64", nodata=FLOAT_NODATA,
                           tags=tags, band_names=bands, overviews=False,
                           compression=fast_compression()) as dst:  # fmt: skip

            def write(row0, arrays):
                from rasterio.windows import Window

                data = np.where(np.isfinite(arrays), arrays, FLOAT_NODATA)
                dst.write(data, window=Window(0, row0, width, data.shape[1]))

            yield write
        return
    import rasterio
    from rasterio.windows import Window

    profile = dict(driver="ENVI", width=width, height=height, count=count, dtype="float64",
                   interleave="bil", nodata=FLOAT_NODATA, crs=crs)  # fmt: skip
    # GDAL's block cache capped as for every writer: memory bounded by a block of lines
    cache = rasterio.Env(**gdal_cache())
    with (
        atomic_output(path) as tmp,
        quiet_georef(),
        cache,
        rasterio.open(tmp, "w", **profile) as dst,
    ):

        def write(row0, arrays):
            data = np.where(np.isfinite(arrays), arrays, FLOAT_NODATA)
            dst.write(data, window=Window(0, row0, width, data.shape[1]))

        yield write
        for i, name in enumerate(bands, start=1):
            dst.set_band_description(i, name)
        dst.update_tags(**{k: str(v) for k, v in tags.items()})
