"""Spaceborne sensor products written to their published layouts (no real file is shipped):
EnMAP L1B (a folder or a zip) and PRISMA L1 (HDF5), filled with a known scene.

The scene: a smooth random texture ``T`` shared by every band (so the VNIR band near 920 nm and
the SWIR band near 1010 nm can be matched), a second texture ``T2`` weighted by wavelength (so
the band ratio is not constant), and a smooth spectrum. The radiance each writer returns is the
dequantised radiance its DN give back (what a reader must present), so tests compare exactly.
"""

from __future__ import annotations

import os
import shutil
import zipfile
from dataclasses import dataclass, field

import numpy as np
import rasterio
from scipy import ndimage

from geoboresight.io import quiet_georef

#: EnMAP-like band centres (nm): VNIR 418–993, SWIR 904–2429 (overlapping, as the real ones);
#: 918 nm is the VNIR band nearest 920, 1004 nm the SWIR band nearest 1010.
ENMAP_VNIR_WL = 418.0 + 12.5 * np.arange(47)
ENMAP_SWIR_WL = 904.0 + 25.0 * np.arange(62)
#: SWIR image content this many lines along-track from the VNIR image, as in real L1B
#: (about 20 px, as noted in EnPT's issue tracker): a feature at VNIR line r is at SWIR
#: line r + 20.
ENMAP_SHIFT = 20


def scene(wavelengths, rows: int, cols: int, seed: int = 0, top: int = 0) -> np.ndarray:
    """Radiance-like cube (bands, rows + top, cols), float64, all positive."""
    rng = np.random.default_rng(seed)
    t = ndimage.gaussian_filter(rng.normal(size=(rows + top, cols)), 1.5)
    t /= np.abs(t).max()
    t2 = ndimage.gaussian_filter(rng.normal(size=(rows + top, cols)), 4.0)
    t2 /= np.abs(t2).max()
    wl = np.asarray(wavelengths, float)[:, None, None]
    spectrum = 1.0 + 0.5 * np.exp(-(((wl - 800.0) / 400.0) ** 2))
    return spectrum * (0.6 + 0.35 * t) + 0.15 * (wl / 2500.0) * t2


@dataclass
class Written:
    """A product written by a fixture and what a reader must find in it."""

    path: str
    vnir_wl: np.ndarray
    swir_wl: np.ndarray
    vnir_radiance: np.ndarray  # (bands, rows, cols) float64, the DN's radiance
    swir_radiance: np.ndarray
    vnir_fwhm: np.ndarray | None = None
    swir_fwhm: np.ndarray | None = None
    vnir_valid: np.ndarray | None = None  # (bands, rows, cols) bool: False where masked
    swir_valid: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


# --- EnMAP L1B ---------------------------------------------------------------------------------

ENMAP_NAME = "ENMAP01-____L1B-DT0000001234_20230701T101010Z_001_V010400_20230702T000000Z"


def _enmap_xml(name, vnir_wl, swir_wl, fwhm, gains, offsets, rows, cols, drop=()) -> str:
    """The METADATA.XML elements the readers use. Layout: GFZ EnPT
    ``enpt/model/metadata/metadata_sensorgeo.py`` (``base/level``,
    ``product/image/{vnir,swir}/{name,channels,dimension/rows,dimension/columns}``,
    ``specific/bandCharacterisation/bandID`` with ``wavelengthCenterOfBand``, ``FWHMOfBand``,
    ``GainOfBand``, ``OffsetOfBand``, VNIR bands then SWIR bands, ``number`` attribute as
    EnPT reads ``product/navigation/RPC/bandID``); EnMAP-Box ``importenmapl1balgorithm.py``
    (the same four band elements, VNIR first). ``drop`` leaves elements out (damaged files)."""
    n_v, n_s = len(vnir_wl), len(swir_wl)
    wl = np.concatenate([vnir_wl, swir_wl])
    bands = []
    for i in range(n_v + n_s):
        items = {
            "wavelengthCenterOfBand": f"{wl[i]:.3f}",
            "FWHMOfBand": f"{fwhm[i]:.3f}",
            "GainOfBand": f"{gains[i]:.9g}",
            "OffsetOfBand": f"{offsets[i]:.9g}",
        }
        body = "".join(f"<{k}>{v}</{k}>" for k, v in items.items() if k not in drop)
        bands.append(f'<bandID number="{i + 1}">{body}</bandID>')
    det = []
    for d, n in (("vnir", n_v), ("swir", n_s)):
        det.append(
            f"<{d}><name>{name}-SPECTRAL_IMAGE_{d.upper()}.TIF</name><channels>{n}</channels>"
            f"<dimension><rows>{rows}</rows><columns>{cols}</columns></dimension></{d}>"
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<level_X>'
        "<base><level>L1B</level><revision>01.04.00</revision></base>"
        f"<product><image>{''.join(det)}</image></product>"
        f"<specific><bandCharacterisation>{''.join(bands)}</bandCharacterisation></specific>"
        "</level_X>\n"
    )


