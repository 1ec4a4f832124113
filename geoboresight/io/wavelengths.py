"""Band centre wavelengths: reading them from file metadata and choosing bands by wavelength.

Sources, in order (the first that gives one value per band wins):

1. ENVI header ``wavelength`` + ``wavelength units`` (GDAL's ``ENVI`` metadata domain);
2. per-band ``wavelength`` / ``wavelength_units`` tags (GDAL ENVI driver, many GeoTIFF writers);
3. GDAL's ``IMAGERY`` domain ``CENTRAL_WAVELENGTH_UM`` (GDAL >= 3.10);
4. band descriptions holding a number with a unit ("920 nm", "Band 12 (0.92 Micrometers)", "920.5").

Units are nanometres or micrometres; values below 100 without a unit are taken as micrometres.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import InputError

_NUMBER = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"
_UM_WORDS = ("micrometer", "micrometre", "micron", "um", "µm")


def unit_scale(units: str | None, values: np.ndarray | None = None) -> float:
    """Factor turning values in ``units`` into nanometres."""
    u = (units or "").strip().lower()
    if u.startswith(("nanomet", "nm")):
        return 1.0
    if u.startswith(_UM_WORDS):
        return 1000.0
    if u in ("", "unknown", "index") and values is not None and len(values):
        # No unit: a VNIR/SWIR sensor in µm has all centres below ~3; in nm above 300.
        return 1000.0 if np.nanmax(values) < 100 else 1.0
    if u.startswith(("millimet", "mm")):
        return 1.0e6
    raise InputError(f"unknown wavelength units {units!r}: use nanometers or micrometers")


def parse_list(text: str) -> np.ndarray:
    """Parse "{400.1, 402.3}" / "400,402" / "400 402" into a float array."""
    return np.array([float(v) for v in re.findall(_NUMBER, text)], dtype="float64")


def parse_user_wavelengths(text: str, count: int, path: str, units: str = "nm") -> np.ndarray:
    """Wavelengths typed by the user for a file without metadata, checked against its bands."""
    values = parse_list(text)
    if len(values) != count:
        raise InputError(
            f"{path} has {count} bands but {len(values)} wavelengths were given: give one "
            "wavelength (nm) per band, comma-separated"
        )
    return values * unit_scale(units, values)


def read_wavelengths(src) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(centres_nm, fwhm_nm) of an open rasterio dataset; None where the file has none."""
    n = src.count
    envi = src.tags(ns="ENVI") if "ENVI" in (src.tag_namespaces() or ()) else {}
    if "wavelength" in envi:
        wl = parse_list(envi["wavelength"])
        if len(wl) == n:
            scale = unit_scale(envi.get("wavelength_units"), wl)
            fw = parse_list(envi.get("fwhm", ""))
            return wl * scale, (fw * scale if len(fw) == n else None)
    band_tags = [src.tags(b) for b in range(1, n + 1)]
    if all("wavelength" in t for t in band_tags):
        try:
            wl = np.array([float(t["wavelength"]) for t in band_tags])
            units = band_tags[0].get("wavelength_units") or src.tags().get("wavelength_units")
            scale = unit_scale(units, wl)
            fw = None
            if all("fwhm" in t for t in band_tags):
                fw = np.array([float(t["fwhm"]) for t in band_tags]) * scale
            return wl * scale, fw
        except ValueError:
            pass
    imagery = []
    for b in range(1, n + 1):
        t = src.tags(b, ns="IMAGERY") if hasattr(src, "tags") else {}
        imagery.append(t.get("CENTRAL_WAVELENGTH_UM"))
    if all(v is not None for v in imagery):
        wl = np.array([float(v) for v in imagery]) * 1000.0
        fw = [src.tags(b, ns="IMAGERY").get("FWHM_UM") for b in range(1, n + 1)]
        fw = np.array([float(v) for v in fw]) * 1000.0 if all(v is not None for v in fw) else None
        return wl, fw
    desc = [d or "" for d in src.descriptions]
    parsed = [_from_description(d) for d in desc]
    if all(p is not None for p in parsed):
        wl = np.array([p[0] for p in parsed])
        scale = unit_scale(parsed[0][1], wl)
        return wl * scale, None
    return None, None


def wavelengths_of(
    src, path: str, user: str | None = None, option: str = "--wavelengths"
) -> tuple[np.ndarray, np.ndarray | None]:
    """(centres_nm, fwhm_nm or None) of an open dataset, or of the user's list ``user``.

    Raises :class:`InputError` naming the file and the option to use when it has none.
    """
    if user:
        return parse_user_wavelengths(user, src.count, path), None
    wl, fwhm = read_wavelengths(src)
    if wl is None:
        raise InputError(
            f"{path} has no wavelength metadata (no ENVI 'wavelength' list, band "
            "'wavelength' tags or band descriptions in nm): give the band centres in nm "
            f"({option} '400,402.5,...')"
        )
    return wl, fwhm


def _from_description(text: str):
    m = re.search(
        rf"({_NUMBER})\s*(nm|nanometers?|micrometers?|microns?|um|µm)?\s*\)?\s*$", text, re.I
    )
    if not m:
        return None
    if not m.group(2) and re.search(r"band\s*\d+\s*$", text, re.I):
        return None  # "Band 12" is an index, not a wavelength
    return float(m.group(1)), m.group(2)


def nearest_band(
    wavelengths_nm: np.ndarray, target_nm: float, tolerance_nm: float, path: str = "the raster"
) -> int:
    """0-based index of the band whose centre is nearest ``target_nm``.

    Raises :class:`InputError` naming the file and its wavelength range when no band centre lies
    within ``tolerance_nm``.
    """
    wl = np.asarray(wavelengths_nm, dtype="float64")
    if wl.size == 0:
        raise InputError(f"{path} has no bands")
    i = int(np.nanargmin(np.abs(wl - target_nm)))
    if abs(wl[i] - target_nm) > tolerance_nm:
        raise InputError(
            f"no band of {path} is within {tolerance_nm:g} nm of {target_nm:g} nm: its bands "
            f"cover {np.nanmin(wl):.1f}–{np.nanmax(wl):.1f} nm (nearest {wl[i]:.1f} nm). "
            "Choose a wavelength in that range or raise the tolerance."
        )
    return i


def format_wavelengths(values_nm, units: str = "Nanometers") -> str:
    """ENVI header list syntax: "{400.00, 402.50}"."""
    return "{" + ", ".join(f"{v:.3f}" for v in values_nm) + "}"
