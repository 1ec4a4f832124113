"""The one way in for every raster input: a path, a sensor product, an open rasterio dataset or
an opened dual-sensor dataset, read as the image it holds.

Every operation opens what the user gives through :func:`open_raster`, so a sensor product
(:mod:`geoboresight.io.products`) reads the same everywhere as ``ratio --vnir`` reads it: a
Specim capture's image lines only (dark frames, frame counter and zero pixel out), a HySpex
file's image after its header, an EnMAP L1B or PRISMA L1 product's VNIR bands then its SWIR
bands in radiance. Anything no product reader recognises is opened by GDAL as it is. As
rasterio's own functions do, an open rasterio dataset is taken where a path is (it is read
through its name, so it gives what its path gives), and a
:class:`~geoboresight.io.dual.DualSensor` from :func:`~geoboresight.io.open_dual` reads as its
VNIR bands then its SWIR bands.

A band is chosen by its number or by its wavelength (:func:`band_at`), the same way for every
input.
"""

from __future__ import annotations

import contextlib
import os
import threading
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from .envi import data_for_header
from .raster import open_raster as _open_file
from .wavelengths import good_bands, nearest_band, read_wavelengths

#: What a plain file is called when no sensor product reader recognises it.
GDAL_RASTER = "GDAL raster"


@dataclass(frozen=True)
class RasterImage:
    """The image a raster input holds: what GDAL opens for it (``source``) and, for a sensor
    product, its band centres (nm, one per band of ``source``), the bands it marks good and the
    units of its values."""

    path: str  # what the user gave, for messages
    source: str  # what GDAL opens
    kind: str = GDAL_RASTER  # the product recognised
    wavelengths: np.ndarray | None = None
    good: np.ndarray | None = None
    units: str = ""

    @property
    def is_product(self) -> bool:
        return self.kind != GDAL_RASTER


def dataset_path(value):
    """The name an open rasterio dataset was opened by (its path, or a GDAL ``/vsi`` path);
    any other value unchanged."""
    if isinstance(value, str | os.PathLike) or value is None:
        return value
    if all(hasattr(value, a) for a in ("read", "name", "mode", "count")):
        return value.name
    return value


_STACKS: dict[tuple[str, ...], str] = {}
_LOCK = threading.Lock()


def _stack(images: list[RasterImage], path: str, kind: str) -> RasterImage:
    """One image of several on one grid, their bands one after the other."""
    from .products._calibrated import stacked_vrt

    key = tuple(im.source for im in images)
    with _LOCK:
        if key not in _STACKS:
            _STACKS[key] = stacked_vrt(key, stem="stack")
    known = all(im.wavelengths is not None for im in images)
    units = {im.units for im in images}
    return RasterImage(
        path,
        _STACKS[key],
        kind,
        np.concatenate([im.wavelengths for im in images]) if known else None,
        np.concatenate([_good(im) for im in images]) if known else None,
        units.pop() if len(units) == 1 else "",
    )


def _good(image: RasterImage) -> np.ndarray:
    n = len(image.wavelengths)
    return np.ones(n, bool) if image.good is None else np.asarray(image.good, bool)


def raster_image(value, label: str = "raster") -> RasterImage:
    """The image ``value`` holds (a path, a sensor product, an open rasterio dataset or a
    :class:`~geoboresight.io.dual.DualSensor`); reads metadata only."""
    from .products import recognise

    if hasattr(value, "vnir") and hasattr(value, "swir") and hasattr(value, "files"):
        files = value.files
        if len(files) == 1:
            return raster_image(files[0], label)
        parts = [raster_image(f, label) for f in files]
        kinds = [p.kind for p in parts if p.is_product]
        return _stack(parts, " + ".join(files), " + ".join(kinds) or "dual-sensor dataset")
    path = dataset_path(value)
    if not isinstance(path, str | os.PathLike):
        raise InputError(f"{label}: expected a raster file or an open dataset, got {value!r:.80}")
    path = os.fspath(path)
    if path.startswith("/vsi") or not (os.path.isfile(path) or os.path.isdir(path)):
        return RasterImage(path, path)  # GDAL's virtual files; a missing file is named on open
    product = recognise(path)
    if product is None:
        data = data_for_header(path) if path.lower().endswith(".hdr") else None
        return RasterImage(path, data or path)  # GDAL opens an ENVI file by its data file
    images = [
        RasterImage(
            path, im.source, product.kind, np.asarray(im.wavelengths, float), im.good, im.units
        )
        for im in product.images
    ]
    return images[0] if len(images) == 1 else _stack(images, path, product.kind)


