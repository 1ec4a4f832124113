"""Opening rasters, reading blocks with their validity mask, and writing GeoTIFF/ENVI outputs.

Raw sensor geometry (no CRS, no geotransform) is common for pushbroom data: it is read without
``NotGeoreferencedWarning`` noise and written back without inventing a CRS or transform.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from xml.sax.saxutils import escape

import numpy as np
import rasterio
from rasterio.errors import NotGeoreferencedWarning, RasterioIOError
from rasterio.transform import Affine
from rasterio.windows import Window

from .. import __version__
from ..errors import InputError
from .wavelengths import format_wavelengths
from .write import atomic_output

#: Nodata written into float outputs.
FLOAT_NODATA = -9999.0
#: GDAL block cache (MB) while reading: enough for a few strips of a full-width cube.
GDAL_CACHE_MB = 64
#: Rows per block when streaming a flight line (pushbroom lines run along rows).
DEFAULT_BLOCK_ROWS = 256


@contextlib.contextmanager
def quiet_georef():
    """Silence NotGeoreferencedWarning: raw sensor geometry is normal here, not a mistake."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        yield


@contextlib.contextmanager
def open_raster(path: str | os.PathLike, label: str = "raster"):
    """Open ``path`` for reading with a clear error when it is missing or unreadable."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"{label} {path} does not exist: check the path")
    if path.lower().endswith(".hdr"):
        # ENVI: GDAL opens the data file, not the header.
        data = _envi_data_for_header(path)
        if data is None:
            raise InputError(
                f"{label} {path} is an ENVI header but no data file sits beside it "
                "(expected the same name without .hdr, or .img/.dat/.raw/.bsq/.bil/.bip)"
            )
        path = data
    # GDAL's block cache defaults to 5 % of RAM and fills up while a flight line streams by:
    # cap it so memory stays bounded by a block (a user's own GDAL_CACHEMAX wins).
    cache = {} if os.environ.get("GDAL_CACHEMAX") else {"GDAL_CACHEMAX": GDAL_CACHE_MB}
    with rasterio.Env(**cache):
        try:
            with quiet_georef():
                src = rasterio.open(path)
        except RasterioIOError as exc:
            raise InputError(f"{label} {path} cannot be read as a raster ({exc})") from None
        try:
            with quiet_georef():
                yield src
        finally:
            src.close()


def _envi_data_for_header(hdr: str) -> str | None:
    stem = hdr[:-4]
    for ext in ("", ".img", ".dat", ".raw", ".bsq", ".bil", ".bip"):
        if os.path.isfile(stem + ext):
            return stem + ext
    return None


def band_count(path: str) -> int:
    with open_raster(path) as src:
        return src.count


def is_georeferenced(src) -> bool:
    """True when the dataset has a CRS or a non-identity geotransform."""
    return src.crs is not None or (src.transform != Affine.identity())


def row_windows(height: int, width: int, block_rows: int = DEFAULT_BLOCK_ROWS) -> Iterator[Window]:
    """Full-width strips of ``block_rows`` lines: memory bounded by a strip, not a flight line."""
    block_rows = max(1, int(block_rows))
    for row in range(0, height, block_rows):
        yield Window(0, row, width, min(block_rows, height - row))


def read_masked(src, band: int, window: Window | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(float32 values, valid mask) of one band: invalid where nodata, masked or non-finite."""
    data = src.read(band, window=window)
    valid = np.ones(data.shape, dtype=bool)
    if src.nodata is not None:
        valid &= data != src.nodata
        if np.isnan(src.nodata):
            valid &= ~np.isnan(data)
    else:
        # Honour an internal mask band (e.g. a GeoTIFF with a per-dataset mask).
        flags = src.mask_flag_enums[band - 1]
        if rasterio.enums.MaskFlags.all_valid not in flags:
            valid &= src.read_masks(band, window=window) > 0
    values = data.astype("float32", copy=False)
    valid &= np.isfinite(values)
    return values, valid


def output_profile(src, count: int = 1, dtype: str = "float32", nodata=FLOAT_NODATA) -> dict:
    """A tiled, compressed GeoTIFF profile on the grid of ``src``; no CRS is invented."""
    profile = {
        "driver": "GTiff",
        "width": src.width,
        "height": src.height,
        "count": count,
        "dtype": dtype,
        "nodata": nodata,
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "deflate",
        "predictor": 3 if np.dtype(dtype).kind == "f" else 2,
        "BIGTIFF": "IF_SAFER",
    }
    if src.crs is not None:
        profile["crs"] = src.crs
    if is_georeferenced(src):
        profile["transform"] = src.transform
    return profile


