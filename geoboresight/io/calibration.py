"""Reading radiometric calibrations: Specim's ENVI ``.cal`` with its ``.bad`` file, the
capture settings the formula needs (integration times, binning, sensor id), the dark
reference with APL's 3σ rejection, and a HySpex file's own calibration arrays.

Layouts, from the code that reads them:

* ``.cal`` (NERC-ARF APL ``Calibration::TestCalfile``/``ReadBinAndTrimGains``; the FENIX
  packs hylite ships in ``sensors/calibration_data/fenix``): ENVI, ``data type = 4``
  (float32), ``interleave = bil``, ``lines = 1``, ``bands`` × ``samples`` gains, a
  ``wavelength`` list (one per band), ``sensorid`` and ``binning = {spectral, spatial}``. A
  calpack may name the data file ``.dat``: any data file with its ``.hdr`` is read.
* ``.bad`` beside the ``.cal`` (APL ``Hawk::DecodeBadPixel``): Specim's layout, a first line
  ``name ccd_samples ccd_bands`` then ``id sample band replacement_sample replacement_band GON``
  with 1-based sample and band; or ARSF's, a first line ``headerlines = N``, N header lines,
  then ``id band sample methods`` 0-based. Bands and samples are the calibration's.
* Capture settings from the capture's Specim header: ``tint`` (ms), or ``tint1``/``tint2``
  with ``vimg1`` for an AisaFENIX; ``binning = {spectral, spatial}``; ``sensorid``.
* Dark reference (APL ``AverageRefinedDarkFrames``): per band and sample, the mean of the dark
  lines within 3 standard deviations of their mean.
* HySpex: the header fields of HyPro's ``make_radio_cali_file_Hyspex`` (scaling factor at byte
  336, integration time 1977, bit shift 1997, SF 2109, aperture 2117, pixel sizes 2125/2133),
  then after the wavelength vector a per-band array and a band × sample array (QE and RE, in
  an order the open readers disagree on), then the background matrix.
"""

from __future__ import annotations

import os
import struct

import numpy as np

from ..errors import InputError, ParameterError
from ..sensor.calibration import (
    EAGLE_IDS,
    EAGLE_MAX,
    FENIX_SWIR_MAX,
    FENIX_VNIR_MAX,
    HAWK_IDS,
    HAWK_MAX,
    UNITS,
    Calibration,
)
from .envi import data_for_header, envi_header
from .products._raw import BLOCK_LINES, RawCube
from .wavelengths import parse_list

#: Standard deviations around the mean within which a dark line's value is averaged (APL).
DARK_SIGMA = 3.0


def _paths(path: str, label: str) -> tuple[str, str]:
    """(header, data file) of a calibration given as either."""
    if path.lower().endswith(".hdr"):
        data = data_for_header(path) if os.path.isfile(path) else None
        if data is None:
            raise InputError(
                f"{label} {path}: no such header, or no data file beside it (the .cal or .dat "
                "of the calibration pack)"
            )
        return path, data
    if not os.path.isfile(path):
        raise InputError(f"{label} {path} does not exist: check the path")
    stem = os.path.splitext(path)[0]
    for hdr in (path + ".hdr", stem + ".hdr"):
        if os.path.isfile(hdr):
            return hdr, path
    raise InputError(f"{label} {path}: no ENVI header beside it ({stem}.hdr): copy it too")


def _keys_of(hdr: str, label: str) -> dict:
    keys = envi_header(hdr[:-4])
    if keys is None:
        raise InputError(f"{label} {hdr} is not an ENVI header (it must start with 'ENVI')")
    return keys


def _whole(keys: dict, key: str, where: str, default=None) -> int:
    text = keys.get(key)
    if text is None:
        if default is not None:
            return default
        raise InputError(f"{where} has no '{key}': add it (the header is damaged)")
    try:
        return int(float(text.strip().strip("{}").split(",")[0]))
    except ValueError:
        raise InputError(f"{where}: '{key} = {text}' is not a whole number") from None


def binning_of(keys: dict, where: str, key: str = "binning") -> tuple[int, int]:
    """``binning = {spectral, spatial}`` of a Specim header; (1, 1) when absent."""
    text = keys.get(key)
    if text is None:
        return (1, 1)
    values = parse_list(text, f"{where}: '{key}'")
    if values.size != 2 or (values < 1).any() or (values != np.round(values)).any():
        raise InputError(f"{where}: '{key} = {text}' must be two whole numbers ≥ 1")
    return int(values[0]), int(values[1])


