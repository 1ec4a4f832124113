"""Specim raw ENVI (AISA Eagle, Hawk, Dual; Fenix): raw DN with dark frames at the end.

What is read, and from where (sources in ``docs/sensors.md``):

* The ENVI header beside the data (``name.hdr`` for ``name.raw``/``name.img``/``name``, or the
  ``.hdr`` itself). A header is Specim's when it holds ``autodarkstartline``, or ``sensorid``,
  ``fps`` or ``tint``.
* ``autodarkstartline = N``: lines N … end are dark frames (shutter closed). The image is lines
  0 … N−1 only, exposed through a VRT (:func:`._raw.raw_vrt`: ``VRTRawRasterBand`` over the
  data file, same offsets and byte order), so every operation sees N lines. The dark reference
  is the mean of the dark lines per band and sample (float64, streamed in blocks of lines),
  ``dark_source = "frames"``, as NERC-ARF APL's ``ReadInAllDarkFrames`` averages them
  (arsf/APL ``src/specimsensors.cpp``, ``src/calibration.cpp``).
* Band 1, sample 0 is a frame counter and band 1, sample 1 a zero pixel: not image. Both are
  hidden by a per-band mask on band 1 (GDAL mask band: every operation's
  :func:`~geoboresight.io.windows.read_masked` leaves them out) and their dark reference is NaN.
  The counter is recognised from the data (it rises by one, or a few for dropped frames, from
  line to line); a file without one is left as it is.
* Frame-counter check of ``autodarkstartline`` (APL's ``DarkFrameSanityCheck``): the counter
  jumps at the first dark line (frames go by while the shutter closes). Some real files point
  ``autodarkstartline`` at the last light line: when the jump is between lines N and N+1 and
  not between N−1 and N, the dark frames start at N+1 and the image has N+1 lines (said in the
  product's notes). No jump, or a jump on both sides: ``autodarkstartline`` is taken as given.
* Without dark frames, a ``DARKREF_<name>.hdr``/data pair beside the capture (the lab
  convention of hylite's ``sensors/fenix.py``) gives the dark reference (mean of all its lines,
  ``dark_source = "DARKREF file"``). A header with ``sensorid``/``fps``/``tint`` but neither
  dark frames, a DARKREF file nor a frame counter is left to GDAL (``read`` returns None).
* Wavelengths, FWHM and ``bbl`` from the header, as for any ENVI file
  (:mod:`geoboresight.io.wavelengths`). The image is named "VNIR" when every band centre is
  below 1000 nm, "SWIR" when every one is above 950 nm, else "cube" (an AISA-Dual merged cube,
  split at the seam by :func:`~geoboresight.io.open_dual`). Values are raw DN; the
  calibration file turns them into radiance (:mod:`geoboresight.io.calibration`).
"""

from __future__ import annotations

import functools
import os

import numpy as np

from ...errors import InputError
from ..envi import ENVI_DTYPES, data_for_header, envi_header
from ..raster import open_raster
from ..wavelengths import good_bands, parse_list, read_wavelengths, unit_scale
from ._raw import RawCube, raw_vrt
from .base import Product, RawCapture, SensorImage

KIND = "Specim raw ENVI"
#: Header keys Specim's acquisition software writes (any one marks a Specim header).
SPECIM_KEYS = ("autodarkstartline", "sensorid", "fps", "tint")
#: The frame counter wraps at 16 bits (APL: MAXFRAMECOUNT = 65535).
COUNTER_MODULUS = 65536
#: Lines whose counter is looked at to recognise one.
COUNTER_PROBE = 8
#: Largest step of a frame counter between two image lines (dropped frames) still called one.
COUNTER_MAX_STEP = 16


def image_name(wavelengths) -> str:
    """ "VNIR" (every centre < 1000 nm), "SWIR" (every centre > 950 nm) or "cube"."""
    wl = np.asarray(wavelengths, float)
    if (wl < 1000.0).all():
        return "VNIR"
    if (wl > 950.0).all():
        return "SWIR"
    return "cube"


def _paths(path: str) -> tuple[str, str] | None:
    """(header, data file) of ``path`` (the header or the data file), or None."""
    if path.lower().endswith(".hdr"):
        if not os.path.isfile(path):
            return None
        data = data_for_header(path)
        return (path, data) if data else None
    if not os.path.isfile(path):
        return None
    stem = os.path.splitext(path)[0]
    for hdr in (path + ".hdr", stem + ".hdr"):
        if os.path.isfile(hdr):
            return hdr, path
    return None


