"""HySpex ``.hyspex`` (NEO; e.g. VNIR-1800, SWIR-384): a binary header, then raw DN.

The layout, checked field by field against two independent readers, EnSpec/hypro
``src/hypro/Radiometry.py`` (``make_radio_cali_file_Hyspex``) and NEO's MATLAB
``readHyspexHdr.m`` (Trond Løke / Pesal Koirala, in AqsaHassan/High-dynamic-hyperspectral-
imaging); little-endian throughout:

=========  ===========================  ==========================================
byte       field                        type
=========  ===========================  ==========================================
0          magic ``HYSPEX\\0\\0``          8 bytes (NEO checks the first 6)
8          ``hdrSize``                  int32 (hypro) / uint32 (NEO): same bytes
12         ``serialNumber``             int32 / uint32
1961       ``spectralSize`` (bands)     uint32
1965       ``spatialSize`` (samples)    uint32
2073       ``numberOfFrames`` (lines)   uint32
2077       ``nobp`` (bad pixels)        uint32
2181       ``spectralVector``           float64 × bands (nm)
then       ``QE``                       float64 × bands
then       ``RE``                       float64 × bands·samples
then       ``background``               float64 × bands·samples: the dark reference
then       ``badPixels``                uint32 × nobp
=========  ===========================  ==========================================

Between bytes 680 and 880 the two readers split a 200-byte block differently by serial number
(a 200-byte sensor string, or 176 bytes + three float64 temperatures, or 168 + two uint32 +
three float64): every branch takes 200 bytes, so the offsets above hold for all of them.

The pixels: uint16, BIL (lines, bands, samples), from byte ``hdrSize`` (hypro reads them as
uint16 BIL; it takes the offset from an ENVI ``header offset``, here ``hdrSize``: see below).
They are exposed through a ``VRTRawRasterBand`` VRT over the ``.hyspex`` file itself.

The dark reference is the ``background`` matrix, ``dark_source = "background matrix"``: hypro
subtracts it from the DN as they are (``rdn = (DN − background) · gain``), so it is in DN.

Not verified, and how the reader copes:

* The order of the background matrix: hypro reshapes it (bands, samples) in C order (samples
  vary fastest); NEO's MATLAB reads a flat vector and its reshape is not in the source. The
  reader follows hypro. If a file's background has non-finite or negative values, or values
  past the 16-bit range, it is not used (the product's notes say so) and the operations fall
  back to their own dark estimate.
* Where the pixels start: ``hdrSize`` (the field's name and SENSORS.md) versus an ENVI
  ``header offset`` (hypro). No ENVI header is needed: the reader works from the ``.hyspex``
  alone. A file longer than ``hdrSize`` + lines × bands × samples × 2 is accepted (with a
  note); a shorter one is refused.
* A second background matrix ("backgroundLast"/"backgroundAfter") follows the bad-pixel list
  for some serial numbers (hypro: 3000–5000; NEO: 3001–4999 and 7000–7999). The ranges
  disagree, so it is not read: the dark reference is the first matrix (recorded before the
  line). The background block is used only when it ends within ``hdrSize``.
* FWHM is not in the header (hypro estimates it from the band spacing): None here.

Values are raw DN; the header's calibration (QE, RE, background, scaling factor, aperture,
integration time) turns them into radiance (:func:`geoboresight.io.calibration.hyspex_calibration`).
"""

from __future__ import annotations

import functools
import os
import struct

import numpy as np

from ...errors import InputError
from ..wavelengths import unit_scale
from ._raw import RawCube, raw_vrt
from .base import Product, RawCapture, SensorImage
from .specim import image_name

KIND = "HySpex"
MAGIC = b"HYSPEX"
HDR_SIZE_AT = 8
SERIAL_AT = 12
SPECTRAL_SIZE_AT = 1961
SPATIAL_SIZE_AT = 1965
FRAMES_AT = 2073
NOBP_AT = 2077
WAVELENGTH_AT = 2181
PIXEL = np.dtype("<u2")
#: Largest DN of a 16-bit pixel: a background above it cannot be a dark level in DN.
MAX_DN = 65535.0


def _u32(blob: bytes, at: int) -> int:
    return struct.unpack_from("<I", blob, at)[0]


