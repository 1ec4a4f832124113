"""ENVI headers: the keys of a ``.hdr``, the data file beside it, and the byte layout of an
uncompressed ENVI file (for the raw strip reader of :mod:`geoboresight.io.cube` and the size
check of :func:`geoboresight.io.raster.check_raw_size`).

Only the standard library and NumPy: both the raster and the cube modules import this one, and
it imports neither.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

import numpy as np

#: NumPy types of ENVI's "data type" codes.
ENVI_DTYPES = {1: "u1", 2: "i2", 3: "i4", 4: "f4", 5: "f8", 12: "u2", 13: "u4", 14: "i8", 15: "u8"}

#: Extensions an ENVI data file takes beside its header ("scene.hdr" + "scene", "scene.img" ...).
DATA_EXTENSIONS = ("", ".img", ".dat", ".raw", ".bsq", ".bil", ".bip")


@dataclass(frozen=True)
class RawLayout:
    """Where the values of an uncompressed ENVI file sit: ``file`` from byte ``offset`` on, in
    ``interleave`` order ('bsq', 'bil' or 'bip'), each a ``dtype`` (with its byte order)."""

    file: str
    offset: int
    interleave: str
    dtype: np.dtype


def envi_header(data_path: str) -> dict | None:
    """The keys of the ENVI header beside ``data_path`` (lower-case names, raw text values),
    or None when there is none."""
    stem = os.path.splitext(data_path)[0]
    for hdr in (data_path + ".hdr", stem + ".hdr"):
        if os.path.isfile(hdr):
            break
    else:
        return None
    with open(hdr, encoding="utf-8", errors="replace") as f:
        text = f.read()
    if not text.lstrip().upper().startswith("ENVI"):
        return None
    text = re.sub(r"\{[^}]*\}", lambda m: m.group(0).replace("\n", " "), text)
    keys = {}
    for line in text.splitlines():
        if "=" in line:
            k, v = line.split("=", 1)
            keys[k.strip().lower()] = v.strip()
    return keys


def is_compressed(keys: dict) -> bool:
    """True when the header announces a compressed data file (no raw layout then)."""
    return keys.get("file compression", "0").strip() not in ("", "0")


def header_dtype(keys: dict) -> np.dtype | None:
    """The NumPy type (with byte order) of the header's "data type", or None when unknown."""
    try:
        code = int(keys["data type"])
        big = int(keys.get("byte order", "0")) == 1
    except (KeyError, ValueError):
        return None
    if code not in ENVI_DTYPES:
        return None
    return np.dtype(ENVI_DTYPES[code]).newbyteorder(">" if big else "<")


def data_for_header(hdr: str) -> str | None:
    """The data file beside the ENVI header ``hdr`` (``.hdr`` removed, then the usual
    extensions), or None."""
    stem = hdr[:-4]
    for ext in DATA_EXTENSIONS:
        if os.path.isfile(stem + ext):
            return stem + ext
    return None


def raw_layout(data_path: str, count: int, height: int, width: int) -> RawLayout | None:
    """The byte layout of the uncompressed ENVI file ``data_path`` holding ``count`` bands of
    ``height`` × ``width``, or None (no header, compressed, unknown type or interleave, or a
    file shorter than the header says): such files are read through GDAL."""
    keys = envi_header(data_path)
    if keys is None or is_compressed(keys):
        return None
    dtype = header_dtype(keys)
    try:
        interleave = keys.get("interleave", "bsq").strip().lower()
        offset = int(keys.get("header offset", "0"))
    except ValueError:
        return None
    if dtype is None or interleave not in ("bsq", "bil", "bip"):
        return None
    expected = offset + count * height * width * dtype.itemsize
    if os.path.getsize(data_path) < expected:
        return None
    return RawLayout(data_path, offset, interleave, dtype)
