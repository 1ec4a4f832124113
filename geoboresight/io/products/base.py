"""The values a product reader returns (:mod:`geoboresight.io.products`)."""

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


@dataclass(frozen=True, eq=False)
class RawCapture:
    """Where a raw capture's DN come from, as its reader found them: what turns them into
    radiance reads this, never the user's path again.

    ``header`` is the file whose keys describe the capture (a Specim ENVI header, or the
    ``.hyspex`` file itself), ``keys`` its ENVI keys (None for HySpex), ``layout`` the byte
    layout of the whole data file (a Specim capture's dark lines included), ``lines`` its image
    lines and ``dark_file`` the dark reference beside it (a Specim ``DARKREF_`` header), or None.
    """

    header: str
    keys: dict | None
    layout: object  # a :class:`._raw.RawCube`
    lines: int
    dark_file: str | None = None


@dataclass(frozen=True)
class Product:
    """A recognised sensor product: what ``open_dual`` and ``geoboresight info`` report."""

    kind: str  # "Specim raw ENVI", "HySpex", "EnMAP L1B", "PRISMA L1"
    path: str  # what the user gave
    images: tuple[SensorImage, ...]
    geolocation: Geolocation | None = None
    notes: tuple[str, ...] = field(default=())
    #: Why a product that can carry geolocation carries none here (as ``info`` states it), or "".
    geolocation_problem: str = ""
    #: The raw capture behind the image (Specim raw ENVI, HySpex), or None.
    capture: RawCapture | None = None

    def image(self, name: str) -> SensorImage | None:
        for im in self.images:
            if im.name == name:
                return im
        return None


#: Products already read in this process, by file identity: a product is read once however
#: many times the operations of a run open it (a chunked cube is unpacked once).
_READ: dict[tuple, Product] = {}


def read_once(container: str, extra, read) -> Product | None:
    """``read()``'s product, kept while ``container`` (the file whose identity stands for the
    product) keeps its path, size and modification time; ``extra`` tells apart several
    products read from one container. None (not kept) when ``read()`` finds no product."""
    st = os.stat(container)
    key = (os.path.realpath(container), st.st_mtime_ns, st.st_size, extra)
    if key not in _READ:
        product = read()
        if product is None:
            return None
        _READ[key] = product
    return _READ[key]


__all__ = ["Geolocation", "Product", "RawCapture", "SensorImage", "read_once"]
