"""PRISMA Level-1 (ASI): one HDF-EOS5 file (``PRS_L1_*.he5``) holding both detectors.

Read with h5py (layout as sister-jpl/sister ``sister/sensors/prisma.py``, EnMAP-Box
``importprismal1algorithm.py``, prismaread and ACOLITE read it):

- ``HDFEOS/SWATHS/PRS_L1_HCO/Data Fields/VNIR_Cube`` and ``SWIR_Cube``: (lines, bands, samples),
  i.e. band-interleaved by line, DN;
- root attributes ``List_Cw_Vnir``/``List_Cw_Swir`` (band centres, nm, in DESCENDING order; 0 = an
  unused slot), ``List_Fwhm_*``, ``List_Cw_*_Flags`` (1 = band in use), ``ScaleFactor_Vnir``/
  ``_Swir`` and ``Offset_*``: radiance = DN / ScaleFactor − Offset, W m⁻² sr⁻¹ µm⁻¹;
- ``HDFEOS/SWATHS/PRS_L1_HCO/Geolocation Fields/Latitude_VNIR``, ``Longitude_VNIR`` (lines,
  samples): the product's geolocation, in WGS 84 degrees.

The cube is never read whole. Stored contiguously and unfiltered, it is presented by a VRT of raw
bands at its byte offset in the HDF5 file; stored chunked (or compressed), it is copied once,
chunk by chunk (memory: one chunk), into an uncompressed BIL file in the VRT temporary folder. A
second VRT applies the radiance scaling (Float32). Band N of the presented image is slot N of the
product (its own order); slots with a 0 centre or flag 0 are marked bad, so no operation picks
them. GDAL's own HDF5 driver is not used: it maps the first dimension (lines) to bands.
"""

from __future__ import annotations

import os

import numpy as np

from ...errors import InputError
from .base import Geolocation, Product, SensorImage, read_once

KIND = "PRISMA L1"
UNITS = "radiance (W m-2 sr-1 um-1)"
SWATH = "HDFEOS/SWATHS/PRS_L1_HCO"
DATA = SWATH + "/Data Fields"
GEO = SWATH + "/Geolocation Fields"
_EXTS = (".he5", ".h5", ".hdf5", ".hdf")
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def _is_hdf5(path: str) -> bool:
    """The HDF5 signature at byte 0 or at a user-block boundary (512, 1024, ...)."""
    try:
        with open(path, "rb") as f:
            for at in (0, 512, 1024, 2048, 4096):
                f.seek(at)
                if f.read(8) == _HDF5_MAGIC:
                    return True
    except OSError:
        return False
    return False


def read(path) -> Product | None:
    """The PRISMA L1 product at ``path`` (an .he5 file), or None when ``path`` is not one;
    :class:`InputError` when it is one but damaged."""
    path = os.fspath(path)
    if not path.lower().endswith(_EXTS) or not os.path.isfile(path):
        return None
    named = os.path.basename(path).upper().startswith("PRS_L1")
    if not _is_hdf5(path):
        if named:
            raise InputError(
                f"{KIND} {path}: not an HDF5 file (truncated download?): download it again"
            )
        return None
    return read_once(path, "prisma", lambda: _read(path, named))


