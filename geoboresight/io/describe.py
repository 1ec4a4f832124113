"""What a flight line is, as ``geoboresight info`` reports it (as ``gdalinfo`` / ``rio info`` do
for a raster): the sensor product recognised, each detector's image (size, interleave, data
type, units, wavelengths, bad bands, dark reference), the two bands the boresight ratio would
use, the geolocation found and the reader's notes.

Metadata only: no pixel is read, beyond a product reader's own dark reference.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import xml.etree.ElementTree as ET

import numpy as np

from ..errors import InputError
from .dual import BandChoice, DualLayout, open_dual
from .image import GDAL_RASTER
from .raster import open_raster, quiet_georef
from .wavelengths import good_bands, read_wavelengths

#: GDAL's IMAGE_STRUCTURE INTERLEAVE, in the ENVI words a hyperspectral user knows.
_INTERLEAVE = {"BAND": "BSQ", "LINE": "BIL", "PIXEL": "BIP"}


def describe_product(
    vnir, swir=None, layout: DualLayout = DualLayout(), bands: BandChoice = BandChoice()
) -> dict:
    """Describe a flight line: one file, folder or zip (a merged cube or a product holding both
    detectors) or a VNIR and a SWIR file.

    Returns a JSON-ready dict: the summary (``product``, ``lines``, ``samples``,
    ``vnir_bands``, ``swir_bands``, the ratio's ``vnir_band``/``vnir_wavelength_nm``/
    ``swir_band``/``swir_wavelength_nm``, ``dark_source``), then ``files`` (per file: its
    product, images, geolocation and notes) and ``ratio_error`` when the ratio's bands cannot
    be found (the reason, as the ratio would say it). Raises :class:`InputError` only when a
    file cannot be read at all.
    """
    paths = [os.fspath(vnir)] + ([os.fspath(swir)] if swir else [])
    labels = ["VNIR", "SWIR"] if swir else ["input"]
    cals = [layout.vnir_calibration, layout.swir_calibration]
    files = [
        _describe_file(p, label, cal) for p, label, cal in zip(paths, labels, cals, strict=False)
    ]
    kinds = list(dict.fromkeys(f["product"] for f in files))
    out = {
        "product": " + ".join(kinds),
        "lines": files[0]["images"][0]["lines"],
        "samples": files[0]["images"][0]["samples"],
        "vnir_bands": None,
        "swir_bands": None,
        "vnir_band": None,
        "vnir_wavelength_nm": None,
        "swir_band": None,
        "swir_wavelength_nm": None,
        "dark_source": "",
        "files": files,
    }
    try:
        dual = open_dual(
            paths[0], paths[1] if swir else None, *_layout_args(layout)
        )  # the split the operations make
        out["vnir_bands"], out["swir_bands"] = len(dual.vnir.bands), len(dual.swir.bands)
        out["arrangement"] = (
            "merged cube"
            if dual.merged
            else ("product" if dual.product and not swir else "two files")
        )
        darks = {d for d in (dual.vnir.dark_source, dual.swir.dark_source) if d}
        out["dark_source"] = ", ".join(sorted(darks))
        chosen = dual.ratio_bands(bands)
        out.update(
            vnir_band=chosen.vnir_band,
            vnir_wavelength_nm=round(chosen.vnir_nm, 3),
            swir_band=chosen.swir_band,
            swir_wavelength_nm=round(chosen.swir_nm, 3),
        )
    except InputError as exc:
        out["ratio_error"] = " ".join(str(exc).split())
    return out


def _layout_args(layout: DualLayout) -> tuple:
    return (
        layout.seam_nm,
        layout.vnir_wavelengths,
        layout.swir_wavelengths,
        layout.vnir_calibration,
        layout.swir_calibration,
    )


def _describe_file(path: str, label: str, calibration=None) -> dict:
    from .products import recognise
    from .radiance import radiance_image, radiometry

    product = recognise(path)
    param = "swir_calibration" if label == "SWIR" else "vnir_calibration"
    values = radiometry(path, calibration, param) if product is not None else None
    if values is not None and values["values"] != "DN":
        image = radiance_image(path, calibration, param)[0]
        product = dataclasses.replace(product, images=(image,))
    if product is None:
        with open_raster(path, label) as src:
            wl, _ = read_wavelengths(src)
            good = good_bands(src)
            image = {
                "name": "cube",
                **_storage(path),
                "units": src.units[0] if src.units and src.units[0] else "not stated",
                **_wavelengths(wl, good),
                "nodata": src.nodata,
                "dark_source": "",
            }
            geo = _grid_geolocation(src)
        return {
            "path": path,
            "product": GDAL_RASTER,
            "images": [image],
            "geolocation": geo,
            "notes": [],
        }
    images = []
    for im in product.images:
        entry = {
            "name": im.name,
            **({} if _temporary(im.source) else {"source": im.source}),
            **_storage(im.source),
            "units": im.units,
            **_wavelengths(im.wavelengths, im.good),
            "nodata": im.nodata,
            "dark_source": im.dark_source,
        }
        if im.dark is not None:
            dark = np.asarray(im.dark, float)
            finite = dark[np.isfinite(dark)]
            entry["dark"] = {
                "bands": int(dark.shape[0]),
                "columns": int(dark.shape[-1]),
                "mean": round(float(finite.mean()), 3) if finite.size else None,
            }
        images.append(entry)
    geo = None
    if product.geolocation is not None:
        g = product.geolocation
        with open_raster(g.x, f"{product.kind} geolocation") as src:
            size = {"lines": src.height, "samples": src.width}
        geo = {"kind": g.source or "per-pixel coordinates", "crs": g.crs, **size}
    notes = list(product.notes)
    if len(images) > 1:
        # How an operation that takes any raster (stats, geolocate, ...) numbers the bands.
        spans, start = [], 1
        for im in images:
            spans.append(f"{start}–{start + im['band_count'] - 1} {im['name']}")
            start += im["band_count"]
        notes.append(f"read as one raster (stats, geolocate, ...): bands {', '.join(spans)}")
    return {
        "path": path,
        "product": product.kind,
        "images": images,
        "geolocation": geo,
        "notes": notes,
        **({"radiometry": values} if values is not None else {}),
    }


def _temporary(source: str) -> bool:
    """A VRT the reader wrote for this process only (gone when it ends): not worth reporting."""
    from .products.vrt import _folder

    return os.path.dirname(os.path.abspath(source)) == _folder()


def _wavelengths(wl, good) -> dict:
    if wl is None:
        return {
            "bands": None,
            "wavelength_min_nm": None,
            "wavelength_max_nm": None,
            "bad_bands": [],
        }
    wl = np.asarray(wl, float)
    n = wl.size
    good = np.ones(n, bool) if good is None else np.asarray(good, bool)
    used = wl[good] if good.any() else wl  # a product's unused slots (centre 0) left out
    return {
        "bands": int(n),
        "wavelength_min_nm": round(float(used.min()), 3),
        "wavelength_max_nm": round(float(used.max()), 3),
        "bad_bands": [int(i) + 1 for i in np.flatnonzero(~good)],
    }


def _storage(source: str, depth: int = 0) -> dict:
    """Size, interleave and data type of what GDAL opens for an image, and the data type and
    interleave of the file it is stored in (through a product's VRT: a raw layout's offsets,
    else the file its first source names)."""
    with _open(source) as src:
        out = {
            "lines": src.height,
            "samples": src.width,
            "band_count": src.count,
            "dtype": src.dtypes[0],
            "driver": src.driver,
        }
        structure = src.tags(ns="IMAGE_STRUCTURE").get("INTERLEAVE", "")
        out["interleave"] = _INTERLEAVE.get(structure.upper(), structure or "unknown")
    if out["driver"] != "VRT" or depth > 3 or not os.path.isfile(source):
        return out
    stored = _vrt_storage(source, depth)
    if stored:
        out["interleave"] = stored.get("interleave", out["interleave"])
        if stored.get("dtype") and stored["dtype"] != out["dtype"]:
            out["stored_dtype"] = stored["dtype"]
    return out


@contextlib.contextmanager
def _open(source: str):
    """Open an image's source: a file (with open_raster's messages) or a GDAL /vsi path."""
    if source.startswith("/vsi"):
        import rasterio

        with quiet_georef(), rasterio.open(source) as src:
            yield src
    else:
        with open_raster(source, "image") as src:
            yield src


def _vrt_storage(source: str, depth: int) -> dict | None:
    try:
        root = ET.parse(source).getroot()
    except (OSError, ET.ParseError):
        return None
    bands = root.findall("VRTRasterBand")
    if not bands:
        return None
    first = bands[0]
    if first.get("subClass") == "VRTRawRasterBand":
        dtype = _GDAL_DTYPES.get(first.get("dataType", ""), first.get("dataType", "").lower())
        size = np.dtype(dtype).itemsize if dtype in _GDAL_DTYPES.values() else 0
        samples = int(root.get("rasterXSize", "0"))
        pixel = int(first.findtext("PixelOffset") or 0)
        line = int(first.findtext("LineOffset") or 0)
        count = len(bands)
        if size and pixel == size * count:
            inter = "BIP"
        elif size and pixel == size and line >= size * samples * count and count > 1:
            inter = "BIL"
        else:
            inter = "BSQ"
        return {"interleave": inter, "dtype": dtype}
    name = first.find(".//SourceFilename")
    if name is None or not name.text:
        return None
    inner = name.text
    if name.get("relativeToVRT", name.get("relativetoVRT")) == "1":
        inner = os.path.join(os.path.dirname(source), inner)
    try:
        stored = _storage(inner, depth + 1)
    except (InputError, OSError):
        return None
    return {
        "interleave": stored["interleave"],
        "dtype": stored.get("stored_dtype", stored["dtype"]),
    }


_GDAL_DTYPES = {
    "Byte": "uint8",
    "Int8": "int8",
    "UInt16": "uint16",
    "Int16": "int16",
    "UInt32": "uint32",
    "Int32": "int32",
    "Float32": "float32",
    "Float64": "float64",
}


def _grid_geolocation(src) -> dict | None:
    """A plain raster's map grid (CRS and pixel size), or None in raw sensor geometry."""
    from .grid import Grid

    grid = Grid.of(src)
    if not grid.georeferenced:
        return None
    t = grid.transform
    return {
        "kind": "map grid (geotransform)",
        "crs": grid.crs.to_string() if grid.crs is not None else None,
        "lines": grid.height,
        "samples": grid.width,
        "pixel_size": [abs(t.a), abs(t.e)],
    }


