"""Writing a simulated jittered line with its true IGM and orthophoto
(:class:`geoboresight.simulate.ortho.OrthoScene`) to a folder, whole or not at all.

Files: ``raw.img/.hdr`` (ENVI float32, one band with its wavelength, raw geometry: no CRS),
``igm.img/.hdr`` (ENVI float64: easting, northing, height of each raw pixel's centre; its CRS
in the header, as an IGM carries it), ``orthophoto.tif`` (float32 GeoTIFF, red, green, blue,
NIR with wavelengths, north-up in the scene's CRS), ``corners.txt`` (the true map coordinates
of the four image corners, for a rough placement: top-left, top-right, bottom-right,
bottom-left), ``attitude.csv`` (line, roll, pitch, yaw in degrees) and ``truth.json``.
"""

from __future__ import annotations

import json
import os

import numpy as np

from ..errors import OutputError
from .grid import Grid
from .raster import quiet_georef, write_envi, write_raster
from .scene import _fix_envi_description
from .write import atomic_output

ORTHO_SCENE_FILES = (
    "raw.img",
    "raw.hdr",
    "igm.img",
    "igm.hdr",
    "orthophoto.tif",
    "corners.txt",
    "attitude.csv",
    "truth.json",
)


def true_corners(igm: np.ndarray) -> np.ndarray:
    """(4, 2) map coordinates of the image's outer corners (top-left, top-right,
    bottom-right, bottom-left), extrapolated half a pixel beyond the corner pixels' centres."""
    x, y = igm[0], igm[1]
    out = []
    for i, j, di, dj in ((0, 0, 1, 1), (0, -1, 1, -2), (-1, -1, -2, -2), (-1, 0, -2, 1)):
        # corner = centre - half a step along the line and half a step along the track
        step_c = np.array([x[i, dj] - x[i, j], y[i, dj] - y[i, j]])
        step_l = np.array([x[di, j] - x[i, j], y[di, j] - y[i, j]])
        out.append(np.array([x[i, j], y[i, j]]) - 0.5 * step_c - 0.5 * step_l)
    return np.array(out)


def write_ortho_scene(scene, folder, overwrite: bool = False) -> list[str]:
    """Write ``scene`` to ``folder`` (created, atomically); the file names written."""
    import rasterio
    from rasterio.crs import CRS

    folder = os.fspath(folder)
    if os.path.lexists(folder) and not overwrite:
        raise OutputError(
            f"output folder {folder} already exists: pass overwrite=True to replace it",
            params=("overwrite",),
        )
    crs = CRS.from_user_input(scene.crs)
    # An existing folder is replaced only if it holds nothing but these files (never emptied).
    with (
        atomic_output(folder, overwrite=overwrite, folder_files=ORTHO_SCENE_FILES) as tmp,
        rasterio.Env(GDAL_PAM_ENABLED="NO"),
    ):
        os.makedirs(tmp)
        write_envi(
            os.path.join(tmp, "raw.img"),
            scene.raw[None].astype("float32"),
            [scene.band_nm],
            description="simulated raw line with attitude jitter (geoboresight)",
        )
        with (
            quiet_georef(),
            rasterio.open(
                os.path.join(tmp, "igm.img"),
                "w",
                driver="ENVI",
                width=scene.igm.shape[2],
                height=scene.igm.shape[1],
                count=3,
                dtype="float64",
                crs=crs,
            ) as dst,
        ):
            dst.write(scene.igm)
            for b, name in enumerate(("easting", "northing", "height"), start=1):
                dst.set_band_description(b, name)
        for name, text in (("raw", "simulated raw line with attitude jitter"), ("igm", "true IGM")):
            _fix_envi_description(os.path.join(tmp, f"{name}.hdr"), f"{text} (geoboresight)")
        from rasterio.transform import Affine

        write_raster(
            os.path.join(tmp, "orthophoto.tif"),
            scene.ortho,
            Grid(scene.ortho.shape[2], scene.ortho.shape[1], crs, Affine(*scene.ortho_transform)),
            nodata=None,
            tags={"product": "simulated orthophoto (true ortho)"},
            band_names=[f"{w:.0f} nm" for w in scene.ortho_nm],
            band_tags=[
                {"wavelength": f"{w:.1f}", "wavelength_units": "nm"} for w in scene.ortho_nm
            ],
        )
        corners = true_corners(scene.igm)
        with open(os.path.join(tmp, "corners.txt"), "w", encoding="utf-8") as f:
            f.write(",".join(f"{v:.3f}" for v in corners.ravel()) + "\n")
        with open(os.path.join(tmp, "attitude.csv"), "w", encoding="utf-8") as f:
            f.write("line,roll_deg,pitch_deg,yaw_deg\n")
            for t, (r, p, y) in enumerate(scene.attitude.T):
                f.write(f"{t},{r:.6f},{p:.6f},{y:.6f}\n")
        with open(os.path.join(tmp, "truth.json"), "w", encoding="utf-8") as f:
            json.dump(scene.truth, f, indent=2)
    return list(ORTHO_SCENE_FILES)
