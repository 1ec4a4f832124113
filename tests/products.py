"""Sensor-product files written to their published layouts, for the product readers' tests.

Nothing here is a real file: each writer follows the published layout facts listed in ``docs/sensors.md``
and cites, in its docstring, where each fact comes from. The images hold a known scene in DN
(e.g. :func:`geoboresight.simulate.scene.simulate_scene`'s cubes, which already carry each
detector's dark offset), so tests can check the physics as well as the bytes.
"""

from __future__ import annotations

import os
import struct

import numpy as np

#: Byte positions of the HySpex header fields (hypro ``Radiometry.py``; NEO ``readHyspexHdr.m``).
HYSPEX_AT = {
    "hdrSize": 8,
    "serialNumber": 12,
    "spectralSize": 1961,
    "spatialSize": 1965,
    "numberOfFrames": 2073,
    "nobp": 2077,
    "spectralVector": 2181,
}


#: Radiometric HySpex header fields: byte and struct format (hypro ``Radiometry.py``).
HYSPEX_FIELDS = {
    "scalingFactor": (336, "<d"),
    "integrationTime": (1977, "<I"),
    "bitshift": (1997, "<I"),
    "SF": (2109, "<d"),
    "apertureSize": (2117, "<d"),
    "pixelSizeX": (2125, "<d"),
    "pixelSizeY": (2133, "<d"),
}


def write_calibration(
    folder,
    name,
    gain,
    wavelengths,
    *,
    sensorid,
    binning=(1, 1),
    fwhm=None,
    extra_keys=None,
    extension=".cal",
    truncate_to=None,
):
    """A Specim radiometric calibration: ``name + extension`` and ``name.hdr``; returns the
    data path. ``gain`` is (bands, samples).

    The layout of NERC-ARF APL's ``Calibration::TestCalfile``/``ReadBinAndTrimGains``
    (github.com/arsf/APL ``src/calibration.cpp``) and of the FENIX calibration packs hylite
    ships (``hylite/sensors/calibration_data/fenix/Radiometric_2x2_1x1.hdr``): ENVI,
    ``lines = 1``, ``data type = 4`` (float32), ``interleave = bil``, ``byte order = 0``,
    ``samples`` × ``bands`` gains, a ``wavelength`` list, ``fwhm``, ``sensorid``,
    ``binning = {spectral, spatial}`` (and, in a FENIX pack, ``tint1``/``tint2``/``vimg1``,
    which APL ignores: ``extra_keys``). ``truncate_to`` cuts the data file to that many bytes.
    """
    os.makedirs(folder, exist_ok=True)
    gain = np.asarray(gain, "<f4")
    bands, samples = gain.shape
    data = os.path.join(folder, name + extension)
    blob = gain.tobytes()
    with open(data, "wb") as f:
        f.write(blob if truncate_to is None else blob[:truncate_to])
    keys = {
        "description": "{Radiometric calibration (geoboresight test fixture)}",
        "samples": samples,
        "bands": bands,
        "lines": 1,
        "interleave": "bil",
        "data type": 4,
        "header offset": 0,
        "byte order": 0,
        "sensorid": sensorid,
        "binning": "{" + f"{binning[0]}, {binning[1]}" + "}",
    }
    keys.update(extra_keys or {})
    text = ["ENVI"] + [f"{k} = {v}" for k, v in keys.items()]
    text.append("wavelength = " + _braces(wavelengths))
    if fwhm is not None:
        text.append("fwhm = " + _braces(fwhm))
    with open(os.path.join(folder, name + ".hdr"), "w", encoding="ascii") as f:
        f.write("\n".join(text) + "\n")
    return data


def write_bad(path, cells, *, layout="specim", ccd=(320, 256)):
    """A bad-pixel file listing ``cells`` (0-based (band, sample) of the calibration).

    Layouts of NERC-ARF APL ``Hawk::DecodeSpecimBadPixels``/``DecodeARSFBadPixels``
    (``src/specimsensors.cpp``): Specim's first line ``name ccd_samples ccd_bands``, then
    ``id sample band replacement_sample replacement_band GON``, 1-based; ARSF's first line
    ``headerlines = N``, N − 1 more header lines (method descriptions), then
    ``id band sample methods``, 0-based.
    """
    if layout == "specim":
        lines = [f"NERC_Hawk_BPR_NUC2_GON0.txt  {ccd[0]} {ccd[1]}"]
        for i, (b, s) in enumerate(cells, start=1):
            lines.append(f"{i} {s + 1} {b + 1} {s + 2} {b + 1} GON")
    else:
        lines = ["headerlines = 3", "method A: dead pixel", "method B: hot pixel"]
        for i, (b, s) in enumerate(cells):
            lines.append(f"{i} {b} {s} A,B")
    with open(path, "w", encoding="ascii") as f:
        f.write("\n".join(lines) + "\n")
    return path


