"""Band centre wavelengths: reading them from file metadata and choosing bands by wavelength.

Sources, in order (the first that gives one value per band wins):

1. ENVI header ``wavelength`` + ``wavelength units`` (GDAL's ``ENVI`` metadata domain);
2. per-band ``wavelength`` / ``wavelength_units`` tags (GDAL ENVI driver, many GeoTIFF writers);
3. GDAL's ``IMAGERY`` domain ``CENTRAL_WAVELENGTH_UM`` (GDAL >= 3.10);
4. band descriptions holding a number with a unit ("920 nm", "Band 12 (0.92 Micrometers)", "920.5").

Units are nanometres or micrometres. Without a unit they are inferred only when unambiguous
(every centre between 0.3 and 2.6: micrometres; between 300 and 2600: nanometres); otherwise
the file is refused with its name and the header key to add. Every token of a list is parsed
strictly: a garbled entry ("5l0", "n/a") is named, never read as a different number.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..errors import InputError

_NUMBER = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"
_UM_WORDS = ("micrometer", "micrometre", "micron", "um", "µm")


#: Band centres (nm) of the sensors this package reads: VNIR+SWIR, with margin.
_NM_RANGE = (300.0, 2600.0)


def unit_scale(units: str | None, values: np.ndarray | None = None, where: str = "") -> float:
    """Factor turning values in ``units`` into nanometres (``where`` names the file in errors).

    Without a unit the values decide, when they can only be one: all within 0.3–2.6
    (micrometres) or all within 300–2600 (nanometres).
    """
    u = (units or "").strip().lower()
    at = f"{where}: " if where else ""
    if u.startswith(("nanomet", "nm")):
        return 1.0
    if u.startswith(_UM_WORDS):
        return 1000.0
    if u.startswith(("millimet", "mm")):
        return 1.0e6
    if u in ("", "unknown") and values is not None and len(values):
        lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
        if _NM_RANGE[0] / 1000 <= lo and hi <= _NM_RANGE[1] / 1000:
            return 1000.0
        if _NM_RANGE[0] <= lo and hi <= _NM_RANGE[1]:
            return 1.0
        raise InputError(
            f"{at}wavelengths {lo:g}–{hi:g} have no unit and could be nanometres or "
            "micrometres (or band numbers): add 'wavelength units = Nanometers' (or "
            "Micrometers) to the header, or give the band centres in nm"
        )
    raise InputError(
        f"{at}unknown wavelength units {units!r}: use Nanometers or Micrometers "
        "('wavelength units' in the ENVI header, 'wavelength_units' band tag)"
    )


def labelled_scale(units: str | None, values: np.ndarray, where: str, fix: str) -> float:
    """:func:`unit_scale` of band centres whose unit is stated, refused when the values
    contradict it: micrometres labelled nanometres (all within 0.3–2.6) would match no band,
    nanometres labelled micrometres (all within 300–2600) would be read as 300 µm and more.
    ``fix`` says how to correct the label."""
    scale = unit_scale(units, values, where)
    if len(values) and (units or "").strip():
        lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
        um = _NM_RANGE[0] / 1000 <= lo and hi <= _NM_RANGE[1] / 1000
        nm = _NM_RANGE[0] <= lo and hi <= _NM_RANGE[1]
        if (scale == 1.0 and um) or (scale == 1000.0 and nm):
            real = "micrometres" if um else "nanometres"
            raise InputError(
                f"{where}: wavelengths {lo:g}–{hi:g} are labelled {units!r} but are {real} "
                f"(VNIR and SWIR bands lie within 300–2600 nm): {fix}"
            )
    return scale


def parse_list(text: str, where: str = "wavelength list") -> np.ndarray:
    """Parse "{400.1, 402.3}" / "400,402" / "400 402" into a float array, strictly.

    Raises :class:`InputError` naming ``where`` and the offending token (e.g. ``5l0``,
    ``n/a``) or a non-finite value: a garbled list is never read as other numbers.
    """
    body = text.strip()
    if body.startswith("{") and body.endswith("}"):
        body = body[1:-1]
    tokens = [t for t in re.split(r"[,\s;]+", body) if t]
    values = []
    for i, token in enumerate(tokens, start=1):
        try:
            value = float(token)
        except ValueError:
            raise InputError(
                f"{where}: entry {i} {token!r} is not a number: fix the list (numbers "
                "separated by commas)"
            ) from None
        if not math.isfinite(value):
            raise InputError(f"{where}: entry {i} is {token!r}: every entry must be finite")
        values.append(value)
    return np.array(values, dtype="float64")


def parse_user_wavelengths(text: str, count: int, path: str, units: str = "nm") -> np.ndarray:
    """Wavelengths typed by the user for a file without metadata, checked against its bands."""
    values = parse_list(text, f"wavelengths given for {path}")
    if len(values) != count:
        raise InputError(
            f"{path} has {count} bands but {len(values)} wavelengths were given: give one "
            "wavelength (nm) per band, comma-separated"
        )
    return values * labelled_scale(units, values, path, "give them in nm")


def read_wavelengths(src) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(centres_nm, fwhm_nm) of an open rasterio dataset; None where the file has none."""
    n = src.count
    name = getattr(src, "name", "the raster")
    envi = src.tags(ns="ENVI") if "ENVI" in (src.tag_namespaces() or ()) else {}
    if "wavelength" in envi:
        wl = parse_list(envi["wavelength"], f"{name}: ENVI header 'wavelength'")
        if len(wl) != n:
            raise InputError(
                f"{name}: its header lists {len(wl)} wavelengths for {n} bands: fix the "
                "'wavelength' list (one centre per band)"
            )
        scale = labelled_scale(
            envi.get("wavelength_units"),
            wl,
            name,
            "fix the header's 'wavelength units' (Nanometers or Micrometers)",
        )
        fw = parse_list(envi.get("fwhm", ""), f"{name}: ENVI header 'fwhm'")
        return wl * scale, (fw * scale if len(fw) == n else None)
    band_tags = [src.tags(b) for b in range(1, n + 1)]
    if all("wavelength" in t for t in band_tags):
        wl = np.concatenate(
            [
                parse_list(t["wavelength"], f"{name}: band {b} tag 'wavelength'")
                for b, t in enumerate(band_tags, start=1)
            ]
        )
        if len(wl) != n:
            raise InputError(f"{name}: each band's 'wavelength' tag must hold one number")
        units = band_tags[0].get("wavelength_units") or src.tags().get("wavelength_units")
        scale = labelled_scale(
            units, wl, name, "fix the bands' 'wavelength_units' tag (Nanometers or Micrometers)"
        )
        fw = None
        if all("fwhm" in t for t in band_tags):
            fw = np.concatenate(
                [
                    parse_list(t["fwhm"], f"{name}: band {b} tag 'fwhm'")
                    for b, t in enumerate(band_tags, start=1)
                ]
            )
            fw = fw * scale if len(fw) == n else None
        return wl * scale, fw
    imagery = []
    for b in range(1, n + 1):
        t = src.tags(b, ns="IMAGERY") if hasattr(src, "tags") else {}
        imagery.append(t.get("CENTRAL_WAVELENGTH_UM"))
    if all(v is not None for v in imagery):
        wl = parse_list(",".join(imagery), f"{name}: IMAGERY CENTRAL_WAVELENGTH_UM") * 1000.0
        fw = [src.tags(b, ns="IMAGERY").get("FWHM_UM") for b in range(1, n + 1)]
        if all(v is not None for v in fw):
            fw = parse_list(",".join(fw), f"{name}: IMAGERY FWHM_UM") * 1000.0
        else:
            fw = None
        return wl, fw
    desc = [d or "" for d in src.descriptions]
    parsed = [_from_description(d) for d in desc]
    if all(p is not None for p in parsed):
        wl = np.array([p[0] for p in parsed])
        units = {_unit_kind(p[1]) for p in parsed}
        if len(units) > 1:
            raise InputError(
                f"{name}: its band descriptions mix wavelength units ({', '.join(desc[:3])}, "
                "...): give the band centres in nm"
            )
        scale = unit_scale(parsed[0][1], wl, f"{name} (band descriptions)")
        return wl * scale, None
    return None, None