def read_calibration(path, label: str = "calibration") -> Calibration:
    """The Specim calibration at ``path`` (the ``.cal``/``.dat`` or its ``.hdr``), with the
    bad cells of a ``.bad`` file of the same name when there is one.

    Raises :class:`InputError` naming the file for a header that is not a one-line float32
    BIL calibration, a data file shorter than the header says, or wavelengths that are
    missing or not one per band.
    """
    hdr, data = _paths(os.fspath(path), label)
    where = f"{label} {hdr}"
    keys = _keys_of(hdr, label)
    bands = _whole(keys, "bands", where)
    samples = _whole(keys, "samples", where)
    lines = _whole(keys, "lines", where)
    if lines != 1:
        raise InputError(f"{where}: a calibration holds one line of gains, this one has {lines}")
    if _whole(keys, "data type", where) != 4:
        raise InputError(f"{where}: the gains must be float32 ('data type = 4')")
    interleave = keys.get("interleave", "bil").strip().lower()
    if interleave not in ("bil", "bsq"):  # one line: BIL and BSQ are the same bytes
        raise InputError(f"{where}: interleave {interleave!r}: a calibration is BIL")
    offset = _whole(keys, "header offset", where, 0)
    big = _whole(keys, "byte order", where, 0) == 1
    need = offset + 4 * bands * samples
    size = os.path.getsize(data)
    if size < need:
        raise InputError(
            f"{label} {data} is {size} bytes but {hdr} describes {bands} bands × {samples} "
            f"samples of float32 from byte {offset} = {need} bytes: the file is truncated "
            "(copy the calibration pack again)"
        )
    raw = np.fromfile(data, np.dtype(">f4" if big else "<f4"), bands * samples, offset=offset)
    gain = raw.reshape(bands, samples).astype(np.float32)
    if "wavelength" not in keys:
        raise InputError(f"{where} has no 'wavelength' list: a calibration names its bands")
    wl = parse_list(keys["wavelength"], f"{where}: 'wavelength'")
    if wl.size != bands:
        raise InputError(f"{where}: {wl.size} wavelengths for {bands} bands")
    fwhm = None
    if "fwhm" in keys:
        fwhm = parse_list(keys["fwhm"], f"{where}: 'fwhm'")
        fwhm = fwhm if fwhm.size == bands else None
    if not np.isfinite(gain).all():
        raise InputError(f"{label} {data}: some gains are not finite numbers (damaged file)")
    bad, bad_source = (), ""
    bad_file = os.path.splitext(data)[0] + ".bad"
    if os.path.isfile(bad_file):
        bad, bad_source = read_bad(bad_file, bands, samples), bad_file
    return Calibration(
        gain=gain,
        wavelengths=wl,
        fwhm=fwhm,
        sensorid=keys.get("sensorid", "").strip(),
        binning=binning_of(keys, where),
        units=UNITS,
        source=os.path.abspath(data),
        bad=bad,
        bad_source=bad_source,
    )


def read_bad(path, bands: int, samples: int) -> tuple[tuple[int, int], ...]:
    """The bad cells (0-based band, sample of the calibration) of a ``.bad`` file in
    Specim's 1-based or ARSF's 0-based layout (APL ``Hawk::DecodeBadPixel``).

    Raises :class:`InputError` naming the file and line for a layout it cannot read or a cell
    outside the calibration's ``bands`` × ``samples``.
    """
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().splitlines()
    if not lines:
        return ()
    first = lines[0]
    cells = []
    if "headerlines" in first:
        try:
            skip = int(first.split("=", 1)[1])
        except (IndexError, ValueError):
            raise InputError(
                f"bad-pixel file {path}: line 1 {first!r} is not 'headerlines = N'"
            ) from None
        rows, base, band_at, sample_at = lines[skip:], 0, 1, 2
        start = skip + 1
    else:
        rows, base, band_at, sample_at = lines[1:], 1, 2, 1
        start = 2
    for i, line in enumerate(rows, start=start):
        words = line.split()
        if not words:
            continue
        try:
            band = int(words[band_at]) - base
            sample = int(words[sample_at]) - base
        except (IndexError, ValueError):
            raise InputError(
                f"bad-pixel file {path}, line {i}: {line.strip()!r} is not a bad-pixel entry"
            ) from None
        if not (0 <= band < bands and 0 <= sample < samples):
            raise InputError(
                f"bad-pixel file {path}, line {i}: band {band + base}, sample {sample + base} "
                f"({'1' if base else '0'}-based) is outside the calibration's {bands} bands × "
                f"{samples} samples: it belongs to another calibration"
            )
        cells.append((band, sample))
    return tuple(cells)