def _braces(values, fmt="{:.4f}") -> str:
    return "{" + ", ".join(fmt.format(v) for v in values) + "}"


def dark_frames(shape, level, noise=2.0, seed=0) -> np.ndarray:
    """(lines, bands, samples) uint16 dark frames: ``level`` (a number, or (bands, samples))
    plus Gaussian read noise, rounded."""
    rng = np.random.default_rng(seed)
    lv = np.broadcast_to(np.asarray(level, float), shape[1:])
    return np.clip(np.rint(lv + rng.normal(0.0, noise, shape)), 0, 65535).astype("<u2")


def write_specim_raw(
    folder,
    name,
    image,
    wavelengths,
    *,
    fwhm=None,
    dark=None,
    dark_lines=0,
    counter=True,
    counter_start=1000,
    counter_jump=37,
    autodark_shift=0,
    autodarkstartline=None,
    sensorid="110001",
    extension=".raw",
    extra_keys=None,
    drop_keys=(),
    seed=0,
):
    """A Specim raw capture: ``name + extension`` (uint16 BIL) and ``name.hdr``. Returns
    (header path, data path, the full (lines, bands, samples) array written).

    ``image`` is (bands, lines, samples) DN; ``dark_lines`` dark frames (``dark``: their level,
    one number or (bands, samples)) follow it. Layout facts and their sources:

    * uint16 BIL ``.raw`` with an ENVI ``.hdr`` (``data type = 12``, ``interleave = bil``);
      header keys ``autodarkstartline``, ``fps``, ``tint``, ``binning``, ``sensorid``,
      ``Wavelength`` (one value per band), ``fwhm``: SENSORS.md, from NERC-ARF APL
      ``src/specimsensors.cpp`` and NEODAAS ``subtract_darkframes_raw.py``.
    * ``autodarkstartline = N``: lines N … end are dark frames (APL ``ReadInAllDarkFrames``).
      ``autodark_shift = -1`` writes N − 1, as some real files do (pointing at the last light
      line: APL ``DarkFrameSanityCheck``); ``autodarkstartline`` writes any value.
    * Band 1, sample 0 is a frame counter, sample 1 a zero pixel (APL skips the first entry
      of each line when averaging dark frames): with ``counter``, the counter runs from
      ``counter_start`` over the image lines and jumps by ``counter_jump`` at the first dark
      line (frames pass while the shutter closes: APL ``DarkFrameSanityCheck``).
    """
    os.makedirs(folder, exist_ok=True)
    bands, lines, samples = image.shape
    light = np.ascontiguousarray(np.asarray(image).transpose(1, 0, 2)).astype("<u2")
    parts = [light]
    if dark_lines:
        parts.append(dark_frames((dark_lines, bands, samples), dark, seed=seed))
    cube = np.concatenate(parts, axis=0)
    if counter:
        total = cube.shape[0]
        frame = counter_start + np.arange(total)
        frame[lines:] += counter_jump - 1
        cube[:, 0, 0] = frame % 65536
        cube[:, 0, 1] = 0
    data = os.path.join(folder, name + extension)
    hdr = os.path.join(folder, name + ".hdr")
    cube.tofile(data)
    keys = {
        "description": "{Specim raw capture (geoboresight test fixture)}",
        "samples": samples,
        "lines": cube.shape[0],
        "bands": bands,
        "header offset": 0,
        "file type": "ENVI Standard",
        "data type": 12,
        "interleave": "bil",
        "byte order": 0,
        "sensorid": sensorid,
        "fps": "25.0",
        "tint": "10.0",
        "binning": "{1, 1}",
        "acquisition date": "DATE(dd-mm-yyyy): 01-06-2010",
        "GPS Start Time": "UTC TIME: 10:11:12",
    }
    if dark_lines:
        keys["autodarkstartline"] = lines + autodark_shift
    if autodarkstartline is not None:
        keys["autodarkstartline"] = autodarkstartline
    keys.update(extra_keys or {})
    for key in drop_keys:
        keys.pop(key, None)
    text = ["ENVI"] + [f"{k} = {v}" for k, v in keys.items()]
    text.append("Wavelength = " + _braces(wavelengths))
    if fwhm is not None:
        text.append("fwhm = " + _braces(fwhm))
    with open(hdr, "w", encoding="ascii") as f:
        f.write("\n".join(text) + "\n")
    return hdr, data, cube