def read(path) -> Product | None:
    """The HySpex product at ``path``, or None when it is not a ``.hyspex`` file."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            magic = f.read(8)
    except OSError:
        return None
    if not magic.startswith(MAGIC):
        return None
    st = os.stat(path)
    return _read(path, os.path.abspath(path), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=64)
def _read(path: str, abspath: str, size: int, mtime_ns: int) -> Product:
    label = f"HySpex file {path}"
    if size < WAVELENGTH_AT:
        raise InputError(
            f"{label} is {size} bytes: its header is truncated (the fixed fields end at byte "
            f"{WAVELENGTH_AT}); copy the file again"
        )
    with open(abspath, "rb") as f:
        fixed = f.read(WAVELENGTH_AT)
    hdr_size = struct.unpack_from("<i", fixed, HDR_SIZE_AT)[0]
    if hdr_size > size:
        raise InputError(
            f"{label}: its header size (hdrSize at byte {HDR_SIZE_AT}) is {hdr_size} bytes, "
            f"past the end of the {size}-byte file: the file is truncated or not a HySpex image"
        )
    if hdr_size < WAVELENGTH_AT:
        raise InputError(
            f"{label}: its header size (hdrSize at byte {HDR_SIZE_AT}) is {hdr_size} bytes, "
            f"less than its fixed fields ({WAVELENGTH_AT} bytes): the header is damaged"
        )
    bands = _u32(fixed, SPECTRAL_SIZE_AT)
    samples = _u32(fixed, SPATIAL_SIZE_AT)
    lines = _u32(fixed, FRAMES_AT)
    if min(bands, samples, lines) < 1:
        raise InputError(
            f"{label}: its header gives {bands} bands, {samples} samples and {lines} lines: "
            "all must be at least 1 (the header is damaged)"
        )
    wl_end = WAVELENGTH_AT + 8 * bands
    if wl_end > hdr_size:
        raise InputError(
            f"{label}: its header ({hdr_size} bytes) is too short for the {bands} wavelengths "
            f"(bytes {WAVELENGTH_AT}–{wl_end}): the header is damaged"
        )
    cube = RawCube(abspath, lines, bands, samples, hdr_size, PIXEL, "bil")
    if size < hdr_size + cube.nbytes:
        raise InputError(
            f"{label} is {size} bytes but its header describes {lines} lines × {bands} bands × "
            f"{samples} samples × 2 bytes from byte {hdr_size} = {hdr_size + cube.nbytes} "
            "bytes: the data are truncated (copy the file again)"
        )
    notes = [f"serial number {_u32(fixed, SERIAL_AT)}; {lines} lines, raw DN"]
    if size > hdr_size + cube.nbytes:
        notes.append(f"{size - hdr_size - cube.nbytes} bytes after the image data not read")
    with open(abspath, "rb") as f:
        f.seek(WAVELENGTH_AT)
        block = f.read(hdr_size - WAVELENGTH_AT)
    wl = np.frombuffer(block, "<f8", bands, 0).astype(np.float64)
    if not np.isfinite(wl).all():
        raise InputError(f"{label}: its wavelength vector (byte {WAVELENGTH_AT}) is not finite")
    wl = wl * unit_scale(None, wl, f"{label} (wavelength vector)")
    dark, dark_source = _background(block, bands, samples, notes)
    image = SensorImage(
        name=image_name(wl),
        source=raw_vrt(cube, lines, wl, stem="hyspex"),
        wavelengths=wl,
        units="DN",
        dark=dark,
        dark_source=dark_source,
    )
    return Product(
        KIND, path, (image,), notes=tuple(notes), capture=RawCapture(path, None, cube, lines)
    )


def _background(block: bytes, bands: int, samples: int, notes: list) -> tuple:
    """(background matrix (bands, samples), "background matrix") from the header bytes after
    byte :data:`WAVELENGTH_AT`, or (None, "") with a note when it is not there or not DN."""
    start = 8 * bands + 8 * bands + 8 * bands * samples  # wavelengths, QE, RE
    stop = start + 8 * bands * samples
    if stop > len(block):
        notes.append("no background matrix within the header: no dark reference")
        return None, ""
    bg = np.frombuffer(block, "<f8", bands * samples, start).reshape(bands, samples).copy()
    if not np.isfinite(bg).all() or bg.min() < 0 or bg.max() > MAX_DN:
        notes.append("background matrix not in DN (non-finite or out of range): not used")
        return None, ""
    return bg, "background matrix"


__all__ = ["KIND", "read"]
