"""Sensor products: recognise the file an instrument or its processing chain writes, and
describe its VNIR and SWIR images so that every operation reads them as it reads ENVI/GeoTIFF.

A reader (one module per product) returns a :class:`Product`: one or two
:class:`SensorImage`, each with a ``source`` that GDAL opens (the product's own file, a
``/vsizip/`` path, or a VRT written by :mod:`.vrt` that exposes only the image lines, the
product's band order, its radiance scaling or its mask), plus wavelengths, FWHM, bad bands, a
dark reference and geolocation. ``recognise(path)`` tries each reader; anything it does not
recognise is opened by GDAL as before (:func:`geoboresight.io.open_dual`).

Readers take metadata only, never whole cubes. A reader that recognises a product but finds it
damaged raises :class:`~geoboresight.errors.InputError` naming the file and what is missing.
"""

from __future__ import annotations

import os
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


#: The files a user gives for each product, as a file dialog filters them (label, patterns):
#: offered beside GDAL's rasters by every VNIR/SWIR input (the QGIS plugin's file filter).
FILE_FORMATS = (
    ("ENVI header", "*.hdr"),
    ("Raw ENVI data (Specim)", "*.raw *.img *.bil *.dat"),
    ("HySpex", "*.hyspex"),
    ("EnMAP L1B (METADATA.XML or zip)", "*METADATA.XML *.zip"),
    ("PRISMA L1 (HDF5)", "*.he5 *.h5"),
)


def readers():
    """The product readers, most specific first: ``read(path) -> Product | None``."""
    from . import enmap, hyspex, prisma, specim

    return (hyspex.read, enmap.read, prisma.read, specim.read)


def recognise(path) -> Product | None:
    """The product ``path`` is, or None when no reader knows it (GDAL then opens it)."""
    path = os.fspath(path)
    for read in readers():
        product = read(path)
        if product is not None:
            return product
    return None


__all__ = ["FILE_FORMATS", "Geolocation", "Product", "SensorImage", "readers", "recognise"]