def write_hyspex(
    folder,
    name,
    image,
    wavelengths,
    background,
    *,
    serial=1234,
    hdr_size=None,
    truncate_to=None,
    qe=None,
    re=None,
    re_first=False,
    fields=None,
    calibration=True,
):
    """A HySpex ``name.hyspex``: the binary header, then the uint16 BIL pixels. Returns its
    path. ``image`` is (bands, lines, samples) DN, ``background`` (bands, samples) DN.

    Layout facts and their sources (EnSpec/hypro ``src/hypro/Radiometry.py``,
    ``make_radio_cali_file_Hyspex``, field by field; NEO's ``readHyspexHdr.m`` in
    AqsaHassan/High-dynamic-hyperspectral-imaging agrees on every one used here):

    * little-endian; magic ``HYSPEX\\0\\0`` (8 bytes); ``hdrSize`` int32 at byte 8;
      ``serialNumber`` at 12; ``spectralSize`` (bands) uint32 at 1961; ``spatialSize``
      (samples) uint32 at 1965; ``numberOfFrames`` (lines) uint32 at 2073; ``nobp`` uint32 at
      2077 (0 here: no bad-pixel list);
    * from byte 2181: ``spectralVector`` float64 × bands (nm), ``QE`` float64 × bands, ``RE``
      float64 × bands·samples, ``background`` float64 × bands·samples (hypro: shape (bands,
      samples), C order), then the bad-pixel list (uint32 × nobp);
    * pixels uint16 BIL (hypro memory-maps them as (lines, bands, samples)) from ``hdrSize``.

    * radiometric fields (hypro, in the order it reads them): ``scalingFactor`` float64 at
      336, ``integrationTime`` uint32 at 1977, ``bitshift`` uint32 at 1997, ``SF`` float64 at
      2109, ``apertureSize`` at 2117, ``pixelSizeX`` at 2125, ``pixelSizeY`` at 2133
      (``fields`` sets them by name). ``re_first`` writes RE before QE (the order the other
      open reader assumes); ``calibration=False`` writes the wavelength vector only.

    Serial numbers 3000–5000 add a second background block (hypro): avoided by the default.
    ``hdr_size`` overrides the field (e.g. past the end of the file); ``truncate_to`` cuts the
    file to that many bytes.
    """
    os.makedirs(folder, exist_ok=True)
    bands, lines, samples = image.shape
    header = bytearray(HYSPEX_AT["spectralVector"])
    header[0:8] = b"HYSPEX\0\0"
    qe_arr = np.ones(bands, "<f8") if qe is None else np.asarray(qe, "<f8")
    re_arr = np.ones((bands, samples), "<f8") if re is None else np.asarray(re, "<f8")
    matrices = [np.asarray(wavelengths, "<f8")]
    if calibration:
        matrices += [re_arr, qe_arr] if re_first else [qe_arr, re_arr]
        matrices.append(np.asarray(background, "<f8").reshape(bands, samples))
    header += b"".join(m.tobytes() for m in matrices)
    header += b"\0" * (-len(header) % 64)  # padding up to hdrSize, as a writer may add
    size = len(header) if hdr_size is None else hdr_size
    struct.pack_into("<i", header, HYSPEX_AT["hdrSize"], size)
    struct.pack_into("<i", header, HYSPEX_AT["serialNumber"], serial)
    for key, value in (
        ("spectralSize", bands),
        ("spatialSize", samples),
        ("numberOfFrames", lines),
        ("nobp", 0),
    ):
        struct.pack_into("<I", header, HYSPEX_AT[key], value)
    for key, value in (fields or {}).items():
        at, fmt = HYSPEX_FIELDS[key]
        struct.pack_into(fmt, header, at, value)
    pixels = np.ascontiguousarray(np.asarray(image).transpose(1, 0, 2)).astype("<u2")
    path = os.path.join(folder, name + ".hyspex")
    blob = bytes(header) + pixels.tobytes()
    if truncate_to is not None:
        blob = blob[:truncate_to]
    with open(path, "wb") as f:
        f.write(blob)
    return path
