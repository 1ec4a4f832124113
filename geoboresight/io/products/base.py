"""The values a product reader returns (:mod:`geoboresight.io.products`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SensorImage:
    """One detector's image in a product, as GDAL will read it.

    ``wavelengths``, ``fwhm``, ``good``, ``gains`` and ``offsets`` have one entry per band of
    ``source`` (band 1 first). ``dark`` is the dark level per band and column, shape
    ``(bands, width)``, in the units ``source`` is read in, or None; ``dark_source`` says where
    it came from ("frames", "DARKREF file", "background matrix", ...).
    """

    name: str  # "VNIR", "SWIR", or "cube" (both detectors in one file, split at the seam)
    source: str  # what GDAL opens
    wavelengths: np.ndarray
    fwhm: np.ndarray | None = None
    good: np.ndarray | None = None
    nodata: float | None = None
    #: What the values read are: "DN" (raw counts) or e.g. "radiance (W m-2 sr-1 um-1)".
    units: str = "DN"
    #: The product's radiance calibration, radiance = gain * value + offset, when ``source``
    #: is still in DN; None when ``source`` already gives radiance or there is none.
    gains: np.ndarray | None = None
    offsets: np.ndarray | None = None
    dark: np.ndarray | None = None
    dark_source: str = ""


@dataclass(frozen=True)
class Geolocation:
    """Per-pixel map coordinates of the raw grid: ``x``/``y`` are single-band rasters GDAL
    opens (longitude/easting and latitude/northing), in ``crs``."""

    x: str
    y: str
    crs: str
    x_band: int = 1
    y_band: int = 1
    source: str = ""  # e.g. "PRISMA Latitude_VNIR/Longitude_VNIR"


@dataclass(frozen=True)
class Product:
    """A recognised sensor product: what ``open_dual`` and ``geoboresight info`` report."""

    kind: str  # "Specim raw ENVI", "HySpex", "EnMAP L1B", "PRISMA L1"
    path: str  # what the user gave
    images: tuple[SensorImage, ...]
    geolocation: Geolocation | None = None
    notes: tuple[str, ...] = field(default=())

    def image(self, name: str) -> SensorImage | None:
        for im in self.images:
            if im.name == name:
                return im
        return None


__all__ = ["Geolocation", "Product", "SensorImage"]
