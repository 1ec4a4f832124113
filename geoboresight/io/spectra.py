"""Spectral libraries: endmember spectra from a CSV table or an ENVI spectral library (.sli).

The unmixing kernel (:mod:`geoboresight.anomaly.unmix`) takes the spectra as arrays; reading
them from files lives here.
"""

from __future__ import annotations

import csv
import os

import numpy as np

from ..errors import InputError
from .cube import ENVI_DTYPES, envi_header
from .wavelengths import parse_list, unit_scale

#: CSV columns holding the library's band widths, not a material.
_FWHM_COLUMNS = ("fwhm", "fwhm_nm")


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
    if wl.max() < 100:
        wl = wl * 1000.0
    return wl, spectra, names


def _read_csv(path):
    with open(path, newline="", encoding="utf-8-sig") as f:
        rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    if len(rows) < 3 or len(rows[0]) < 2:
        raise InputError(
            f"endmember CSV {path}: expected a header row, then one row per wavelength with "
            "the wavelength (nm) first and one reflectance column per endmember"
        )
    names = [c.strip() for c in rows[0][1:]]
    try:
        data = np.array([[float(c) for c in r[: len(names) + 1]] for r in rows[1:]])
    except ValueError as exc:
        raise InputError(f"endmember CSV {path}: non-numeric value ({exc})") from None
    keep = [i for i, n in enumerate(names) if n.lower() not in _FWHM_COLUMNS]
    if not keep:
        raise InputError(f"endmember CSV {path}: no endmember column after the wavelength")
    return data[:, 0], data[:, 1:][:, keep].T.copy(), [names[i] for i in keep]


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
