"""Small dual-sensor files for the spine's tests (independent of the simulator)."""

from __future__ import annotations

import numpy as np
import rasterio
from rasterio.transform import from_origin

from geoboresight.io import quiet_georef

VNIR_WL = np.linspace(400.0, 970.0, 12)  # last band 970, 920 nearby
SWIR_WL = 980.0 + 30.0 * np.arange(50)  # 980, 1010, ..., 2450


def cube(bands: int, rows: int = 40, cols: int = 30, seed: int = 0, dtype="int16") -> np.ndarray:
    rng = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        return rng.uniform(0.0, 4000.0, (bands, rows, cols)).astype(dtype)
    return rng.integers(0, 4000, (bands, rows, cols)).astype(dtype)


def write_envi(
    path,
    data,
    wavelengths,
    units="Nanometers",
    interleave="bsq",
    nodata=None,
    crs=None,
    transform=None,
):
    """Write an ENVI file with rasterio (the data file path; GDAL writes the .hdr)."""
    profile = dict(
        driver="ENVI",
        width=data.shape[2],
        height=data.shape[1],
        count=data.shape[0],
        dtype=str(data.dtype),
        interleave=interleave,
    )
    if nodata is not None:
        profile["nodata"] = nodata
    if crs is not None:
        profile["crs"] = crs
        profile["transform"] = transform
    scale = 1000.0 if units.lower().startswith("micro") else 1.0
    with quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        dst.write(data)
        if wavelengths is not None:
            wl = ", ".join(f"{w / scale:.6f}" for w in wavelengths)
            dst.update_tags(ns="ENVI", wavelength="{" + wl + "}", wavelength_units=units)
    return str(path)


def write_gtiff(
    path, data, wavelengths=None, nodata=None, crs=None, transform=None, how="description"
):
    profile = dict(
        driver="GTiff",
        width=data.shape[2],
        height=data.shape[1],
        count=data.shape[0],
        dtype=str(data.dtype),
    )
    if nodata is not None:
        profile["nodata"] = nodata
    if crs is not None:
        profile.update(crs=crs, transform=transform)
    with quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        dst.write(data)
        if wavelengths is not None:
            for i, w in enumerate(wavelengths, start=1):
                if how == "description":
                    dst.set_band_description(i, f"{w:.2f} nm")
                else:
                    dst.update_tags(i, wavelength=f"{w:.3f}", wavelength_units="nm")
    return str(path)


UTM = "EPSG:32636"
TRANSFORM = from_origin(700000.0, 3500000.0, 1.5, 1.5)