def format_description(d: dict) -> str:
    """The description as lines a person reads (what ``geoboresight info`` prints)."""
    lines = [f"Product: {d['product']}"]
    if d.get("arrangement"):
        lines[0] += f" ({d['arrangement']})"
    lines.append(f"Size: {d['lines']} lines × {d['samples']} samples")
    for f in d["files"]:
        lines.append("")
        lines.append(f"File: {f['path']} ({f['product']})")
        for im in f["images"]:
            wl = (
                f"{im['wavelength_min_nm']:.1f}–{im['wavelength_max_nm']:.1f} nm"
                if im["wavelength_min_nm"] is not None
                else "no wavelengths"
            )
            stored = f", stored {im['stored_dtype']}" if im.get("stored_dtype") else ""
            lines.append(
                f"  {im['name']}: {im['lines']} lines × {im['samples']} samples × "
                f"{im['band_count']} bands, {im['interleave']}, {im['dtype']}{stored}, "
                f"{im['units']}"
            )
            bad = im["bad_bands"]
            lines.append(
                f"    wavelengths {wl} ({im['bands'] or 0} bands, range of the good ones); bad bands: "
                + (_ranges(bad) if bad else "none")
            )
            if im.get("dark"):
                dk = im["dark"]
                lines.append(
                    f"    dark reference: {im['dark_source']} ({dk['bands']} bands × "
                    f"{dk['columns']} columns, mean {dk['mean']})"
                )
            else:
                lines.append("    dark reference: none")
        geo = f["geolocation"]
        if geo is None:
            lines.append("  geolocation: none (raw sensor geometry)")
        else:
            lines.append(
                f"  geolocation: {geo['kind']}, {geo['crs'] or 'no CRS'}, "
                f"{geo['lines']} lines × {geo['samples']} samples"
            )
        for key, value in (f.get("radiometry") or {}).items():
            lines.append(f"  {key.replace('_', ' ')}: {value}")
        for note in f["notes"]:
            lines.append(f"  note: {note}")
    lines.append("")
    if d.get("ratio_error"):
        lines.append(f"Boresight ratio: not possible as given: {d['ratio_error']}")
    else:
        lines.append(
            f"Sensors: VNIR {d['vnir_bands']} bands, SWIR {d['swir_bands']} bands (bad bands left out)"
        )
        lines.append(
            f"Boresight ratio: SWIR band {d['swir_band']} ({d['swir_wavelength_nm']:.1f} nm) / "
            f"VNIR band {d['vnir_band']} ({d['vnir_wavelength_nm']:.1f} nm)"
        )
        lines.append(f"Dark reference: {d['dark_source'] or 'none'}")
    return "\n".join(lines)


def _ranges(numbers: list[int]) -> str:
    """``[1, 2, 3, 7]`` as ``1-3, 7``."""
    parts, start, prev = [], None, None
    for n in numbers:
        if start is None:
            start = prev = n
        elif n == prev + 1:
            prev = n
        else:
            parts.append(f"{start}" if start == prev else f"{start}-{prev}")
            start = prev = n
    if start is not None:
        parts.append(f"{start}" if start == prev else f"{start}-{prev}")
    return ", ".join(parts)


__all__ = ["GDAL_RASTER", "describe_product", "format_description"]