def _read(path: str, named: bool) -> Product | None:
    try:
        import h5py
    except ImportError:  # a core dependency: only a broken installation lacks it
        raise InputError(
            f"{KIND} {path}: reading PRISMA needs the h5py package: pip install h5py"
        ) from None
    where = f"{KIND} {path}"
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        if named:
            raise InputError(f"{where}: the HDF5 file cannot be opened ({exc})") from None
        return None
    with f:
        swaths = list(f["HDFEOS/SWATHS"]) if "HDFEOS/SWATHS" in f else []
        if "PRS_L1_HCO" not in swaths:
            other = [s for s in swaths if s.startswith("PRS_")]
            if other:
                raise InputError(
                    f"{where}: a PRISMA product with swaths {', '.join(other)}, not the L1 "
                    "radiance cube (PRS_L1_HCO): only L1 is read (L2 products are "
                    "orthorectified, so the VNIR/SWIR offset is gone)"
                )
            if "List_Cw_Vnir" in f.attrs or named:
                raise InputError(
                    f"{where}: PRISMA L1 without its cubes (no {SWATH}): the file is "
                    "incomplete; download it again"
                )
            return None
        images, notes = [], []
        for det, att in (("VNIR", "Vnir"), ("SWIR", "Swir")):
            images.append(_detector(f, path, det, att, notes))
        geo = _geolocation(f, path, images[0], notes)
    notes.append(
        "PRISMA VNIR and SWIR are co-registered by the ground segment (PRS_L1_HCO): the "
        "measured boresight offset is what remains"
    )
    problem = "" if geo is not None else next((n for n in notes if "geolocation" in n), "")
    return Product(KIND, path, tuple(images), geo, tuple(notes), problem)


def _attr(f, name: str, where: str, what: str):
    if name not in f.attrs:
        raise InputError(f"{where}: no root attribute {name} ({what}): the file is incomplete")
    return f.attrs[name]


def _detector(f, path: str, det: str, att: str, notes: list) -> SensorImage:
    from ._calibrated import calibrated_vrt

    where = f"{KIND} {path}"
    name = f"{DATA}/{det}_Cube"
    if name not in f:
        raise InputError(
            f"{where}: no {det}_Cube ({name}): the file is incomplete; download it again"
        )
    dset = f[name]
    if dset.ndim != 3:
        raise InputError(f"{where}: {det}_Cube has shape {dset.shape}, not (lines, bands, samples)")
    lines, bands, samples = (int(n) for n in dset.shape)
    cw = np.asarray(_attr(f, f"List_Cw_{att}", where, f"{det} band centres"), float).ravel()
    if cw.size != bands:
        raise InputError(
            f"{where}: List_Cw_{att} has {cw.size} wavelengths but {det}_Cube has {bands} "
            "bands: the metadata does not match the cube"
        )
    fwhm = f.attrs.get(f"List_Fwhm_{att}")
    fwhm = None if fwhm is None else np.asarray(fwhm, float).ravel()
    if fwhm is not None and fwhm.size != bands:
        notes.append(f"{det}: List_Fwhm_{att} has {fwhm.size} values for {bands} bands: ignored")
        fwhm = None
    good = cw > 0
    flags = f.attrs.get(f"List_Cw_{att}_Flags")
    if flags is not None and np.asarray(flags).size == bands:
        good &= np.asarray(flags).ravel() != 0
    if not good.any():
        raise InputError(f"{where}: every {det} slot has a 0 centre wavelength or flag 0")
    scale = float(np.asarray(_attr(f, f"ScaleFactor_{att}", where, "DN to radiance")).ravel()[0])
    if not np.isfinite(scale) or scale <= 0:
        raise InputError(f"{where}: ScaleFactor_{att} is {scale!r}, not a positive number")
    if f"Offset_{att}" in f.attrs:
        offset = float(np.asarray(f.attrs[f"Offset_{att}"]).ravel()[0])
    else:
        offset = 0.0
        notes.append(f"{det}: no Offset_{att}: taken as 0")
    dtype = np.dtype(dset.dtype)
    raw = _raw_source(f, dset, path, det.lower(), notes)
    source = calibrated_vrt(
        raw,
        samples,
        lines,
        dtype,
        [1.0 / scale] * bands,
        [-offset] * bands,
        wavelengths=cw,
        fwhm=fwhm,
        units=UNITS,
        metadata={"scale_factor": [scale] * bands, "offset": [offset] * bands},
        stem=f"prisma-{det.lower()}",
    )
    return SensorImage(det, source, cw, fwhm, good, units=UNITS)


def _contiguous(dset) -> int | None:
    """The byte offset of an uncompressed, contiguous dataset in its file, else None."""
    if dset.chunks is not None or dset.compression is not None or dset.dtype.kind not in "uif":
        return None
    try:
        offset = dset.id.get_offset()
    except Exception:  # no storage allocated, or an external/virtual layout
        return None
    return None if offset is None else int(offset)


