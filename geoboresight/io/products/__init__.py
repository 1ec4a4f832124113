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

from .base import Geolocation, Product, SensorImage

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