@contextlib.contextmanager
def open_raster(value, label: str = "raster"):
    """Open the image ``value`` holds (:func:`raster_image`) for reading, with clear errors
    when it is missing or unreadable; closed on leaving."""
    image = raster_image(value, label)
    where = label if not image.is_product else f"{label} {image.path} ({image.kind}):"
    with _open_file(image.source, where) as src:
        yield src


def band_count(value, label: str = "raster") -> int:
    """The number of bands of ``value``'s image."""
    with open_raster(value, label) as src:
        return src.count


def require_band(value, band: int, label: str = "raster", param: str = "band") -> None:
    """Raise :class:`ParameterError` naming ``param`` when ``value``'s image has no band
    ``band`` (1-based), or its sensor product marks that band bad (an unused slot, a band
    flagged by the processing chain: ``info`` lists them)."""
    image = raster_image(value, label)
    count = band_count(value, label)
    if band > count:
        raise ParameterError(
            f"parameter '{param}': band {band} does not exist in {image.path}, which has "
            f"{count} band(s)",
            params=(param,),
        )
    if image.is_product and image.good is not None and not image.good[band - 1]:
        good = np.flatnonzero(image.good) + 1
        raise ParameterError(
            f"parameter '{param}': band {band} of {image.path} is marked bad by the "
            f"{image.kind} product (an unused or flagged band; its good bands are "
            f"{_spans(good)}): choose a good band, or the band by its wavelength",
            params=(param,),
        )


def _spans(numbers) -> str:
    """``[1, 2, 3, 7]`` as ``1–3, 7``."""
    out, start = [], None
    for i, n in enumerate(numbers):
        if start is None:
            start = n
        if i + 1 == len(numbers) or numbers[i + 1] != n + 1:
            out.append(f"{start}" if start == n else f"{start}–{n}")
            start = None
    return ", ".join(out)


def band_at(
    value,
    band_nm: float,
    tolerance_nm: float = 10.0,
    label: str = "raster",
    param: str = "band_nm",
) -> int:
    """The 1-based band of ``value``'s image whose centre is nearest ``band_nm`` (within
    ``tolerance_nm``), among the bands the product or the ENVI ``bbl`` marks good.

    Raises :class:`ParameterError` naming ``param`` when the image has no band centres or none
    lies within the tolerance."""
    image = raster_image(value, label)
    wl, good = image.wavelengths, image.good
    if wl is None:
        with open_raster(value, label) as src:
            wl, _ = read_wavelengths(src)
            good = good_bands(src)
    if wl is None:
        raise ParameterError(
            f"parameter '{param}': {label} {image.path} states no band wavelengths: choose the "
            "band by its number instead",
            params=(param,),
        )
    good = np.ones(len(wl), bool) if good is None else np.asarray(good, bool)
    pick = np.flatnonzero(good)
    try:
        i = nearest_band(
            np.asarray(wl, float)[pick],
            band_nm,
            tolerance_nm,
            f"{label} {image.path}",
            "Choose a wavelength in that range, or the band by its number.",
        )
    except InputError as exc:
        raise ParameterError(f"parameter '{param}': {exc}", params=(param,)) from None
    return int(pick[i]) + 1


__all__ = [
    "GDAL_RASTER",
    "RasterImage",
    "band_at",
    "band_count",
    "dataset_path",
    "open_raster",
    "raster_image",
    "require_band",
]
