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
#: (about 20 px: EnPT issue #12): a feature at VNIR line r is at SWIR line r + 20.
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

    ``damage``: "no-wavelengths" (bandID without wavelengthCenterOfBand), "no-swir-image",
    "band-mismatch" (the SWIR TIF has one band less than the XML says).
    """
    folder = str(folder)
    name = ENMAP_NAME
    top = os.path.join(folder, name) if zip else folder
    os.makedirs(top, exist_ok=True)
    n_v = len(ENMAP_VNIR_WL)
    wl = np.concatenate([ENMAP_VNIR_WL, ENMAP_SWIR_WL])
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
        mask_v[np.argmin(np.abs(ENMAP_VNIR_WL - 920)), :, 7] = 1
        for m in (mask_v, mask_s):
            idx = rng.integers(0, m.size, m.size // 500)
            m.flat[idx] = rng.integers(1, 4, idx.size)  # any nonzero value is defective
    with open(os.path.join(top, f"{name}-METADATA.XML"), "w", encoding="utf-8") as f:
        drop = ("wavelengthCenterOfBand",) if damage == "no-wavelengths" else ()
        f.write(
            _enmap_xml(name, ENMAP_VNIR_WL, ENMAP_SWIR_WL, fwhm, gains, offsets, rows, cols, drop)
        )
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
        ENMAP_VNIR_WL.copy(),
        ENMAP_SWIR_WL.copy(),
        gains[:n_v, None, None] * dn_v + offsets[:n_v, None, None],
        gains[n_v:, None, None] * dn_s + offsets[n_v:, None, None],
        fwhm[:n_v],
        fwhm[n_v:],
        mask_v == 0,
        mask_s == 0,
        {"gains": gains, "offsets": offsets, "shift": shift, "name": name},
    )