def sensor_family(sensorid: str, keys: dict, wavelengths) -> str:
    """ "FENIX", "Eagle", "Hawk" or "Specim" (unknown) of a capture."""
    if "tint1" in keys or "tint2" in keys or "vimg1" in keys:
        return "FENIX"
    if sensorid in EAGLE_IDS:
        return "Eagle"
    if sensorid in HAWK_IDS:
        return "Hawk"
    return "Specim"


def capture_tints(keys: dict, where: str, n_bands: int) -> tuple[np.ndarray, str]:
    """Integration time (ms) of each band of a Specim capture, and how it was found: ``tint``,
    or ``tint1`` for an AisaFENIX's ``vimg1`` bands and ``tint2`` for the rest (APL ignores
    the calibration's own tints, and so does this)."""
    from ..sensor.calibration import fenix_tints

    def value(key):
        text = keys.get(key)
        if text is None:
            return None
        try:
            t = float(text.strip().strip("{}"))
        except ValueError:
            raise InputError(f"{where}: '{key} = {text}' is not a number (ms)") from None
        if not (np.isfinite(t) and t > 0):
            raise InputError(f"{where}: '{key} = {text}': an integration time must be > 0 ms")
        return t

    t1, t2 = value("tint1"), value("tint2")
    if t1 is not None or t2 is not None:
        if t1 is None or t2 is None:
            raise InputError(
                f"{where} gives {'tint1' if t1 is not None else 'tint2'} but not "
                f"{'tint2' if t1 is not None else 'tint1'}: an AisaFENIX capture needs both "
                "integration times"
            )
        vimg = keys.get("vimg1")
        if vimg is None:
            raise InputError(f"{where} has no 'vimg1': the FENIX VNIR band range is needed")
        lo, hi = parse_list(vimg, f"{where}: 'vimg1'")[:2]
        n1 = int(hi - lo + 1)
        return fenix_tints(n_bands, n1, t1, t2), (
            f"tint1 = {t1:g} ms (bands 1–{n1}), tint2 = {t2:g} ms (bands {n1 + 1}–{n_bands})"
        )
    t = value("tint")
    if t is None:
        raise InputError(
            f"{where} has no 'tint' (integration time, ms): radiance divides by it, so it "
            "cannot be guessed; add it from the flight log"
        )
    return np.full(n_bands, t), f"tint = {t:g} ms"


def saturation_of(family: str, keys: dict, wavelengths, binning: tuple[int, int]) -> np.ndarray:
    """The raw maximum of each band (APL ``specimsensors.h``): Eagle 4095, Hawk 16383, FENIX
    VNIR 4095 × spatial binning and SWIR 65535; an unknown Specim sensor by its wavelengths
    (Eagle's below 1000 nm, Hawk's above)."""
    wl = np.asarray(wavelengths, float)
    if family == "Eagle":
        return np.full(wl.size, float(EAGLE_MAX))
    if family == "Hawk":
        return np.full(wl.size, float(HAWK_MAX))
    if family == "FENIX":
        lo, hi = parse_list(keys["vimg1"], "vimg1")[:2]
        n1 = int(hi - lo + 1)
        sat = np.full(wl.size, float(FENIX_SWIR_MAX))
        sat[:n1] = FENIX_VNIR_MAX * binning[1]
        return sat
    return np.where(wl < 1000.0, float(EAGLE_MAX), float(HAWK_MAX))