def _int(keys: dict, key: str, hdr: str, default=None) -> int:
    text = keys.get(key)
    if text is None:
        if default is not None:
            return default
        raise InputError(f"Specim header {hdr} has no '{key}': add it (the header is damaged)")
    try:
        return int(text.strip().strip("{}").strip())
    except ValueError:
        raise InputError(
            f"Specim header {hdr}: '{key} = {text}' is not a whole number: fix the header"
        ) from None


def _layout(keys: dict, hdr: str, data: str) -> RawCube:
    code = _int(keys, "data type", hdr)
    if code not in ENVI_DTYPES:
        raise InputError(f"Specim header {hdr}: data type {code} is not a raw number type")
    big = _int(keys, "byte order", hdr, 0) == 1
    interleave = keys.get("interleave", "bil").strip().lower()
    if interleave not in ("bil", "bsq", "bip"):
        raise InputError(f"Specim header {hdr}: interleave {interleave!r} is not bil/bsq/bip")
    cube = RawCube(
        data,
        _int(keys, "lines", hdr),
        _int(keys, "bands", hdr),
        _int(keys, "samples", hdr),
        _int(keys, "header offset", hdr, 0),
        np.dtype(ENVI_DTYPES[code]).newbyteorder(">" if big else "<"),
        interleave,
    )
    if min(cube.lines, cube.bands, cube.samples) < 1:
        raise InputError(f"Specim header {hdr}: lines, samples and bands must all be ≥ 1")
    size = os.path.getsize(data)
    if size < cube.offset + cube.nbytes:
        raise InputError(
            f"Specim raw file {data} is {size} bytes but {hdr} describes {cube.lines} lines × "
            f"{cube.bands} bands × {cube.samples} samples × {cube.dtype.itemsize} bytes from "
            f"byte {cube.offset} = {cube.offset + cube.nbytes} bytes: the file is truncated "
            "(copy it again)"
        )
    return cube


def _counter(cube: RawCube, first: int, stop: int) -> np.ndarray:
    """Band 1, sample 0 of lines ``first`` … ``stop - 1`` (the frame counter), as int64."""
    mm = cube.memmap()
    values = np.asarray(mm[first:stop, 0, 0]).astype(np.int64)
    del mm
    return values


def _steps(counter: np.ndarray) -> np.ndarray:
    return np.diff(counter) % COUNTER_MODULUS


def has_frame_counter(cube: RawCube, lines: int) -> bool:
    """True when band 1, sample 0 of the first image lines counts frames (steps of 1, or a
    few for dropped frames, at least half of them exactly 1)."""
    n = min(lines, COUNTER_PROBE)
    if n < 3:
        return False
    steps = _steps(_counter(cube, 0, n))
    return bool(((steps >= 1) & (steps <= COUNTER_MAX_STEP)).all() and np.median(steps) == 1)


def first_dark_line(cube: RawCube, start: int) -> tuple[int, str | None]:
    """The first dark line given ``autodarkstartline = start``, checked with the frame counter
    (APL's ``DarkFrameSanityCheck``), and a note when it was moved."""
    if start < 1 or start + 2 > cube.lines:
        return start, None
    before, after = _steps(_counter(cube, start - 1, start + 2))
    if after > before and after > 1:
        return start + 1, (
            f"autodarkstartline = {start} points at the last light line (the frame counter "
            f"jumps by {after} between lines {start} and {start + 1}, by {before} before): "
            f"dark frames taken from line {start + 1}"
        )
    return start, None


def _darkref(hdr: str, cube: RawCube) -> tuple[np.ndarray, str] | None:
    """The mean of a ``DARKREF_<name>`` capture beside ``hdr`` (its path), or None."""
    folder, base = os.path.split(hdr)
    ref_hdr = os.path.join(folder, "DARKREF_" + os.path.splitext(base)[0] + ".hdr")
    if not os.path.isfile(ref_hdr):
        return None
    ref_data = data_for_header(ref_hdr)
    keys = envi_header(ref_data) if ref_data else None
    if keys is None:
        raise InputError(
            f"dark reference {ref_hdr} has no data file beside it (or is not an ENVI header): "
            "copy the DARKREF data file, or move the header away"
        )
    ref = _layout(keys, ref_hdr, ref_data)
    if (ref.bands, ref.samples) != (cube.bands, cube.samples):
        raise InputError(
            f"dark reference {ref_hdr} has {ref.bands} bands × {ref.samples} samples but the "
            f"capture {hdr} has {cube.bands} × {cube.samples}: use the DARKREF of this capture"
        )
    dark = ref.line_mean(0, ref.lines)
    if has_frame_counter(ref, ref.lines):
        dark[0, :2] = np.nan  # its frame counter and zero pixel are not dark signal
    return dark, ref_hdr