def grid_of(src) -> dict:
    """The grid (size, CRS, transform) of an open dataset, for comparing or creating rasters."""
    return {
        "width": src.width,
        "height": src.height,
        "crs": src.crs,
        "transform": src.transform if is_georeferenced(src) else None,
    }


def base_tags(**extra) -> dict:
    tags = {"GEOBORESIGHT_VERSION": __version__}
    tags.update({k.upper(): str(v) for k, v in extra.items()})
    return tags


def write_raster(
    path: str,
    arrays: np.ndarray | list[np.ndarray],
    like=None,
    *,
    crs=None,
    transform=None,
    nodata=FLOAT_NODATA,
    dtype: str | None = None,
    tags: dict | None = None,
    band_names: list[str] | None = None,
    overwrite: bool = True,
    colormap: dict | None = None,
    band_tags: list[dict] | None = None,
) -> str:
    """Write one or more bands (2-D arrays, or a 3-D stack) to a GeoTIFF atomically.

    The grid comes from ``like`` (an open dataset or a :func:`grid_of` dict), or from ``crs``
    and ``transform``. Masked entries of ``numpy.ma`` arrays are written as ``nodata``.
    """
    stack = np.ma.asarray(arrays)
    if stack.ndim == 2:
        stack = stack[np.newaxis]
    dtype = dtype or str(stack.dtype if stack.dtype != np.float64 else np.dtype("float32"))
    height, width = stack.shape[1:]
    profile = {
        "driver": "GTiff",
        "width": width,
        "height": height,
        "count": stack.shape[0],
        "dtype": dtype,
        "tiled": width >= 256 and height >= 256,
        "compress": "deflate",
        "BIGTIFF": "IF_SAFER",
    }
    if profile["tiled"]:
        profile.update(blockxsize=256, blockysize=256)
    if nodata is not None:
        profile["nodata"] = nodata
    if like is not None:
        grid = like if isinstance(like, dict) else grid_of(like)
        crs = grid.get("crs") if crs is None else crs
        transform = grid.get("transform") if transform is None else transform
    if crs is not None:
        profile["crs"] = crs
    if transform is not None and transform != Affine.identity():
        profile["transform"] = transform
    data = (
        stack.filled(nodata if nodata is not None else 0) if np.ma.isMaskedArray(stack) else stack
    )
    with atomic_output(path, overwrite=overwrite) as tmp, quiet_georef():
        with rasterio.open(tmp, "w", **profile) as dst:
            dst.write(np.asarray(data).astype(dtype, copy=False))
            dst.update_tags(**base_tags(**(tags or {})))
            if band_names:
                for i, name in enumerate(band_names, start=1):
                    dst.set_band_description(i, name)
            if band_tags:
                for i, bt in enumerate(band_tags, start=1):
                    dst.update_tags(i, **{k: str(v) for k, v in bt.items()})
            if colormap:
                dst.write_colormap(1, colormap)
    return path


def write_envi(
    path: str,
    cube: np.ndarray,
    wavelengths_nm,
    fwhm_nm=None,
    *,
    interleave: str = "bil",
    nodata=None,
    crs=None,
    transform=None,
    description: str = "",
    overwrite: bool = True,
) -> str:
    """Write a (bands, rows, cols) cube as ENVI with ``wavelength``/``fwhm`` in nanometres.

    ``path`` is the data file (e.g. ``scene_vnir.img``); GDAL writes ``scene_vnir.hdr``
    beside it. Raw geometry (no ``crs``/``transform``) stays raw.
    """
    cube = np.asarray(cube)
    profile = {
        "driver": "ENVI",
        "width": cube.shape[2],
        "height": cube.shape[1],
        "count": cube.shape[0],
        "dtype": str(cube.dtype),
        "interleave": interleave,
    }
    if nodata is not None:
        profile["nodata"] = nodata
    if crs is not None:
        profile["crs"] = crs
    if transform is not None and transform != Affine.identity():
        profile["transform"] = transform
    envi = {
        "wavelength": format_wavelengths(wavelengths_nm),
        "wavelength_units": "Nanometers",
    }
    if fwhm_nm is not None:
        envi["fwhm"] = format_wavelengths(fwhm_nm)
    with atomic_output(path, overwrite=overwrite) as tmp, quiet_georef():
        with rasterio.open(tmp, "w", **profile) as dst:
            dst.write(cube)
            dst.update_tags(ns="ENVI", **envi)
            for i, wl in enumerate(wavelengths_nm, start=1):
                dst.set_band_description(i, f"{wl:.2f} nm")
            if description:
                dst.update_tags(description=description)
    return path


