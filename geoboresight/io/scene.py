"""The simulator's files: a simulated scene (:class:`geoboresight.simulate.Scene`) written to a
folder, whole or not at all.

Files: ``vnir.img/.hdr`` and ``swir.img/.hdr`` (ENVI, BIL, uint16 DN, wavelengths and FWHM in
nm, raw geometry), optionally ``merged.img/.hdr`` (all 198 bands), the truth rasters on the VNIR
grid as GeoTIFF (``truth_dsm.tif``, ``truth_shadow_fraction.tif``,
``truth_target_abundance.tif``, ``truth_cloud_mask.tif``, ``truth_material.tif`` with a colour
table and class names in its tags), ``truth.json`` and ``endmembers.csv`` (``wavelength_nm``,
``fwhm_nm`` + one reflectance column per material). With the scene's navigation
(:mod:`geoboresight.simulate.navigation`): ``igm.tif`` (float64 easting and northing of each
VNIR pixel, to the centimetre, its CRS in the header, raw geometry) and ``ortho.tif`` (an RGB
uint8 orthophoto, JPEG-compressed, north-up in that CRS, cells beyond the simulated ground in
its internal mask). The same scene always gives
the same bytes.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np

from ..errors import OutputError
from .raster import write_envi, write_raster
from .write import atomic_output, check_folder_replaceable

#: Colours of the material classes in truth_material.tif (QGIS shows the colour table).
MATERIAL_COLOURS = {
    0: (0, 0, 0, 0),
    1: (60, 60, 60, 255),
    2: (190, 190, 180, 255),
    3: (140, 70, 50, 255),
    4: (200, 110, 70, 255),
    5: (150, 170, 200, 255),
    6: (160, 120, 80, 255),
    7: (100, 75, 50, 255),
    8: (230, 210, 150, 255),
    9: (120, 190, 80, 255),
    10: (30, 110, 40, 255),
    11: (180, 160, 100, 255),
    12: (150, 140, 130, 255),
    13: (255, 0, 255, 255),
    14: (255, 255, 255, 255),
}

#: The files every scene folder holds (``merged.img/.hdr`` only when asked for).
SCENE_FILES = (
    "vnir.img",
    "vnir.hdr",
    "swir.img",
    "swir.hdr",
    "truth_dsm.tif",
    "truth_shadow_fraction.tif",
    "truth_target_abundance.tif",
    "truth_cloud_mask.tif",
    "truth_material.tif",
    "truth.json",
    "endmembers.csv",
)
#: Every name a scene folder may hold: an existing folder with anything else is never replaced.
#: The scene's navigation (``simulate --navigation``).
NAVIGATION_FILES = ("igm.tif", "ortho.tif")
#: The raw capture of both detectors and its calibration (``simulate --capture``).
CAPTURE_FILES = ("capture.raw", "capture.hdr", "capture_cal.cal", "capture_cal.hdr")
SCENE_FOLDER_FILES = (
    *SCENE_FILES,
    "merged.img",
    "merged.hdr",
    *NAVIGATION_FILES,
    *CAPTURE_FILES,
)


def check_scene_folder(folder) -> None:
    """Raise :class:`OutputError` if ``folder`` exists and holds files that no scene writes
    (the user's own files): a scene replaces only a folder of scene files."""
    check_folder_replaceable(os.fspath(folder), SCENE_FOLDER_FILES)


def write_scene(
    scene,
    folder,
    merged: bool = False,
    overwrite: bool = False,
    navigation=None,
    capture=None,
) -> str:
    """Write ``scene`` to ``folder`` (created; written whole or not at all); ``folder``.

    ``merged=True`` also writes ``merged.img/.hdr`` with all 198 bands; ``navigation`` (a
    :class:`geoboresight.simulate.navigation.Navigation`) writes ``igm.tif`` and ``ortho.tif``
    and records the map placement in ``truth.json``; ``capture`` (a
    :class:`geoboresight.simulate.capture.Capture`) writes the raw capture and its calibration
    (:func:`write_capture`). An existing folder is replaced only with
    ``overwrite=True``.
    """
    import rasterio

    folder = os.fspath(folder)
    if os.path.lexists(folder) and not overwrite:
        raise OutputError(
            f"output folder {folder} already exists: choose another folder, or pass "
            "overwrite=True to replace it",
            params=("overwrite",),
        )
    parent = os.path.dirname(os.path.abspath(folder))
    if not os.path.isdir(parent):
        raise OutputError(
            f"output folder {folder}: its parent {parent} does not exist; create it first"
        )
    # The ENVI headers hold wavelengths, FWHM and band names: no redundant .aux.xml sidecars
    # (which GDAL applications would rewrite when they open the scene).
    with (
        atomic_output(folder, overwrite=overwrite, folder_files=SCENE_FOLDER_FILES) as tmp,
        rasterio.Env(GDAL_PAM_ENABLED="NO"),
    ):
        os.makedirs(tmp)
        write_cubes(scene, tmp, merged=merged)
        if capture is not None:
            write_capture(capture, scene, tmp)
        write_truth_rasters(scene, tmp)
        truth = scene.truth
        if navigation is not None:
            write_navigation(navigation, tmp)
            truth = {**truth, "navigation": navigation.truth}
        write_truth_json(truth, os.path.join(tmp, "truth.json"))
        write_endmembers(scene, os.path.join(tmp, "endmembers.csv"))
    return folder


def write_cubes(scene, folder: str, merged: bool = False) -> None:
    """``vnir.img/.hdr``, ``swir.img/.hdr`` and optionally ``merged.img/.hdr`` in ``folder``
    (ENVI BIL uint16 DN; noise-free scenes are rounded to 12 bits)."""
    truth = scene.truth
    desc = f"geoboresight simulate preset={truth['preset']} seed={truth['seed']}"
    vnir, swir = as_dn(scene.vnir), as_dn(scene.swir)
    cubes = [
        ("vnir", vnir, scene.vnir_wavelengths, scene.vnir_fwhm, "VNIR"),
        ("swir", swir, scene.swir_wavelengths, scene.swir_fwhm, "SWIR"),
    ]
    if merged:
        both = np.concatenate([vnir, swir]).astype(vnir.dtype, copy=False)
        cubes.append(("merged", both, scene.wavelengths, scene.fwhm, "VNIR+SWIR"))
    for name, cube, wavelengths, fwhm, label in cubes:
        write_envi(
            os.path.join(folder, f"{name}.img"),
            cube,
            wavelengths,
            fwhm,
            description=f"{desc} {label}",
        )
        _fix_envi_description(os.path.join(folder, f"{name}.hdr"), f"{desc} {label}")


def write_capture(capture, scene, folder: str) -> None:
    """``capture.raw/.hdr``: a raw capture of both detectors in one file
    (:class:`geoboresight.simulate.capture.Capture`: the VNIR bands, ``vimg1``, at ``tint1``; the
    SWIR bands at ``tint2``), with its Specim header, dark frames after the image and a frame
    counter in band 1, sample 0; and ``capture_cal.cal/.hdr``, its radiometric calibration in
    the layout of Specim's calibration packs (float32 BIL, one line of bands × samples)."""
    raw, nv = capture.raw, capture.n_vnir
    ns_b, samples = raw.shape[1] - nv, raw.shape[2]
    raw.astype("<u2").tofile(os.path.join(folder, "capture.raw"))
    wl = np.asarray(scene.wavelengths, float)
    fwhm = np.asarray(scene.fwhm, float)
    t1, t2 = capture.tints_ms
    common = [
        f"samples = {samples}",
        f"bands = {nv + ns_b}",
        "header offset = 0",
        "interleave = bil",
        "byte order = 0",
        f"sensorid = {capture.sensorid}",
        "binning = {1, 1}",
        f"tint1 = {t1:g}",
        f"tint2 = {t2:g}",
        f"vimg1 = {{1, {nv}}}",
        f"vimg2 = {{{nv + 1}, {nv + ns_b}}}",
        "wavelength units = Nanometers",
        "wavelength = {" + ", ".join(f"{w:.2f}" for w in wl) + "}",
        "fwhm = {" + ", ".join(f"{w:.2f}" for w in fwhm) + "}",
    ]
    desc = f"geoboresight simulate preset={scene.truth['preset']} seed={scene.truth['seed']}"
    with open(os.path.join(folder, "capture.hdr"), "w", encoding="utf-8", newline="\n") as f:
        f.write(
            "\n".join(
                ["ENVI", f"description = {{{desc} raw capture}}", f"lines = {raw.shape[0]}"]
                + ["data type = 12", f"autodarkstartline = {capture.lines}", "fps = 25"]
                + common
            )
            + "\n"
        )
    capture.gain.astype("<f4").tofile(os.path.join(folder, "capture_cal.cal"))
    with open(os.path.join(folder, "capture_cal.hdr"), "w", encoding="utf-8", newline="\n") as f:
        f.write(
            "\n".join(
                ["ENVI", f"description = {{{desc} radiometric calibration}}", "lines = 1"]
                + ["data type = 4"]
                + common
            )
            + "\n"
        )


def write_truth_rasters(scene, folder: str) -> None:
    """The truth GeoTIFFs on the VNIR pixel grid (raw geometry) in ``folder``."""
    truth = scene.truth
    tags = {
        "preset": truth["preset"],
        "seed": truth["seed"],
        "grid": "VNIR pixel grid (raw geometry)",
    }
    continuous = (
        ("dsm", scene.dsm, "float32", {"units": "m above the lowest ground"}, "dsm_m"),
        ("shadow_fraction", scene.shadow_fraction, "float32", {}, "shadow_fraction"),
        ("target_abundance", scene.target_abundance, "float32", {}, "target_abundance"),
        ("cloud_mask", scene.cloud_mask, "uint8", {}, "cloud_mask"),
    )
    for name, array, dtype, extra, band in continuous:
        write_raster(
            os.path.join(folder, f"truth_{name}.tif"),
            array.astype(dtype),
            nodata=None,
            dtype=dtype,
            tags={**tags, **extra},
            band_names=[band],
        )
    classes = {f"CLASS_{k}": v for k, v in scene.material_names.items()}
    write_raster(
        os.path.join(folder, "truth_material.tif"),
        scene.material.astype("uint8"),
        nodata=0,
        dtype="uint8",
        tags={**tags, **classes},
        band_names=["material"],
        band_tags=[classes],
        colormap=MATERIAL_COLOURS,
    )


def write_navigation(nav, folder: str) -> None:
    """``igm.tif`` and ``ortho.tif`` of a scene's navigation in ``folder``."""
    import rasterio
    from rasterio.crs import CRS
    from rasterio.transform import Affine

    from .georef import write_igm

    crs = CRS.from_user_input(nav.crs)
    igm = np.round(nav.igm, 2)  # centimetres: the rest is noise to the compressor
    write_igm(
        os.path.join(folder, "igm.tif"),
        igm[0],
        igm[1],
        crs,
        {"product": "simulated IGM: map coordinates of each VNIR pixel's mean ground point"},
    )
    bands, ny, nx = nav.ortho.shape
    profile = {
        "driver": "GTiff",
        "width": nx,
        "height": ny,
        "count": bands,
        "dtype": "uint8",
        "crs": crs,
        "transform": Affine(*nav.ortho_transform),
        "tiled": True,
        "blockxsize": 256,
        "blockysize": 256,
        # An orthophoto as agencies ship them: JPEG in YCbCr (a tenth of deflate's size).
        "compress": "jpeg",
        "photometric": "ycbcr",
        "jpeg_quality": 90,
        "interleave": "pixel",
    }
    # A JPEG's values are approximate: the cells beyond the ground are in a mask (deflated, exact),
    # not a nodata value that dark shadows could decode to.
    with (
        rasterio.Env(GDAL_TIFF_INTERNAL_MASK=True),
        rasterio.open(os.path.join(folder, "ortho.tif"), "w", **profile) as dst,
    ):
        dst.write(nav.ortho)
        dst.write_mask(np.where(nav.ortho_valid, 255, 0).astype("uint8"))
        dst.update_tags(product="simulated orthophoto (true ortho, no cloud)")
        for b, name in enumerate(("red", "green", "blue"), start=1):
            dst.set_band_description(b, name)


def write_truth_json(truth: dict, path: str) -> None:
    """``truth.json``: indented, keys in the scene's order, ending with a newline."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=2, sort_keys=False)
        f.write("\n")


def write_endmembers(scene, path: str) -> None:
    """``endmembers.csv``: ``wavelength_nm``, ``fwhm_nm`` and one reflectance column per
    material (the scene's abundance names), one row per band."""
    names = list(scene.abundance_names)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write(",".join(["wavelength_nm", "fwhm_nm", *names]) + "\n")
        for b, (wl, fw) in enumerate(zip(scene.wavelengths, scene.fwhm, strict=True)):
            vals = [f"{scene.endmember_spectra[n][b]:.6f}" for n in names]
            f.write(",".join([f"{wl:.3f}", f"{fw:.3f}", *vals]) + "\n")


def _fix_envi_description(hdr: str, text: str) -> None:
    """Replace GDAL's ENVI ``description`` (the temporary file's path) by ``text``.

    Keeps the header free of machine-specific paths, so that the same seed gives the same bytes.
    """
    with open(hdr, encoding="utf-8") as f:
        content = f.read()
    content = re.sub(r"description = \{[^}]*\}", "description = {" + text + "}", content, count=1)
    with open(hdr, "w", encoding="utf-8", newline="\n") as f:
        f.write(content)


def as_dn(cube: np.ndarray) -> np.ndarray:
    """uint16 DN: noise-free (float) cubes are rounded and clipped to 12 bits."""
    if cube.dtype == np.uint16:
        return cube
    return np.clip(np.rint(cube), 0, 4095).astype("uint16")


__all__ = [
    "CAPTURE_FILES",
    "MATERIAL_COLOURS",
    "NAVIGATION_FILES",
    "SCENE_FILES",
    "as_dn",
    "write_capture",
    "write_cubes",
    "write_endmembers",
    "write_navigation",
    "write_scene",
    "write_truth_json",
    "write_truth_rasters",
]
