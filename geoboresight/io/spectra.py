"""Spectral libraries: endmember spectra from a CSV table or an ENVI spectral library (.sli).

The unmixing kernel (:mod:`geoboresight.anomaly.unmix`) takes the spectra as arrays; reading
them from files lives here.
"""

from __future__ import annotations

import csv
import os

import numpy as np

from ..errors import InputError
from .envi import ENVI_DTYPES, envi_header
from .wavelengths import parse_list, unit_scale

#: CSV columns holding the library's band widths, not a material.
_FWHM_COLUMNS = ("fwhm",)


def read_spectral_library(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(wavelengths_nm (w,), spectra (N, w), names) of a CSV table or an ENVI spectral library.

    CSV: a header row, the first column the wavelength (nm, or µm when all values are < 100),
    one column per endmember (e.g. the simulator's ``endmembers.csv``); a ``fwhm_nm`` column
    is the library's band width, not a material. ENVI: ``.sli`` + ``.hdr`` (either may be
    given), with ``wavelength`` and ``spectra names``. Wavelengths come back sorted, in nm.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"endmember library {path} does not exist: check the path")
    low = path.lower()
    if low.endswith(".csv") or low.endswith(".txt"):
        wl, spectra, names = _read_csv(path)
    else:
        wl, spectra, names = _read_sli(path)
    if wl.size < 2 or not np.all(np.diff(wl) > 0):
        order = np.argsort(wl)
        wl, spectra = wl[order], spectra[:, order]
        if np.any(np.diff(wl) <= 0):
            raise InputError(f"endmember library {path}: wavelengths must be distinct")
    return wl, spectra, names


def _column_unit(name: str) -> str:
    """The unit a column header declares: 'nm', 'um' or '' (none)."""
    low = name.strip().lower().replace("µ", "u").replace("μ", "u")
    for unit in ("nm", "um", "micrometer", "micrometre", "micron", "nanomet"):
        if unit in low.replace("wavelength", "").replace("fwhm", ""):
            return "nm" if unit in ("nm", "nanomet") else "um"
    return ""


def _read_csv(path):
    """The endmember table's schema: a header row naming the columns; first the wavelength
    (``wavelength``, optionally with its unit: ``wavelength_nm``, ``wavelength (um)``), then
    optional band widths (``fwhm``, ``fwhm_nm``), then one column of reflectance per material,
    each with a distinct name. A unit in the header must agree with the values; without one,
    the values decide only where they can be one unit alone (300–2600 nm or 0.3–2.6 µm)."""
    with open(path, newline="", encoding="utf-8-sig") as f:
        rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    if len(rows) < 3 or len(rows[0]) < 2:
        raise InputError(
            f"endmember CSV {path}: expected a header row, then one row per wavelength with "
            "the wavelength (nm) first and one reflectance column per endmember"
        )
    header = [c.strip() for c in rows[0]]
    if not any(w in header[0].lower() for w in ("wave", "wl", "lambda")):
        raise InputError(
            f"endmember CSV {path}: the first column is {header[0]!r}; it must be the "
            "wavelength (name it e.g. 'wavelength_nm'), followed by one column per material"
        )
    names = header[1:]
    for i, r in enumerate(rows[1:], start=2):
        if len(r) < len(header):
            raise InputError(
                f"endmember CSV {path}, line {i}: {len(r)} value(s) for {len(header)} columns"
            )
    try:
        data = np.array([[float(c) for c in r[: len(header)]] for r in rows[1:]])
    except ValueError as exc:
        raise InputError(f"endmember CSV {path}: non-numeric value ({exc})") from None
    if not np.isfinite(data).all():
        raise InputError(f"endmember CSV {path}: NaN or infinite values; fill or remove them")
    keep = [i for i, n in enumerate(names) if n.lower().split("_")[0] not in _FWHM_COLUMNS]
    chosen = [names[i] for i in keep]
    if not keep:
        raise InputError(f"endmember CSV {path}: no endmember column after the wavelength")
    if any(not n for n in chosen) or len(set(chosen)) != len(chosen):
        raise InputError(
            f"endmember CSV {path}: material columns need distinct, non-empty names "
            f"(got {', '.join(repr(n) for n in chosen)})"
        )
    wl = data[:, 0]
    declared = _column_unit(header[0])
    scale = unit_scale(declared, wl, f"endmember CSV {path}")
    nm = wl * scale
    if declared and not (300.0 <= nm.min() and nm.max() <= 2600.0):
        raise InputError(
            f"endmember CSV {path}: the header says {header[0]!r} but the values "
            f"{wl.min():g}–{wl.max():g} are not VNIR/SWIR wavelengths in that unit; fix the "
            "header's unit (nm or um) or the values"
        )
    return nm, data[:, 1:][:, keep].T.copy(), chosen


def _read_sli(path):
    stem = os.path.splitext(path)[0]
    hdr = path if path.lower().endswith(".hdr") else stem + ".hdr"
    if not os.path.exists(hdr):
        raise InputError(f"ENVI spectral library {path}: header {hdr} not found")
    data_path = None
    for ext in (".sli", ".esl", ".dat", ".img", ""):
        if os.path.isfile(stem + ext) and not (stem + ext).lower().endswith(".hdr"):
            data_path = stem + ext
            break
    keys = envi_header(data_path or stem)
    if keys is None or data_path is None:
        raise InputError(f"ENVI spectral library {path}: could not find the header and data file")
    try:
        samples, lines = int(keys["samples"]), int(keys["lines"])
        code = int(keys["data type"])
        offset = int(keys.get("header offset", "0"))
        big = int(keys.get("byte order", "0")) == 1
    except (KeyError, ValueError) as exc:
        raise InputError(f"ENVI spectral library {hdr}: missing header key {exc}") from None
    if code not in ENVI_DTYPES:
        raise InputError(f"ENVI spectral library {hdr}: unsupported data type {code}")
    dt = np.dtype(ENVI_DTYPES[code]).newbyteorder(">" if big else "<")
    spectra = np.fromfile(data_path, dtype=dt, count=samples * lines, offset=offset)
    if spectra.size != samples * lines:
        raise InputError(
            f"ENVI spectral library {data_path} holds {spectra.size} values, its header "
            f"announces {lines} spectra × {samples} samples"
        )
    spectra = spectra.reshape(lines, samples).astype(np.float64)
    wl_text = keys.get("wavelength")
    if not wl_text:
        raise InputError(f"ENVI spectral library {hdr} has no 'wavelength' list")
    wl = parse_list(wl_text)
    wl = wl * unit_scale(keys.get("wavelength units"), wl)
    names_text = keys.get("spectra names", "")
    names = [s.strip() for s in names_text.strip("{} ").split(",")] if names_text else []
    if len(names) != lines:
        names = [f"spectrum {i + 1}" for i in range(lines)]
    scale = float(keys.get("reflectance scale factor", "1") or 1)
    return wl, spectra / scale, names