@contextlib.contextmanager
def create_raster(
    path: str,
    grid: dict,
    *,
    count: int = 1,
    dtype: str = "float32",
    nodata=FLOAT_NODATA,
    tags: dict | None = None,
    band_names: list[str] | None = None,
    overwrite: bool = True,
):
    """Open a new tiled, compressed GeoTIFF for block-by-block writing; atomic on success.

    ``grid`` is a :func:`grid_of`-style dict (width, height, crs, transform or None for raw
    sensor geometry). Yields the open rasterio dataset.
    """
    profile = {
        "driver": "GTiff",
        "width": grid["width"],
        "height": grid["height"],
        "count": count,
        "dtype": dtype,
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "deflate",
        "BIGTIFF": "IF_SAFER",
    }
    if nodata is not None:
        profile["nodata"] = nodata
    if grid.get("crs") is not None:
        profile["crs"] = grid["crs"]
    if grid.get("transform") is not None:
        profile["transform"] = grid["transform"]
    with atomic_output(path, overwrite=overwrite) as tmp, quiet_georef():
        with rasterio.open(tmp, "w", **profile) as dst:
            yield dst
            dst.update_tags(**base_tags(**(tags or {})))
            if band_names:
                for i, name in enumerate(band_names, start=1):
                    dst.set_band_description(i, name)


def require_same_grid(a, b, label_a: str, label_b: str) -> None:
    """Raise InputError naming both files when two open datasets differ in size."""
    if (a.height, a.width) != (b.height, b.width):
        raise InputError(
            f"{label_a} {a.name} is {a.width} × {a.height} pixels but {label_b} {b.name} is "
            f"{b.width} × {b.height}: both must be on the same pixel grid"
        )


def sample_pixels(srcs_bands, height, width, block_rows, size, seed, progress):
    """A reproducible random sample (about ``size`` pixels) of several bands, streamed.

    ``srcs_bands`` is a list of (dataset, band). Returns (values (n_bands, n), valid (n,)).
    """
    rng = np.random.default_rng(seed)
    p = min(1.0, size / max(1, height * width))
    cols, oks = [], []
    windows = list(row_windows(height, width, block_rows))
    for i, win in enumerate(windows):
        pick = rng.random((win.height, win.width)) < p
        vals, ok = [], np.ones(int(pick.sum()), bool)
        for src, band in srcs_bands:
            v, valid = read_masked(src, band, win)
            vals.append(v[pick])
            ok &= valid[pick]
        cols.append(np.stack(vals))
        oks.append(ok)
        progress.update((i + 1) / len(windows), "sampling")
    return np.concatenate(cols, axis=1), np.concatenate(oks)


def _pam_categories(names: dict[int, str]) -> str:
    top = max(names)
    cats = "".join(
        f"      <Category>{escape(names.get(i, ''))}</Category>\n" for i in range(top + 1)
    )
    return (
        '<PAMDataset>\n  <PAMRasterBand band="1">\n    <CategoryNames>\n'
        f"{cats}    </CategoryNames>\n  </PAMRasterBand>\n</PAMDataset>\n"
    )


@contextlib.contextmanager
def create_class_raster(
    path, grid, *, tags, band_name, colormap, category_names, band_tags=None, nodata=255
):
    """A uint8 GeoTIFF (nodata 255) with a colour table and GDAL category names, written
    block by block; atomic. Category names go in the GDAL PAM sidecar (.aux.xml), where GDAL
    and QGIS read them (the colour table is inside the TIFF)."""
    profile = {
        "driver": "GTiff",
        "width": grid["width"],
        "height": grid["height"],
        "count": 1,
        "dtype": "uint8",
        "nodata": nodata,
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        "compress": "deflate",
        "photometric": "palette",
    }
    if grid.get("crs") is not None:
        profile["crs"] = grid["crs"]
    if grid.get("transform") is not None:
        profile["transform"] = grid["transform"]
    with atomic_output(path) as tmp:
        with quiet_georef(), rasterio.open(tmp, "w", **profile) as dst:
            dst.write_colormap(1, colormap)
            yield dst
            dst.update_tags(**base_tags(**tags))
            dst.set_band_description(1, band_name)
            if band_tags:
                dst.update_tags(1, **{k: str(v) for k, v in band_tags.items()})
        with open(tmp + ".aux.xml", "w", encoding="utf-8") as f:
            f.write(_pam_categories(category_names))