def refined_dark(cube: RawCube, first: int, stop: int) -> np.ndarray:
    """Dark level per band and sample (float64): the mean of lines ``first`` … ``stop − 1``
    within :data:`DARK_SIGMA` standard deviations of their mean (APL
    ``AverageRefinedDarkFrames``), streamed in blocks of lines (three passes)."""
    mm = cube.memmap()
    n = stop - first
    mean = cube.line_mean(first, stop)
    sq = np.zeros_like(mean)
    for r0 in range(first, stop, BLOCK_LINES):
        block = np.asarray(mm[r0 : min(stop, r0 + BLOCK_LINES)], np.float64)
        sq += ((block - mean) ** 2).sum(axis=0)
    std = np.sqrt(sq / max(1, n - 1))
    total = np.zeros_like(mean)
    count = np.zeros_like(mean)
    for r0 in range(first, stop, BLOCK_LINES):
        block = np.asarray(mm[r0 : min(stop, r0 + BLOCK_LINES)], np.float64)
        keep = np.abs(block - mean) <= DARK_SIGMA * std
        total += np.where(keep, block, 0.0).sum(axis=0)
        count += keep.sum(axis=0)
    del mm
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), mean)


def capture_dark(product, tint) -> tuple[np.ndarray, str]:
    """The dark level (bands, samples) the radiance of a Specim capture (a recognised
    :class:`~geoboresight.io.products.Product`) subtracts, and where it came from: its dark
    frames, refined (:func:`refined_dark`), or its DARKREF file, taken at the capture's
    integration times ``tint`` (ms per band)."""
    path, image = product.path, product.images[0]
    cube, lines, ref_hdr = product.capture.layout, product.capture.lines, product.capture.dark_file
    if image.dark is None:
        raise InputError(
            f"Specim capture {path} has no dark frames ('autodarkstartline') and no DARKREF "
            "file beside it: radiance needs the dark level"
        )
    if image.dark_source == "frames":
        dark = refined_dark(cube, lines, cube.lines)
        dark[~np.isfinite(np.asarray(image.dark))] = np.nan  # the frame counter's cells
        return dark, f"dark frames, lines {lines}-{cube.lines - 1}, 3-sigma mean (APL)"
    ref = envi_header(ref_hdr[:-4]) or {}
    ref_tint, _ = capture_tints(ref, f"dark reference {ref_hdr}", cube.bands)
    if not np.allclose(ref_tint, tint, rtol=1e-6):
        raise InputError(
            f"dark reference {ref_hdr} was taken at {_tints(ref_tint)} ms but {path} at "
            f"{_tints(tint)} ms: a dark file must have the capture's integration time (APL "
            "refuses to scale it)"
        )
    return np.asarray(image.dark, float), f"{image.dark_source} {ref_hdr} (mean)"


def _tints(t: np.ndarray) -> str:
    return "/".join(f"{v:g}" for v in dict.fromkeys(np.asarray(t).tolist()))