def _fwhm(keys: dict, hdr: str, n: int) -> np.ndarray | None:
    """The header's ``fwhm`` in nm, read here because GDAL keeps Specim's capitalised
    ``Wavelength`` key as written and then drops the FWHM."""
    raw = parse_list(keys["wavelength"], f"{hdr}: 'Wavelength'")
    fwhm = parse_list(keys["fwhm"], f"{hdr}: 'fwhm'")
    if len(fwhm) != n or len(raw) != n:
        return None
    return fwhm * unit_scale(keys.get("wavelength units"), raw, hdr)


def _stamp(*paths: str) -> tuple:
    out = []
    for p in paths:
        st = os.stat(p)
        out.append((os.path.abspath(p), st.st_size, st.st_mtime_ns))
    return tuple(out)


def read(path) -> Product | None:
    """The Specim raw product at ``path`` (header or data file), or None when it is not one."""
    path = os.fspath(path)
    found = _paths(path)
    if found is None:
        return None
    hdr, data = found
    keys = _header_keys(hdr)
    if keys is None or not any(k in keys for k in SPECIM_KEYS):
        return None
    folder, base = os.path.split(hdr)
    ref = os.path.join(folder, "DARKREF_" + os.path.splitext(base)[0] + ".hdr")
    stamps = _stamp(hdr, data) + (_stamp(ref) if os.path.isfile(ref) else ())
    return _read(path, hdr, data, stamps)


def capture(path) -> tuple[str, dict, RawCube] | None:
    """(header path, header keys, byte layout of the whole file, dark lines included) of the
    Specim capture at ``path``, or None when it is not one (what radiance calibration reads)."""
    found = _paths(os.fspath(path))
    if found is None:
        return None
    hdr, data = found
    keys = _header_keys(hdr)
    if keys is None or not any(k in keys for k in SPECIM_KEYS):
        return None
    return hdr, keys, _layout(keys, hdr, data)


def _header_keys(hdr: str) -> dict | None:
    """The keys of ``hdr`` itself (:func:`envi_header` looks beside a data file)."""
    return envi_header(hdr[:-4]) if os.path.isfile(hdr) else None


@functools.lru_cache(maxsize=64)
def _read(path: str, hdr: str, data: str, stamps: tuple) -> Product | None:
    keys = _header_keys(hdr)
    cube = _layout(keys, hdr, data)
    notes: list[str] = []
    dark = None
    dark_source = ""
    dark_file = None
    lines = cube.lines
    if "autodarkstartline" in keys:
        start = _int(keys, "autodarkstartline", hdr)
        if start < 1 or start >= cube.lines:
            raise InputError(
                f"Specim header {hdr}: autodarkstartline = {start} but the file has "
                f"{cube.lines} lines: the dark frames must start within the file, after at "
                "least one image line (fix 'autodarkstartline' or 'lines' in the header)"
            )
        counter = has_frame_counter(cube, start)
        if counter:
            start, moved = first_dark_line(cube, start)
            if moved:
                notes.append(moved)
        lines = start
        dark = cube.line_mean(start, cube.lines)
        dark_source = "frames"
        notes.append(
            f"image lines 0–{start - 1}; lines {start}–{cube.lines - 1} are dark frames "
            f"({cube.lines - start}), averaged into the dark reference"
        )
    else:
        counter = has_frame_counter(cube, cube.lines)
        ref = _darkref(hdr, cube)
        if ref is not None:
            dark, dark_file = ref
            dark_source = "DARKREF file"
            notes.append(f"dark reference: mean of {dark_file}")
        elif not counter:
            return None  # nothing a plain GDAL read misses
    masked = None
    if counter:
        masked = {0: (0, 1)}
        notes.append("band 1, samples 0–1 (frame counter, zero pixel) masked")
        if dark is not None:
            dark[0, :2] = np.nan
    with open_raster(data, f"{KIND} {path}") as src:
        wl, fwhm = read_wavelengths(src)
        good = good_bands(src)
    if wl is None:
        raise InputError(
            f"Specim header {hdr} has no 'wavelength' list: add the band centres (the "
            "'Wavelength = {...}' block Specim's software writes)"
        )
    if fwhm is None and "fwhm" in keys and "wavelength" in keys:
        fwhm = _fwhm(keys, hdr, len(wl))
    source = raw_vrt(cube, lines, wl, masked, stem="specim")
    image = SensorImage(
        name=image_name(wl),
        source=source,
        wavelengths=wl,
        fwhm=fwhm,
        good=good,
        units="DN",
        dark=dark,
        dark_source=dark_source,
    )
    raw = RawCapture(hdr, keys, cube, lines, dark_file)
    return Product(KIND, path, (image,), notes=tuple(notes), capture=raw)


__all__ = ["KIND", "capture", "first_dark_line", "has_frame_counter", "image_name", "read"]