def _raw_source(f, dset, path: str, stem: str, notes: list) -> str:
    """What GDAL opens for the raw cube (lines, bands, samples): a raw VRT into the HDF5
    file, or into a BIL copy of a chunked dataset."""
    from ._calibrated import raw_bil_vrt

    lines, bands, samples = (int(n) for n in dset.shape)
    if dset.ndim == 2:
        lines, samples, bands = int(dset.shape[0]), int(dset.shape[1]), 1
    offset = _contiguous(dset)
    if offset is not None:
        return raw_bil_vrt(path, offset, lines, bands, samples, dset.dtype, stem)
    copy = _copy_bil(dset, stem)
    size = os.path.getsize(copy) / 2**20
    notes.append(
        f"{dset.name.rsplit('/', 1)[-1]} is stored chunked {dset.chunks}"
        + (f" with {dset.compression} compression" if dset.compression else "")
        + f": copied once, chunk by chunk, to an uncompressed BIL file ({size:.0f} MB) in the "
        "temporary VRT folder (removed when the process ends)"
    )
    return raw_bil_vrt(copy, 0, lines, bands, samples, dset.dtype.newbyteorder("<"), stem)


def _copy_bil(dset, stem: str) -> str:
    """Copy a chunked dataset to a little-endian raw file of the same shape, one chunk at a
    time (memory: one chunk)."""
    from ._calibrated import temp_path

    out = temp_path(f"{stem}-cube", ".bil")
    dtype = np.dtype(dset.dtype).newbyteorder("<")
    mm = np.memmap(out, dtype=dtype, mode="w+", shape=tuple(int(n) for n in dset.shape))
    try:
        for sl in dset.iter_chunks():
            mm[sl] = dset[sl]
        mm.flush()
    finally:
        del mm
    return out


def _geolocation(f, path: str, image: SensorImage, notes: list) -> Geolocation | None:
    lat_name, lon_name = f"{GEO}/Latitude_VNIR", f"{GEO}/Longitude_VNIR"
    if lat_name not in f or lon_name not in f:
        notes.append("no Latitude_VNIR/Longitude_VNIR: no geolocation")
        return None
    lat, lon = f[lat_name], f[lon_name]
    cube = f[f"{DATA}/VNIR_Cube"]
    want = (cube.shape[0], cube.shape[2])
    if lat.shape != want or lon.shape != want:
        notes.append(
            f"Latitude_VNIR/Longitude_VNIR are {lat.shape}/{lon.shape}, not the cube's "
            f"(lines, samples) {want}: no geolocation"
        )
        return None
    return Geolocation(
        _coordinate(lon, path, "lon"),
        _coordinate(lat, path, "lat"),
        "EPSG:4326",
        source="PRISMA Latitude_VNIR/Longitude_VNIR",
    )


def _coordinate(dset, path: str, stem: str) -> str:
    """A single-band raster GDAL opens for a 2-D coordinate field: a raw VRT into the HDF5
    file when contiguous, else a small float GeoTIFF in the VRT folder."""
    from ._calibrated import raw_bil_vrt, temp_path

    offset = _contiguous(dset)
    lines, samples = (int(n) for n in dset.shape)
    if offset is not None:
        return raw_bil_vrt(path, offset, lines, 1, samples, dset.dtype, f"prisma-{stem}")
    import rasterio

    from ..raster import quiet_georef

    out = temp_path(f"prisma-{stem}", ".tif")
    data = np.asarray(dset[()], dtype="float64" if dset.dtype == np.float64 else "float32")
    with (
        quiet_georef(),
        rasterio.open(
            out,
            "w",
            driver="GTiff",
            width=samples,
            height=lines,
            count=1,
            dtype=data.dtype.name,
        ) as dst,
    ):
        dst.write(data, 1)
    return out


__all__ = ["KIND", "UNITS", "read"]