def _dn(radiance, gains, offsets, dtype, divide=False):
    """DN of ``radiance``: (radiance - offset) / gain, or radiance * gain + offset with
    ``divide`` (PRISMA's DN = (radiance + offset) * scale); checked to fit ``dtype``."""
    g, o = np.asarray(gains)[:, None, None], np.asarray(offsets)[:, None, None]
    dn = np.round((radiance + o) * g if divide else (radiance - o) / g)
    info = np.iinfo(dtype)
    assert dn.min() >= info.min and dn.max() <= info.max, "fixture DN out of range"
    return dn.astype(dtype)


def _write_tif(path, data, nodata=None):
    profile = dict(
        driver="GTiff",
        width=data.shape[2],
        height=data.shape[1],
        count=data.shape[0],
        dtype=str(data.dtype),
        interleave="band",
    )
    if nodata is not None:
        profile["nodata"] = nodata
    with quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        dst.write(data)


def write_enmap_l1b(
    folder,
    zip: bool = False,
    rows: int = 128,
    cols: int = 96,
    shift: int = ENMAP_SHIFT,
    seed: int = 0,
    masked: bool = True,
    damage: str | None = None,
    vnir_wl: np.ndarray = ENMAP_VNIR_WL,
    swir_wl: np.ndarray = ENMAP_SWIR_WL,
) -> Written:
    """An EnMAP L1B product in ``folder`` (or a zip of it with one top folder, as delivered).

    Files (names as GFZ EnPT ``enpt/io/reader.py`` checks them and EnMAP-Box
    ``importenmapl1balgorithm.py`` finds them: ``<product>-METADATA.XML``,
    ``<product>-SPECTRAL_IMAGE_VNIR.TIF``, ``-SPECTRAL_IMAGE_SWIR.TIF``,
    ``-QL_PIXELMASK_VNIR.TIF``, ``-QL_PIXELMASK_SWIR.TIF``); the zip holds
    ``<product>/<product>-...`` (EnMAP-Box ``findSpectralImageFilename``). Images: int16 DN
    (not verified: the real data type; the reader takes it from the file), bands x rows x
    columns, radiance = gain · DN + offset (EnPT ``DN2TOARadiance``). Pixel masks: uint8, the
    image's shape, nonzero = defective (EnPT casts the map to bool, True = dead pixel); here
    column 7 of VNIR band 41 (the band nearest 920 nm) and a few random pixels of every band.
    The SWIR image sees the scene ``shift`` lines later than the VNIR image.

    ``vnir_wl``, ``swir_wl``: the band centres (nm); by default 47 + 62 bands (a real product
    has 91 + 133 over the same ranges).

    ``damage``: "no-wavelengths" (bandID without wavelengthCenterOfBand), "no-swir-image",
    "band-mismatch" (the SWIR TIF has one band less than the XML says).
    """
    folder = str(folder)
    name = ENMAP_NAME
    top = os.path.join(folder, name) if zip else folder
    os.makedirs(top, exist_ok=True)
    vnir_wl, swir_wl = np.asarray(vnir_wl, float), np.asarray(swir_wl, float)
    n_v = len(vnir_wl)
    wl = np.concatenate([vnir_wl, swir_wl])
    fwhm = np.where(wl < 1000, 6.5, 10.0) + 0.001 * np.arange(wl.size)
    gains = 1.2e-4 * (1.0 + 0.3 * np.sin(wl / 150.0))
    offsets = -1.0e-3 * (1.0 + 0.5 * np.cos(wl / 300.0))
    truth = scene(wl, rows, cols, seed=seed, top=shift)
    # VNIR sees scene lines shift..shift+rows, SWIR lines 0..rows: feature at VNIR r -> SWIR r+shift
    rad_v = truth[:n_v, shift : shift + rows]
    rad_s = truth[n_v:, 0:rows]
    dn_v = _dn(rad_v, gains[:n_v], offsets[:n_v], "int16")
    dn_s = _dn(rad_s, gains[n_v:], offsets[n_v:], "int16")
    rng = np.random.default_rng(seed + 7)
    mask_v = np.zeros(dn_v.shape, "uint8")
    mask_s = np.zeros(dn_s.shape, "uint8")
    if masked:
        mask_v[np.argmin(np.abs(vnir_wl - 920)), :, 7] = 1
        for m in (mask_v, mask_s):
            idx = rng.integers(0, m.size, m.size // 500)
            m.flat[idx] = rng.integers(1, 4, idx.size)  # any nonzero value is defective
    with open(os.path.join(top, f"{name}-METADATA.XML"), "w", encoding="utf-8") as f:
        drop = ("wavelengthCenterOfBand",) if damage == "no-wavelengths" else ()
        f.write(_enmap_xml(name, vnir_wl, swir_wl, fwhm, gains, offsets, rows, cols, drop))
    _write_tif(os.path.join(top, f"{name}-SPECTRAL_IMAGE_VNIR.TIF"), dn_v)
    if damage != "no-swir-image":
        _write_tif(
            os.path.join(top, f"{name}-SPECTRAL_IMAGE_SWIR.TIF"),
            dn_s[:-1] if damage == "band-mismatch" else dn_s,
        )
    _write_tif(os.path.join(top, f"{name}-QL_PIXELMASK_VNIR.TIF"), mask_v)
    _write_tif(os.path.join(top, f"{name}-QL_PIXELMASK_SWIR.TIF"), mask_s)
    path = folder
    if zip:
        path = os.path.join(os.path.dirname(folder.rstrip(os.sep)) or ".", f"{name}.ZIP")
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(os.listdir(top)):
                z.write(os.path.join(top, f), f"{name}/{f}")
        shutil.rmtree(folder)
    return Written(
        path,
        vnir_wl.copy(),
        swir_wl.copy(),
        gains[:n_v, None, None] * dn_v + offsets[:n_v, None, None],
        gains[n_v:, None, None] * dn_s + offsets[n_v:, None, None],
        fwhm[:n_v],
        fwhm[n_v:],
        mask_v == 0,
        mask_s == 0,
        {"gains": gains, "offsets": offsets, "shift": shift, "name": name},
    )


# --- PRISMA L1 ---------------------------------------------------------------------------------

#: PRISMA-like slots, DESCENDING as in the product; VNIR: 3 unused slots (centre 0) first,
#: SWIR: 2 unused slots last (a real file: 66 VNIR slots, first 3 zero; 173 SWIR, last 2 zero).
#: (Stored as float32 in the file: the values here are float32-exact.)
PRISMA_VNIR_CW = np.concatenate([np.zeros(3), np.linspace(985.0, 402.0, 40)]).astype("f4") * 1.0
PRISMA_SWIR_CW = np.concatenate([np.linspace(2450.0, 942.0, 50), np.zeros(2)]).astype("f4") * 1.0
PRISMA_NAME = "PRS_L1_STD_OFFL_20200524101500_20200524101504_0001.he5"


def write_prisma_l1(
    path,
    chunked: bool = False,
    lines: int = 96,
    samples: int = 80,
    seed: int = 1,
    scale: float = 100.0,
    offset: float = 0.5,
    damage: str | None = None,
) -> Written:
    """A PRISMA L1 HDF-EOS5 file at ``path``.

    Layout (sister-jpl/sister ``sister/sensors/prisma.py``, EnMAP-Box
    ``importprismal1algorithm.py``, ACOLITE and prismaread read it so):
    ``HDFEOS/SWATHS/PRS_L1_HCO/Data Fields/VNIR_Cube`` and ``SWIR_Cube``, uint16, shape
    (lines, bands, samples); root attributes ``List_Cw_Vnir``/``List_Cw_Swir`` (descending,
    0 = unused slot), ``List_Fwhm_*``, ``List_Cw_*_Flags`` (1 = in use; sister keeps the bands
    whose flag is true), ``ScaleFactor_*`` (100 in a real file) and ``Offset_*`` (0 in a real
    file; 0.5 here so that its sign is tested): radiance = DN / ScaleFactor − Offset (prismaread;
    sister and ACOLITE add the offset instead: the same while it is 0);
    ``HDFEOS/SWATHS/PRS_L1_HCO/Geolocation Fields/Latitude_VNIR``, ``Longitude_VNIR``, float32
    (not verified: the real dtype), (lines, samples). Unused slots hold DN 0.

    ``chunked``: the cubes and coordinates stored chunked with gzip (chunks not aligned with the
    shape), instead of contiguous. ``damage``: "no-vnir-cube", "wavelength-count" (List_Cw_Vnir
    one value short), "no-wavelengths" (no List_Cw_Swir).
    """
    import h5py

    path = str(path)
    rad = {}
    cubes = {}
    truth = scene(
        np.concatenate([PRISMA_VNIR_CW, PRISMA_SWIR_CW]).clip(400.0), lines, samples, seed=seed
    )
    truth *= 40.0  # W m-2 sr-1 um-1
    n_v = PRISMA_VNIR_CW.size
    for det, cw, part in (
        ("VNIR", PRISMA_VNIR_CW, truth[:n_v]),
        ("SWIR", PRISMA_SWIR_CW, truth[n_v:]),
    ):
        dn = _dn(part, [scale] * cw.size, [offset] * cw.size, "uint16", divide=True)
        dn[cw == 0] = 0
        cubes[det] = dn  # (bands, lines, samples)
        rad[det] = dn / scale - offset
    r, c = np.mgrid[0:lines, 0:samples].astype("float32")
    lat = (45.0 - 0.00027 * r + 0.00004 * c).astype("float32")
    lon = (9.0 + 0.00036 * c + 0.00005 * r).astype("float32")
    opts = dict(chunks=True, compression="gzip") if chunked else {}
    with h5py.File(path, "w") as f:
        f.attrs["Processing_Level"] = np.bytes_("1")
        for det, att, cw in (("VNIR", "Vnir", PRISMA_VNIR_CW), ("SWIR", "Swir", PRISMA_SWIR_CW)):
            cw_out = cw[:-1] if (damage == "wavelength-count" and det == "VNIR") else cw
            if not (damage == "no-wavelengths" and det == "SWIR"):
                f.attrs[f"List_Cw_{att}"] = cw_out.astype("float32")
            f.attrs[f"List_Fwhm_{att}"] = np.where(cw > 0, 10.0, 0.0).astype("float32")
            f.attrs[f"List_Cw_{att}_Flags"] = (cw > 0).astype("int8")
            f.attrs[f"ScaleFactor_{att}"] = np.float32(scale)
            f.attrs[f"Offset_{att}"] = np.float32(offset)
            if damage == "no-vnir-cube" and det == "VNIR":
                continue
            bil = np.ascontiguousarray(cubes[det].transpose(1, 0, 2))  # (lines, bands, samples)
            if chunked:
                opts["chunks"] = (32, 8, 40)
            f.create_dataset(f"HDFEOS/SWATHS/PRS_L1_HCO/Data Fields/{det}_Cube", data=bil, **opts)
        geo = "HDFEOS/SWATHS/PRS_L1_HCO/Geolocation Fields"
        gopts = dict(chunks=(32, 40), compression="gzip") if chunked else {}
        f.create_dataset(f"{geo}/Latitude_VNIR", data=lat, **gopts)
        f.create_dataset(f"{geo}/Longitude_VNIR", data=lon, **gopts)
    good_v, good_s = PRISMA_VNIR_CW > 0, PRISMA_SWIR_CW > 0
    return Written(
        path,
        PRISMA_VNIR_CW.copy(),
        PRISMA_SWIR_CW.copy(),
        rad["VNIR"],
        rad["SWIR"],
        np.where(good_v, 10.0, 0.0),
        np.where(good_s, 10.0, 0.0),
        extra={"lat": lat, "lon": lon, "scale": scale, "offset": offset},
    )