def good_bands(src) -> np.ndarray:
    """True for each band the ENVI header's ``bbl`` (bad-band list: 1 good, 0 bad) keeps; all
    True without one. Bad bands (detector edges, water vapour, dead bands flagged by the
    processing chain) are never picked for the ratio, matching or spectral work."""
    n = src.count
    envi = src.tags(ns="ENVI") if "ENVI" in (src.tag_namespaces() or ()) else {}
    if "bbl" not in envi:
        return np.ones(n, bool)
    name = getattr(src, "name", "the raster")
    flags = parse_list(envi["bbl"], f"{name}: ENVI header 'bbl'")
    if len(flags) != n or not np.isin(flags, (0, 1)).all():
        raise InputError(
            f"{name}: its header's 'bbl' (bad-band list) must hold one 0 (bad) or 1 (good) per "
            f"band, {n} in all; it has {len(flags)} values: fix or remove the 'bbl' line"
        )
    return flags.astype(bool)


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


def _unit_kind(unit: str | None) -> str:
    u = (unit or "").lower()
    return "nm" if u.startswith(("nm", "nano")) else ("um" if u else "")


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
    wavelengths_nm: np.ndarray,
    target_nm: float,
    tolerance_nm: float,
    path: str = "the raster",
    fix: str = "Choose a wavelength in that range or raise the tolerance.",
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
            f"cover {np.nanmin(wl):.1f}–{np.nanmax(wl):.1f} nm (nearest {wl[i]:.1f} nm). " + fix
        )
    return i


def format_wavelengths(values_nm, units: str = "Nanometers") -> str:
    """ENVI header list syntax: "{400.00, 402.50}"."""
    return "{" + ", ".join(f"{v:.3f}" for v in values_nm) + "}"