def require_match(
    cal: Calibration,
    sensorid: str,
    binning: tuple[int, int],
    capture: str,
    param: str = "calibration",
):
    """Refuse a calibration measured on another sensor, or at a binning the capture's is not a
    whole multiple of (naming both values); the (spectral, spatial) binning ratio."""
    if cal.sensorid and sensorid and cal.sensorid != sensorid:
        raise ParameterError(
            f"parameter '{param}': {cal.source} is for sensorid {cal.sensorid} but "
            f"{capture} was taken by sensorid {sensorid}: use that sensor's calibration",
            params=(param,),
        )
    ratio = []
    for name, have, want in zip(("spectral", "spatial"), binning, cal.binning, strict=True):
        if have % want:
            raise ParameterError(
                f"parameter '{param}': {cal.source} was measured at {name} binning {want} "
                f"but {capture} is binned {have}: use the calibration for binning "
                f"{binning[0]}×{binning[1]}",
                params=(param,),
            )
        ratio.append(have // want)
    return tuple(ratio)


# --------------------------------------------------------------------------------- HySpex
SCALING_AT = 336
INTEGRATION_AT = 1977
BITSHIFT_AT = 1997
SF_AT = 2109
APERTURE_AT = 2117
PIXEL_X_AT = 2125
PIXEL_Y_AT = 2133


def hyspex_calibration(path) -> tuple[Calibration, np.ndarray, float, str]:
    """(calibration with the gain of :func:`~geoboresight.sensor.calibration.hyspex_gain`,
    background (bands, samples), saturation DN, which array was read as QE) of a ``.hyspex``.

    The QE (per band) and RE (per band and sample) arrays follow the wavelength vector in an
    order two open readers disagree on: the order is taken where the per-band array lies in
    0–1 (a quantum efficiency) and the other does not, and refused when the file does not
    say (both or neither).
    """
    from ..sensor.calibration import hyspex_gain
    from .products.hyspex import (
        FRAMES_AT,
        HDR_SIZE_AT,
        SPATIAL_SIZE_AT,
        SPECTRAL_SIZE_AT,
        WAVELENGTH_AT,
    )

    path = os.fspath(path)
    label = f"HySpex file {path}"
    with open(path, "rb") as f:
        fixed = f.read(WAVELENGTH_AT)
        if len(fixed) < WAVELENGTH_AT:
            raise InputError(f"{label}: its header is truncated")
        hdr_size = struct.unpack_from("<i", fixed, HDR_SIZE_AT)[0]
        bands = struct.unpack_from("<I", fixed, SPECTRAL_SIZE_AT)[0]
        samples = struct.unpack_from("<I", fixed, SPATIAL_SIZE_AT)[0]
        block = f.read(max(0, hdr_size - WAVELENGTH_AT))
    del FRAMES_AT
    need = 8 * (bands + bands + bands * samples + bands * samples)
    if len(block) < need:
        raise InputError(
            f"{label}: its header ({hdr_size} bytes) holds no calibration arrays (QE, RE and "
            f"background need {need} bytes after byte {WAVELENGTH_AT}): give a file recorded "
            "with its calibration, or convert it to radiance with NEO's software"
        )
    wl = np.frombuffer(block, "<f8", bands, 0)
    n = bands * samples
    a_small = np.frombuffer(block, "<f8", bands, 8 * bands)  # QE first (HyPro)
    a_big = np.frombuffer(block, "<f8", n, 16 * bands)
    b_big = np.frombuffer(block, "<f8", n, 8 * bands)  # RE first
    b_small = np.frombuffer(block, "<f8", bands, 8 * bands + 8 * n)

    def is_qe(x):
        return bool(np.isfinite(x).all() and (x > 0).all() and (x <= 1).all())

    qe_first, re_first = is_qe(a_small), is_qe(b_small)
    if qe_first == re_first:
        raise InputError(
            f"{label}: its calibration arrays do not say which is the quantum efficiency (a "
            "per-band array within 0–1 either "
            + ("in both orders" if qe_first else "in neither order")
            + "): the file's calibration cannot be used"
        )
    qe, re = (a_small, a_big) if qe_first else (b_small, b_big)
    re = re.reshape(bands, samples)
    if not (np.isfinite(re).all() and (re > 0).all()):
        raise InputError(f"{label}: its responsivity (RE) array is not positive and finite")
    bg = np.frombuffer(block, "<f8", n, 16 * bands + 8 * n).reshape(bands, samples)

    def f8(at):
        return struct.unpack_from("<d", fixed, at)[0]

    tint = float(struct.unpack_from("<I", fixed, INTEGRATION_AT)[0])
    bitshift = struct.unpack_from("<I", fixed, BITSHIFT_AT)[0]
    values = {
        "SF": f8(SF_AT),
        "integration time": tint,
        "aperture size": f8(APERTURE_AT),
        "pixel size X": f8(PIXEL_X_AT),
        "pixel size Y": f8(PIXEL_Y_AT),
    }
    for name, v in values.items():
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"{label}: its header's {name} is {v!r}: radiance needs it > 0")
    gain = hyspex_gain(
        re,
        qe,
        wl,
        scaling=values["SF"],
        tint=tint,
        aperture=values["aperture size"],
        pixel_x=values["pixel size X"],
        pixel_y=values["pixel size Y"],
    )
    cal = Calibration(
        gain=gain.astype(np.float32),
        wavelengths=wl.copy(),
        units=UNITS,
        source=os.path.abspath(path),
    )
    saturation = float(2 ** (16 - min(int(bitshift), 16)) - 1)
    return cal, bg.copy(), saturation, "QE before RE" if qe_first else "RE before QE"


__all__ = [
    "DARK_SIGMA",
    "binning_of",
    "capture_tints",
    "hyspex_calibration",
    "read_bad",
    "read_calibration",
    "refined_dark",
    "require_match",
    "saturation_of",
    "sensor_family",
]
